#include "vslam/map_io/sqlite_database.hpp"

#include <filesystem>

#include <sqlite3.h>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

constexpr int kMaxReadValueBytes = 1 << 20;

// SQLite's messages may quote a damaged schema, newlines included: an error stays one line.
std::string oneLine(std::string message) {
  for (char& c : message)
    if (c == '\n' || c == '\r') c = ' ';
  return message;
}

}  // namespace

SqliteStatement::SqliteStatement(sqlite3* database, const std::string& path, const std::string& sql)
    : database_(database), path_(path) {
  if (sqlite3_prepare_v2(database_, sql.c_str(), -1, &statement_, nullptr) != SQLITE_OK) {
    const std::string reason = oneLine(sqlite3_errmsg(database_));
    sqlite3_finalize(statement_);
    statement_ = nullptr;
    throw InputError(path_, 0, "SQLite: " + reason);
  }
}

SqliteStatement::~SqliteStatement() { sqlite3_finalize(statement_); }

SqliteStatement::SqliteStatement(SqliteStatement&& other) noexcept
    : database_(other.database_), path_(std::move(other.path_)), statement_(other.statement_) {
  other.statement_ = nullptr;
}

void SqliteStatement::fail(const std::string& what) const {
  throw InputError(path_, 0, "SQLite: " + what + ": " + oneLine(sqlite3_errmsg(database_)));
}

SqliteStatement& SqliteStatement::bind(int index, long long value) {
  if (sqlite3_bind_int64(statement_, index, value) != SQLITE_OK) fail("bind");
  return *this;
}

SqliteStatement& SqliteStatement::bind(int index, double value) {
  if (sqlite3_bind_double(statement_, index, value) != SQLITE_OK) fail("bind");
  return *this;
}

SqliteStatement& SqliteStatement::bind(int index, const std::string& text) {
  if (sqlite3_bind_text(statement_, index, text.c_str(), static_cast<int>(text.size()), SQLITE_TRANSIENT) != SQLITE_OK)
    fail("bind");
  return *this;
}

SqliteStatement& SqliteStatement::bindBlob(int index, const void* data, size_t size) {
  if (sqlite3_bind_blob(statement_, index, data, static_cast<int>(size), SQLITE_TRANSIENT) != SQLITE_OK) fail("bind");
  return *this;
}

SqliteStatement& SqliteStatement::bindNull(int index) {
  if (sqlite3_bind_null(statement_, index) != SQLITE_OK) fail("bind");
  return *this;
}

bool SqliteStatement::step() {
  const int status = sqlite3_step(statement_);
  if (status == SQLITE_ROW) return true;
  if (status == SQLITE_DONE) return false;
  fail("step");
}

void SqliteStatement::run() {
  while (step()) {
  }
  reset();
}

void SqliteStatement::reset() {
  sqlite3_reset(statement_);
  sqlite3_clear_bindings(statement_);
}

bool SqliteStatement::isNull(int column) const { return sqlite3_column_type(statement_, column) == SQLITE_NULL; }
long long SqliteStatement::integer(int column) const { return sqlite3_column_int64(statement_, column); }
double SqliteStatement::real(int column) const { return sqlite3_column_double(statement_, column); }

std::string SqliteStatement::text(int column) const {
  const unsigned char* value = sqlite3_column_text(statement_, column);
  return value ? std::string(reinterpret_cast<const char*>(value), sqlite3_column_bytes(statement_, column))
               : std::string();
}

std::vector<uint8_t> SqliteStatement::blob(int column) const {
  const auto* data = static_cast<const uint8_t*>(sqlite3_column_blob(statement_, column));
  const int size = sqlite3_column_bytes(statement_, column);
  return data ? std::vector<uint8_t>(data, data + size) : std::vector<uint8_t>();
}

SqliteDatabase::SqliteDatabase(const std::string& path, Access access) : path_(path) {
  // SQLite would create a missing file even to read it: say it is missing instead.
  if (access == Access::ReadOnly && !std::filesystem::is_regular_file(path))
    throw InputError(path, 0, "no such map file");
  const int flags = access == Access::ReadOnly ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
  if (sqlite3_open_v2(path.c_str(), &database_, flags, nullptr) != SQLITE_OK) {
    const std::string reason = database_ ? oneLine(sqlite3_errmsg(database_)) : "out of memory";
    sqlite3_close(database_);
    database_ = nullptr;
    throw InputError(path, 0, "SQLite cannot open it: " + reason);
  }
  // A file's schema may compute a column (`descriptor BLOB AS (zeroblob(900000000))`):
  // SQLite would build each such value, up to 1 GB, and we would copy it. A map's
  // longest value is a file path; a larger one is SQLite's "string or blob too big".
  if (access == Access::ReadOnly) sqlite3_limit(database_, SQLITE_LIMIT_LENGTH, kMaxReadValueBytes);
#ifdef SQLITE_DBCONFIG_TRUSTED_SCHEMA
  // A file's schema is not ours to trust: functions it names run only when
  // SQLite deems them harmless. An older library refuses the option; then the
  // map loader's own schema check is what stands.
  if (access == Access::ReadOnly) sqlite3_db_config(database_, SQLITE_DBCONFIG_TRUSTED_SCHEMA, 0, nullptr);
#endif
}

SqliteDatabase::~SqliteDatabase() { sqlite3_close(database_); }

void SqliteDatabase::execute(const std::string& sql) {
  char* message = nullptr;
  if (sqlite3_exec(database_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string reason = oneLine(message ? message : sqlite3_errmsg(database_));
    sqlite3_free(message);
    throw InputError(path_, 0, "SQLite: " + reason);
  }
}

long long SqliteDatabase::queryInteger(const std::string& sql) {
  SqliteStatement statement = prepare(sql);
  if (!statement.step()) throw InputError(path_, 0, "SQLite: no result for " + sql);
  return statement.integer(0);
}

bool SqliteDatabase::hasTable(const std::string& name) {
  SqliteStatement statement = prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?");
  statement.bind(1, name);
  return statement.step();
}

}  // namespace vslam
