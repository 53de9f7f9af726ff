#pragma once
// What the map-file tests compare: a saved map's rows.
#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "vslam/map_io/sqlite_database.hpp"

namespace vslam::test {

// Every row of every table of a map file as text, sorted per table (quote()
// prints every digit of a REAL and BLOBs in hex), leaving out the map_info
// rows whose key is in `skipped_info_keys`: "the same rows" of a round trip.
inline std::map<std::string, std::vector<std::string>> mapFileRows(const std::string& path,
                                                                   const std::set<std::string>& skipped_info_keys = {}) {
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  std::vector<std::string> tables;
  {
    SqliteStatement names = db.prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name");
    while (names.step()) tables.push_back(names.text(0));
  }
  std::map<std::string, std::vector<std::string>> rows;
  for (const std::string& table : tables) {
    SqliteStatement columns = db.prepare("SELECT name FROM pragma_table_info('" + table + "')");
    std::string select;
    while (columns.step()) select += (select.empty() ? "" : " || '|' || ") + ("quote(" + columns.text(0) + ")");
    std::string where;
    if (table == "map_info" && !skipped_info_keys.empty()) {
      for (const std::string& key : skipped_info_keys) where += (where.empty() ? "" : ", ") + ("'" + key + "'");
      where = " WHERE key NOT IN (" + where + ")";
    }
    SqliteStatement all = db.prepare("SELECT " + select + " FROM " + table + where);
    while (all.step()) rows[table].push_back(all.text(0));
    std::sort(rows[table].begin(), rows[table].end());
  }
  return rows;
}

}  // namespace vslam::test
