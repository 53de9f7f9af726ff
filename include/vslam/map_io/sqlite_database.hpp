#pragma once
// A thin RAII layer over SQLite's C API (Debian's libsqlite3) for saved maps:
// one open database file and its prepared statements. Every SQLite error
// becomes an InputError naming the database file and SQLite's reason, so a
// corrupt or foreign file is refused with one line, never a crash.
#include <cstdint>
#include <string>
#include <vector>

struct sqlite3;
struct sqlite3_stmt;

namespace vslam {

class SqliteStatement {
 public:
  SqliteStatement(sqlite3* database, const std::string& path, const std::string& sql);
  ~SqliteStatement();
  SqliteStatement(SqliteStatement&& other) noexcept;
  SqliteStatement(const SqliteStatement&) = delete;
  SqliteStatement& operator=(const SqliteStatement&) = delete;
  SqliteStatement& operator=(SqliteStatement&&) = delete;

  // Parameters are numbered from 1, as in SQL's "?".
  SqliteStatement& bind(int index, long long value);
  SqliteStatement& bind(int index, double value);
  SqliteStatement& bind(int index, const std::string& text);
  SqliteStatement& bindBlob(int index, const void* data, size_t size);
  SqliteStatement& bindNull(int index);
  // Runs one step: true when a row is ready, false when the statement is done.
  bool step();
  // Runs a statement that returns no row, then resets it for the next bindings.
  void run();
  void reset();

  // Columns are numbered from 0.
  bool isNull(int column) const;
  long long integer(int column) const;
  double real(int column) const;
  std::string text(int column) const;
  std::vector<uint8_t> blob(int column) const;

 private:
  [[noreturn]] void fail(const std::string& what) const;
  sqlite3* database_;
  std::string path_;
  sqlite3_stmt* statement_ = nullptr;
};

class SqliteDatabase {
 public:
  enum class Access { ReadOnly, Create };
  // ReadOnly: the file must exist (a missing one is an InputError);
  // Create: created when missing, opened for writing.
  SqliteDatabase(const std::string& path, Access access);
  ~SqliteDatabase();
  SqliteDatabase(const SqliteDatabase&) = delete;
  SqliteDatabase& operator=(const SqliteDatabase&) = delete;

  void execute(const std::string& sql);
  SqliteStatement prepare(const std::string& sql) { return SqliteStatement(database_, path_, sql); }
  // The single integer (or text) a query such as "SELECT COUNT(*) FROM t" returns.
  long long queryInteger(const std::string& sql);
  bool hasTable(const std::string& name);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  sqlite3* database_ = nullptr;
};

}  // namespace vslam
