#include "vslam/map_io/map_database.hpp"

#include <cinttypes>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"
#include "vslam/feature/matcher.hpp"
#include "vslam/feature/orb_extractor.hpp"
#include "vslam/io/atomic_file.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/sqlite_database.hpp"

namespace vslam {
namespace {

constexpr int kDescriptorBytes = 32;

// Schema version 1 (docs/MAPS.md). Poses are stored as the 12 numbers of
// T_cw (row-major R, then t) rather than a quaternion, so that a map read
// back and saved again gives the same rows, bit for bit.
constexpr const char* kSchema = R"sql(
CREATE TABLE map_info(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE camera(name TEXT NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  fx REAL NOT NULL, fy REAL NOT NULL, cx REAL NOT NULL, cy REAL NOT NULL,
  k1 REAL NOT NULL, k2 REAL NOT NULL, p1 REAL NOT NULL, p2 REAL NOT NULL, k3 REAL NOT NULL,
  bf REAL NOT NULL, fps REAL NOT NULL, depth_factor REAL NOT NULL, th_depth REAL NOT NULL, max_depth_m REAL NOT NULL);
CREATE TABLE classes(class_id INTEGER PRIMARY KEY, name TEXT NOT NULL);
CREATE TABLE keyframes(id INTEGER PRIMARY KEY, frame_id INTEGER NOT NULL, frame_index INTEGER NOT NULL,
  timestamp REAL NOT NULL,
  r00 REAL NOT NULL, r01 REAL NOT NULL, r02 REAL NOT NULL,
  r10 REAL NOT NULL, r11 REAL NOT NULL, r12 REAL NOT NULL,
  r20 REAL NOT NULL, r21 REAL NOT NULL, r22 REAL NOT NULL,
  tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  parent_id INTEGER REFERENCES keyframes(id), not_erase INTEGER NOT NULL,
  keypoint_count INTEGER NOT NULL, has_depth INTEGER NOT NULL);
CREATE TABLE keypoints(keyframe_id INTEGER NOT NULL REFERENCES keyframes(id), idx INTEGER NOT NULL,
  x REAL NOT NULL, y REAL NOT NULL, undistorted_x REAL NOT NULL, undistorted_y REAL NOT NULL,
  size REAL NOT NULL, angle REAL NOT NULL, response REAL NOT NULL, octave INTEGER NOT NULL,
  class_id INTEGER NOT NULL, detection_id INTEGER NOT NULL,
  red INTEGER NOT NULL, green INTEGER NOT NULL, blue INTEGER NOT NULL,
  depth REAL, u_right REAL, descriptor BLOB NOT NULL,
  PRIMARY KEY(keyframe_id, idx)) WITHOUT ROWID;
CREATE TABLE bow_words(keyframe_id INTEGER NOT NULL REFERENCES keyframes(id), word_id INTEGER NOT NULL,
  weight REAL NOT NULL, PRIMARY KEY(keyframe_id, word_id)) WITHOUT ROWID;
CREATE TABLE bow_features(keyframe_id INTEGER NOT NULL REFERENCES keyframes(id), node_id INTEGER NOT NULL,
  idx INTEGER NOT NULL, PRIMARY KEY(keyframe_id, node_id, idx)) WITHOUT ROWID;
CREATE TABLE map_points(id INTEGER PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  reference_keyframe_id INTEGER NOT NULL REFERENCES keyframes(id), first_keyframe_id INTEGER NOT NULL,
  descriptor BLOB, normal_x REAL NOT NULL, normal_y REAL NOT NULL, normal_z REAL NOT NULL,
  min_distance REAL NOT NULL, max_distance REAL NOT NULL, visible INTEGER NOT NULL, found INTEGER NOT NULL,
  class_id INTEGER NOT NULL, class_confidence REAL NOT NULL,
  red INTEGER NOT NULL, green INTEGER NOT NULL, blue INTEGER NOT NULL, confirmed_min_observations INTEGER NOT NULL);
CREATE TABLE observations(map_point_id INTEGER NOT NULL REFERENCES map_points(id),
  keyframe_id INTEGER NOT NULL REFERENCES keyframes(id), idx INTEGER NOT NULL,
  PRIMARY KEY(map_point_id, keyframe_id)) WITHOUT ROWID;
CREATE INDEX observations_by_keyframe ON observations(keyframe_id, idx);
CREATE TABLE covisibility(keyframe_id INTEGER NOT NULL REFERENCES keyframes(id),
  other_id INTEGER NOT NULL REFERENCES keyframes(id), weight INTEGER NOT NULL,
  PRIMARY KEY(keyframe_id, other_id)) WITHOUT ROWID;
CREATE TABLE loop_edges(keyframe_id INTEGER NOT NULL REFERENCES keyframes(id),
  other_id INTEGER NOT NULL REFERENCES keyframes(id), PRIMARY KEY(keyframe_id, other_id)) WITHOUT ROWID;
CREATE TABLE objects(id INTEGER PRIMARY KEY, class_id INTEGER NOT NULL, class_name TEXT NOT NULL,
  confidence REAL NOT NULL, centroid_x REAL NOT NULL, centroid_y REAL NOT NULL, centroid_z REAL NOT NULL,
  box_min_x REAL NOT NULL, box_min_y REAL NOT NULL, box_min_z REAL NOT NULL,
  box_max_x REAL NOT NULL, box_max_y REAL NOT NULL, box_max_z REAL NOT NULL);
CREATE TABLE object_points(object_id INTEGER NOT NULL REFERENCES objects(id), map_point_id INTEGER NOT NULL,
  rejected INTEGER NOT NULL, PRIMARY KEY(object_id, map_point_id)) WITHOUT ROWID;
CREATE TABLE object_keyframes(object_id INTEGER NOT NULL REFERENCES objects(id), keyframe_id INTEGER NOT NULL,
  PRIMARY KEY(object_id, keyframe_id)) WITHOUT ROWID;
CREATE TABLE object_merged_classes(object_id INTEGER NOT NULL REFERENCES objects(id), class_name TEXT NOT NULL,
  PRIMARY KEY(object_id, class_name)) WITHOUT ROWID;
)sql";

// The writer's own schema in a database of its own: what a map file's tables
// are compared with, so that no second copy of the columns can drift from it.
class ExpectedSchema {
 public:
  ExpectedSchema() : db_(":memory:", SqliteDatabase::Access::Create) { db_.execute(kSchema); }
  SqliteDatabase& db() { return db_; }
  // Our tables, in the order the writer creates them.
  std::vector<std::string> tables() {
    std::vector<std::string> names;
    SqliteStatement rows = db_.prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY rowid");
    while (rows.step()) names.push_back(rows.text(0));
    return names;
  }

 private:
  SqliteDatabase db_;
};

std::string nowUtc() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

SensorMode parseMode(const std::string& path, const std::string& text) {
  if (text == "mono") return SensorMode::Monocular;
  if (text == "rgbd") return SensorMode::RgbD;
  throw InputError(path, 0, "map_info mode is '" + text + "', not mono or rgbd");
}

void writeSchemaAndHeader(SqliteDatabase& db, const MapFileHeader& header) {
  db.execute(kSchema);
  SqliteStatement info = db.prepare("INSERT INTO map_info(key, value) VALUES(?, ?)");
  auto put = [&](const std::string& key, const std::string& value) { info.bind(1, key).bind(2, value).run(); };
  auto number = [](double value) {
    char text[64];
    std::snprintf(text, sizeof(text), "%.17g", value);
    return std::string(text);
  };
  put("schema_version", std::to_string(kMapSchemaVersion));
  put("mode", toString(header.mode));
  put("orb_levels", std::to_string(header.orb_levels));
  put("orb_scale_factor", number(header.orb_scale_factor));
  put("vocabulary_checksum", header.vocabulary_checksum);
  put("vocabulary_file", header.vocabulary_file);
  put("sequence", header.sequence);
  put("created_utc", header.created_utc.empty() ? nowUtc() : header.created_utc);
  const PinholeCamera& c = header.camera;
  SqliteStatement camera = db.prepare("INSERT INTO camera VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  camera.bind(1, c.name).bind(2, static_cast<long long>(c.width)).bind(3, static_cast<long long>(c.height));
  int column = 4;
  for (double value : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3, c.bf, c.fps, c.depth_factor, c.th_depth,
                       c.max_depth_m})
    camera.bind(column++, value);
  camera.run();
}

void writeKeyFrames(SqliteDatabase& db, const std::vector<KeyFrame*>& keyframes) {
  SqliteStatement row = db.prepare(
      "INSERT INTO keyframes VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  SqliteStatement keypoint =
      db.prepare("INSERT INTO keypoints VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  SqliteStatement word = db.prepare("INSERT INTO bow_words VALUES(?, ?, ?)");
  SqliteStatement feature = db.prepare("INSERT INTO bow_features VALUES(?, ?, ?)");
  SqliteStatement covisible = db.prepare("INSERT INTO covisibility VALUES(?, ?, ?)");
  SqliteStatement loop = db.prepare("INSERT INTO loop_edges VALUES(?, ?)");
  for (const KeyFrame* keyframe : keyframes) {
    const long long id = keyframe->id();
    const SE3& T_cw = keyframe->pose();
    row.bind(1, id).bind(2, static_cast<long long>(keyframe->frameId()));
    row.bind(3, static_cast<long long>(keyframe->frameIndex())).bind(4, keyframe->timestamp());
    int column = 5;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) row.bind(column++, T_cw.R(r, c));
    for (int r = 0; r < 3; ++r) row.bind(column++, T_cw.t(r));
    // Every live keyframe but the first has a live parent (keyframe.hpp); should
    // one not, it hangs from the first, so that the file still holds one tree.
    const KeyFrame* parent = keyframe->parent();
    if (parent && parent->isBad()) parent = nullptr;
    if (!parent && keyframe != keyframes.front()) {
      spdlog::warn("keyframe {} has no live parent: saved as a child of keyframe {}", keyframe->id(),
                   keyframes.front()->id());
      parent = keyframes.front();
    }
    if (parent)
      row.bind(17, static_cast<long long>(parent->id()));
    else
      row.bindNull(17);
    row.bind(18, static_cast<long long>(keyframe->not_erase ? 1 : 0));
    row.bind(19, static_cast<long long>(keyframe->size()));
    const bool has_depth = !keyframe->depth.empty();
    row.bind(20, static_cast<long long>(has_depth ? 1 : 0));
    row.run();

    for (size_t i = 0; i < keyframe->size(); ++i) {
      const cv::KeyPoint& kp = keyframe->keypoints[i];
      const FeatureLabel label = i < keyframe->labels.size() ? keyframe->labels[i] : FeatureLabel{};
      const cv::Vec3b bgr = i < keyframe->colours.size() ? keyframe->colours[i] : cv::Vec3b(0, 0, 0);
      keypoint.bind(1, id).bind(2, static_cast<long long>(i));
      keypoint.bind(3, static_cast<double>(kp.pt.x)).bind(4, static_cast<double>(kp.pt.y));
      keypoint.bind(5, static_cast<double>(keyframe->points[i].x)).bind(6, static_cast<double>(keyframe->points[i].y));
      keypoint.bind(7, static_cast<double>(kp.size)).bind(8, static_cast<double>(kp.angle));
      keypoint.bind(9, static_cast<double>(kp.response)).bind(10, static_cast<long long>(kp.octave));
      keypoint.bind(11, static_cast<long long>(label.class_id)).bind(12, static_cast<long long>(label.detection_id));
      keypoint.bind(13, static_cast<long long>(bgr[2])).bind(14, static_cast<long long>(bgr[1]));
      keypoint.bind(15, static_cast<long long>(bgr[0]));
      if (has_depth) {
        keypoint.bind(16, static_cast<double>(keyframe->depth[i])).bind(17, static_cast<double>(keyframe->u_right[i]));
      } else {
        keypoint.bindNull(16).bindNull(17);
      }
      keypoint.bindBlob(18, keyframe->descriptors.ptr<uint8_t>(static_cast<int>(i)), kDescriptorBytes);
      keypoint.run();
    }
    for (const auto& [word_id, weight] : keyframe->bow) word.bind(1, id).bind(2, static_cast<long long>(word_id)).bind(3, weight).run();
    for (const auto& [node_id, indices] : keyframe->bow_features)
      for (int index : indices)
        feature.bind(1, id).bind(2, static_cast<long long>(node_id)).bind(3, static_cast<long long>(index)).run();
    for (KeyFrame* other : keyframe->orderedCovisibles())
      if (!other->isBad())
        covisible.bind(1, id).bind(2, static_cast<long long>(other->id()))
            .bind(3, static_cast<long long>(keyframe->weight(other))).run();
    for (KeyFrame* other : keyframe->loopEdges())
      if (!other->isBad()) loop.bind(1, id).bind(2, static_cast<long long>(other->id())).run();
  }
}

// Returns the ids of the points written: a point no live keyframe sees is not.
std::set<long> writeMapPoints(SqliteDatabase& db, const std::vector<MapPoint*>& points) {
  SqliteStatement row =
      db.prepare("INSERT INTO map_points VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  SqliteStatement observation = db.prepare("INSERT INTO observations VALUES(?, ?, ?)");
  // A keypoint holds one point: the loader refuses a file where two claim it,
  // so the writer never writes one (the first point, by id, keeps it).
  std::set<std::pair<long, int>> claimed;
  std::set<long> written;
  for (const MapPoint* point : points) {
    std::vector<std::pair<KeyFrame*, int>> observed;
    for (const auto& [keyframe, index] : point->observations())
      if (!keyframe->isBad() && claimed.insert({keyframe->id(), index}).second) observed.emplace_back(keyframe, index);
    if (observed.empty()) continue;  // seen by no live keyframe: nothing could ever match it
    // Only live keyframes are saved, and a point's reference is always one of its observers.
    KeyFrame* reference = observed.front().first;
    for (const auto& [keyframe, index] : observed)
      if (keyframe == point->reference()) reference = keyframe;
    const MapPoint::SavedState state = point->savedState();
    const long long id = point->id();
    row.bind(1, id).bind(2, point->position().x()).bind(3, point->position().y()).bind(4, point->position().z());
    row.bind(5, static_cast<long long>(reference->id())).bind(6, static_cast<long long>(point->firstKeyframeId()));
    if (state.descriptor.empty())
      row.bindNull(7);
    else
      row.bindBlob(7, state.descriptor.ptr<uint8_t>(0), kDescriptorBytes);
    row.bind(8, state.normal.x()).bind(9, state.normal.y()).bind(10, state.normal.z());
    row.bind(11, state.min_distance).bind(12, state.max_distance);
    row.bind(13, static_cast<long long>(state.visible)).bind(14, static_cast<long long>(state.found));
    row.bind(15, static_cast<long long>(state.class_id)).bind(16, state.class_confidence);
    row.bind(17, static_cast<long long>(state.colour[2])).bind(18, static_cast<long long>(state.colour[1]));
    row.bind(19, static_cast<long long>(state.colour[0]));
    row.bind(20, static_cast<long long>(state.confirmed_min_observations));
    row.run();
    for (const auto& [keyframe, index] : observed)
      observation.bind(1, id).bind(2, static_cast<long long>(keyframe->id())).bind(3, static_cast<long long>(index)).run();
    written.insert(point->id());
  }
  return written;
}

// Objects name their points and keyframes by id; only those in `point_ids` and
// `keyframe_ids` (the ones the file holds) are written. The others are points
// culled since the objects were grouped, or ones the file leaves out: no longer
// members, and the loader would have to drop them.
void writeObjects(SqliteDatabase& db, const std::vector<ObjectLandmark>& objects,
                  const std::vector<std::string>& class_names, const std::set<long>& point_ids,
                  const std::set<long>& keyframe_ids) {
  SqliteStatement name = db.prepare("INSERT INTO classes VALUES(?, ?)");
  for (size_t i = 0; i < class_names.size(); ++i) name.bind(1, static_cast<long long>(i)).bind(2, class_names[i]).run();
  SqliteStatement row = db.prepare("INSERT INTO objects VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  SqliteStatement member = db.prepare("INSERT INTO object_points VALUES(?, ?, ?)");
  SqliteStatement seen_by = db.prepare("INSERT INTO object_keyframes VALUES(?, ?)");
  SqliteStatement merged = db.prepare("INSERT INTO object_merged_classes VALUES(?, ?)");
  long points_left_out = 0, keyframes_left_out = 0;
  for (size_t o = 0; o < objects.size(); ++o) {
    const ObjectLandmark& object = objects[o];
    const long long id = static_cast<long long>(o);
    row.bind(1, id).bind(2, static_cast<long long>(object.class_id)).bind(3, object.class_name).bind(4, object.confidence);
    int column = 5;
    for (const Vec3* v : {&object.centroid, &object.box_min, &object.box_max})
      for (int k = 0; k < 3; ++k) row.bind(column++, (*v)(k));
    row.run();
    auto writeMembers = [&](const std::vector<long>& members, long long rejected) {
      for (long point : members) {
        if (point_ids.count(point) == 0) {
          ++points_left_out;
          continue;
        }
        member.bind(1, id).bind(2, static_cast<long long>(point)).bind(3, rejected).run();
      }
    };
    writeMembers(object.point_ids, 0);
    writeMembers(object.rejected_point_ids, 1);
    for (long keyframe : object.keyframe_ids) {
      if (keyframe_ids.count(keyframe) == 0) {
        ++keyframes_left_out;
        continue;
      }
      seen_by.bind(1, id).bind(2, static_cast<long long>(keyframe)).run();
    }
    for (const std::string& class_name : object.merged_classes) merged.bind(1, id).bind(2, class_name).run();
  }
  if (points_left_out > 0 || keyframes_left_out > 0)
    spdlog::debug("map save: {} object points and {} object keyframes not in the saved map are left out",
                  points_left_out, keyframes_left_out);
}

// Opens a map read-only after SQLite's own check of every page and index.
void checkIntegrity(SqliteDatabase& db) {
  std::string first;
  try {
    SqliteStatement check = db.prepare("PRAGMA integrity_check");
    if (check.step()) first = check.text(0);
  } catch (const InputError& e) {
    // SQLite gives up before checking: not a database, or a damaged header.
    const std::string message = e.what();
    throw InputError(db.path(), 0, "corrupt map file (" + message.substr(message.find("SQLite")) + ")");
  }
  if (first == "ok") return;
  for (char& c : first)
    if (c == '\n') c = ' ';  // the error stays one line
  throw InputError(db.path(), 0, "corrupt map file (SQLite integrity check: " + first + ")");
}

// A stored integer as a T in [low, high], by default T's whole range. SQLite
// keeps 64 bits, and a plain cast would turn 2^32 + 1 into 1, inside every
// range checked after it. `name()` names the value, built only for a refusal.
template <typename T, typename Name>
T storedAs(long long value, const std::string& path, Name&& name, long long low = std::numeric_limits<T>::min(),
           long long high = std::numeric_limits<T>::max()) {
  if (value < low || value > high)
    throw InputError(path, 0, name() + " is " + std::to_string(value) + ", out of range (" + std::to_string(low) +
                                  ".." + std::to_string(high) + ")");
  return static_cast<T>(value);
}

// Text from a file in a refusal: one line, and short (a name may be 1 MB long).
std::string shown(std::string text) {
  constexpr size_t kMaxShown = 120;
  if (text.size() > kMaxShown) text = text.substr(0, kMaxShown) + "...";
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

// A table's columns as PRAGMA table_xinfo gives them, one text each: name,
// declared type, NOT NULL, default, place in the primary key (1 for its first
// column), and whether SQLite hides the column or computes it on every read.
std::vector<std::string> columnsOf(SqliteDatabase& db, const std::string& table) {
  SqliteStatement rows =
      db.prepare("SELECT name, type, \"notnull\", dflt_value, pk, hidden FROM pragma_table_xinfo(?) ORDER BY cid");
  rows.bind(1, table);
  std::vector<std::string> columns;
  while (rows.step()) {
    std::string column = rows.text(0);
    if (!rows.text(1).empty()) column += " " + rows.text(1);
    if (rows.integer(2) != 0) column += " NOT NULL";
    if (!rows.isNull(3)) column += " DEFAULT " + rows.text(3);
    if (rows.integer(4) != 0) column += " PRIMARY KEY " + std::to_string(rows.integer(4));
    const long long hidden = rows.integer(5);
    if (hidden == 1) column += " HIDDEN";
    if (hidden == 2) column += " GENERATED VIRTUAL";
    if (hidden == 3) column += " GENERATED STORED";
    if (hidden < 0 || hidden > 3) column += " hidden " + std::to_string(hidden);
    columns.push_back(column);
  }
  return columns;
}

// A map's schema is the file's own, and SQLite obeys it on every read: a
// crafted one could compute a column, drop a NOT NULL or a primary key, or
// make a table virtual. Each of `table`'s columns must be the writer's.
void checkColumns(SqliteDatabase& db, ExpectedSchema& expected, const std::string& table) {
  const std::string& path = db.path();
  const std::string differs = "the map's tables are not as vslam writes them: ";
  SqliteStatement kind =
      db.prepare("SELECT sql LIKE 'CREATE VIRTUAL TABLE%' FROM sqlite_master WHERE type = 'table' AND name = ?");
  kind.bind(1, table);
  if (kind.step() && kind.integer(0) != 0) throw InputError(path, 0, differs + table + " is a virtual table");
  const std::vector<std::string> ours = columnsOf(expected.db(), table), theirs = columnsOf(db, table);
  if (theirs.size() != ours.size())
    throw InputError(path, 0, differs + table + " has " + std::to_string(theirs.size()) + " columns, not " +
                                  std::to_string(ours.size()));
  for (size_t c = 0; c < ours.size(); ++c)
    if (theirs[c] != ours[c])
      throw InputError(path, 0, differs + "column " + std::to_string(c + 1) + " of " + table + " is '" +
                                    shown(theirs[c]) + "', not '" + ours[c] + "'");
}

// The writer makes none, and a map is only read: one would be there for no good reason.
void refuseViewsAndTriggers(SqliteDatabase& db) {
  SqliteStatement extra =
      db.prepare("SELECT type, name FROM sqlite_master WHERE type IN ('view', 'trigger') ORDER BY rowid LIMIT 1");
  if (extra.step())
    throw InputError(db.path(), 0, "the map has a " + extra.text(0) + " named " + shown(extra.text(1)) +
                                       " (vslam writes no views or triggers)");
}

MapFileHeader readHeader(SqliteDatabase& db) {
  const std::string& path = db.path();
  checkIntegrity(db);
  for (const std::string& table : {std::string("map_info"), std::string("camera")})
    if (!db.hasTable(table)) throw InputError(path, 0, "not a vslam map (no table " + table + ")");
  ExpectedSchema expected;
  refuseViewsAndTriggers(db);
  // map_info is read before the version is known: every version keeps its two columns.
  checkColumns(db, expected, "map_info");
  std::map<std::string, std::string> info;
  SqliteStatement rows = db.prepare("SELECT key, value FROM map_info");
  while (rows.step()) info[rows.text(0)] = rows.text(1);
  auto value = [&](const std::string& key) {
    auto it = info.find(key);
    if (it == info.end()) throw InputError(path, 0, "map_info has no " + key);
    return it->second;
  };
  auto integer = [&](const std::string& key) {
    const std::string text = value(key);
    try {
      size_t used = 0;
      const int number = std::stoi(text, &used);
      if (used == text.size()) return number;
    } catch (const std::exception&) {
    }
    throw InputError(path, 0, "map_info " + key + " is '" + text + "', not an integer");
  };
  MapFileHeader header;
  header.schema_version = integer("schema_version");
  if (header.schema_version > kMapSchemaVersion)
    throw InputError(path, 0,
                     "map schema version " + std::to_string(header.schema_version) +
                         " is newer than this vslam reads (up to " + std::to_string(kMapSchemaVersion) +
                         "): update vslam");
  if (header.schema_version < 1) throw InputError(path, 0, "map schema version " + value("schema_version") + " is not valid");
  for (const std::string& table : expected.tables()) {
    if (!db.hasTable(table)) throw InputError(path, 0, "map schema " + std::to_string(header.schema_version) + " has no table " + table);
    checkColumns(db, expected, table);
  }
  header.mode = parseMode(path, value("mode"));
  header.orb_levels = integer("orb_levels");
  try {
    header.orb_scale_factor = std::stod(value("orb_scale_factor"));
  } catch (const std::exception&) {  // std::stod's invalid_argument and out_of_range
    throw InputError(path, 0, "map_info orb_scale_factor is not a number");
  }
  header.vocabulary_checksum = value("vocabulary_checksum");
  header.vocabulary_file = value("vocabulary_file");
  header.sequence = value("sequence");
  header.created_utc = value("created_utc");
  if (db.queryInteger("SELECT COUNT(*) FROM camera") != 1) throw InputError(path, 0, "the camera table must hold one row");
  SqliteStatement camera = db.prepare("SELECT * FROM camera");
  camera.step();
  PinholeCamera& c = header.camera;
  c.name = camera.text(0);
  c.width = storedAs<int>(camera.integer(1), path, [] { return std::string("the camera's width"); });
  c.height = storedAs<int>(camera.integer(2), path, [] { return std::string("the camera's height"); });
  int column = 3;
  for (double* field : {&c.fx, &c.fy, &c.cx, &c.cy, &c.k1, &c.k2, &c.p1, &c.p2, &c.k3, &c.bf, &c.fps, &c.depth_factor,
                        &c.th_depth, &c.max_depth_m})
    *field = camera.real(column++);
  return header;
}

std::string describeCamera(const PinholeCamera& c) {
  char text[256];
  std::snprintf(text, sizeof(text), "%s %dx%d fx %.6g fy %.6g cx %.6g cy %.6g k1 %.6g k2 %.6g p1 %.6g p2 %.6g k3 %.6g",
                c.name.c_str(), c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3);
  return text;
}

// The run that loads a map goes on counting from its ids and subtracts them
// (frames since a keyframe, a point's age): one near the end of `long` would
// overflow there, or at once in Map::restoreKeyFrame. 2^40 is beyond any run
// (a thousand keyframes a second for 34 years).
constexpr long long kMaxStoredId = 1LL << 40;

long storedId(long long value, const std::string& path, const std::string& what) {
  if (value < 0 || value > kMaxStoredId)
    throw InputError(path, 0, what + " " + std::to_string(value) + " is out of range (0.." +
                                  std::to_string(kMaxStoredId) + ")");
  return static_cast<long>(value);
}

cv::Mat descriptorFrom(const std::vector<uint8_t>& bytes, const std::string& path, const std::string& what) {
  if (bytes.size() != kDescriptorBytes)
    throw InputError(path, 0, what + " has a descriptor of " + std::to_string(bytes.size()) + " bytes, not 32");
  cv::Mat descriptor(1, kDescriptorBytes, CV_8U);
  std::copy(bytes.begin(), bytes.end(), descriptor.ptr<uint8_t>(0));
  return descriptor;
}

}  // namespace

const char* toString(SensorMode mode) { return mode == SensorMode::RgbD ? "rgbd" : "mono"; }

std::string vocabularyChecksum(const std::string& path) {
  if (path.empty()) return "none";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot read the vocabulary file");
  uint64_t hash = 0xcbf29ce484222325ULL;  // FNV-1a 64
  char buffer[1 << 16];
  while (in.read(buffer, sizeof(buffer)) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      hash ^= static_cast<uint8_t>(buffer[i]);
      hash *= 0x100000001b3ULL;
    }
  }
  char text[20];
  std::snprintf(text, sizeof(text), "%016" PRIx64, hash);
  return text;
}

ScalePyramid makeScalePyramid(int levels, double scale_factor) {
  OrbParams params;
  params.n_levels = levels;
  params.scale_factor = scale_factor;
  const OrbExtractor extractor(params);
  ScalePyramid pyramid;
  pyramid.levels = extractor.levels();
  pyramid.scale_factor = scale_factor;
  pyramid.scale = extractor.scaleFactors();
  pyramid.sigma2 = extractor.levelSigma2();
  pyramid.inv_sigma2 = extractor.invLevelSigma2();
  return pyramid;
}

void saveMapDatabase(const std::string& path, const Map& map, const MapFileHeader& header,
                     const std::vector<ObjectLandmark>& objects, const std::vector<std::string>& class_names) {
  writeFileAtomically(path, [&](const std::string& temporary) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);  // left by a killed run: SQLite would open it
    try {
      SqliteDatabase db(temporary, SqliteDatabase::Access::Create);
      // The file is renamed into place only when complete; its own journal would buy nothing.
      db.execute("PRAGMA journal_mode = OFF");
      db.execute("BEGIN");
      writeSchemaAndHeader(db, header);
      const std::vector<KeyFrame*> keyframes = map.keyframes();
      writeKeyFrames(db, keyframes);
      const std::set<long> point_ids = writeMapPoints(db, map.mapPoints());
      std::set<long> keyframe_ids;
      for (const KeyFrame* keyframe : keyframes) keyframe_ids.insert(keyframe->id());
      writeObjects(db, objects, class_names, point_ids, keyframe_ids);
      db.execute("COMMIT");
    } catch (const InputError& e) {
      // The error names the temporary file; the user knows the final one.
      const std::string message = e.what();
      throw InputError(path, 0, "cannot write the map (" + message.substr(message.find(": ") + 2) + ")");
    }
  });
}

MapFileHeader readMapHeader(const std::string& path) {
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  return readHeader(db);
}

MapFileCounts readMapCounts(const std::string& path) {
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  readHeader(db);
  MapFileCounts counts;
  auto count = [&](const std::string& from) { return static_cast<long>(db.queryInteger("SELECT COUNT(*) FROM " + from)); };
  counts.keyframes = count("keyframes");
  counts.keypoints = count("keypoints");
  counts.map_points = count("map_points");
  counts.observations = count("observations");
  counts.covisibility_edges = count("covisibility");
  counts.spanning_tree_edges = count("keyframes WHERE parent_id IS NOT NULL");
  counts.loop_edges = count("loop_edges");
  counts.objects = count("objects");
  counts.classes = count("classes");
  return counts;
}

MapIdentity mapIdentityOf(const Config& config, const std::string& vocabulary_path) {
  MapIdentity identity;
  identity.mode = config.sensor;
  identity.camera = config.camera;
  identity.orb_levels = config.orb.n_levels;
  identity.orb_scale_factor = config.orb.scale_factor;
  identity.vocabulary_checksum = vocabularyChecksum(vocabulary_path);
  return identity;
}

void checkMapCompatible(const std::string& path, const MapFileHeader& header, const MapIdentity& required) {
  if (header.mode != required.mode)
    throw InputError(path, 0,
                     std::string("the map was made in ") + toString(header.mode) + " mode, this run is " +
                         toString(required.mode));
  const PinholeCamera& a = header.camera;
  const PinholeCamera& b = required.camera;
  const bool same_camera = a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
                           a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 &&
                           a.p2 == b.p2 && a.k3 == b.k3 && (header.mode != SensorMode::RgbD || a.bf == b.bf);
  if (!same_camera)
    throw InputError(path, 0, "the map was made with another camera (" + describeCamera(a) + "; this run: " +
                                  describeCamera(b) + ")");
  if (header.orb_levels != required.orb_levels || header.orb_scale_factor != required.orb_scale_factor)
    throw InputError(path, 0,
                     "the map was made with another ORB pyramid (" + std::to_string(header.orb_levels) +
                         " levels, scale " + std::to_string(header.orb_scale_factor) + "; this run: " +
                         std::to_string(required.orb_levels) + " levels, scale " +
                         std::to_string(required.orb_scale_factor) + ")");
  if (header.vocabulary_checksum != required.vocabulary_checksum)
    throw InputError(path, 0,
                     "the map was made with another vocabulary (checksum " + header.vocabulary_checksum + " from " +
                         header.vocabulary_file + "; this run's is " + required.vocabulary_checksum + ")");
}

void loadMapDatabase(const std::string& path, Map& map, const PinholeCamera& camera, const ScalePyramid& pyramid,
                     std::vector<ObjectLandmark>* objects, std::vector<std::string>* class_names) {
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  readHeader(db);
  if (map.keyframeCount() > 0 || !map.allKeyFrames().empty())
    throw std::logic_error("loadMapDatabase: the map must be empty");
  auto refuse = [&](const std::string& what) { throw InputError(path, 0, "inconsistent map: " + what); };
  const cv::Rect2f bounds = undistortedImageBounds(camera);

  // Keyframes with their keypoints, in id order (the map keeps them sorted).
  std::map<long, long> parent_of;  // keyframe -> parent, -1 for the root
  std::set<long> not_erase;
  {
    SqliteStatement rows = db.prepare(
        "SELECT id, frame_id, frame_index, timestamp, r00, r01, r02, r10, r11, r12, r20, r21, r22, tx, ty, tz, "
        "parent_id, not_erase, keypoint_count, has_depth FROM keyframes ORDER BY id");
    SqliteStatement keypoints = db.prepare(
        "SELECT idx, x, y, undistorted_x, undistorted_y, size, angle, response, octave, class_id, detection_id, red, "
        "green, blue, depth, u_right, descriptor FROM keypoints WHERE keyframe_id = ? ORDER BY idx");
    long previous_id = -1;
    while (rows.step()) {
      const long id = storedId(rows.integer(0), path, "keyframe id");
      // Ids are the tables' primary keys, so unique unless the schema itself was damaged.
      if (id <= previous_id) refuse("keyframe id " + std::to_string(id) + " is not unique or not >= 0");
      previous_id = id;
      const std::string where = "keyframe " + std::to_string(id);
      Frame frame;
      frame.id = storedId(rows.integer(1), path, where + "'s frame_id");
      frame.index = storedAs<int>(rows.integer(2), path, [&] { return where + "'s frame_index"; });
      frame.timestamp = rows.real(3);
      frame.camera = &camera;
      frame.pyramid = &pyramid;
      int column = 4;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) frame.T_cw.R(r, c) = rows.real(column++);
      for (int r = 0; r < 3; ++r) frame.T_cw.t(r) = rows.real(column++);
      frame.has_pose = true;
      parent_of[id] = rows.isNull(16) ? -1 : static_cast<long>(rows.integer(16));
      if (rows.integer(17) != 0) not_erase.insert(id);
      const long long count = rows.integer(18);
      const bool has_depth = rows.integer(19) != 0;
      if (count < 0 || count > 1000000) refuse(where + " has keypoint_count " + std::to_string(count));
      frame.descriptors = cv::Mat(static_cast<int>(count), kDescriptorBytes, CV_8U);
      keypoints.bind(1, static_cast<long long>(id));
      long long expected = 0;
      auto field = [&](const char* column) {
        return [&, column] { return where + "'s keypoint " + std::to_string(expected) + "'s " + column; };
      };
      while (keypoints.step()) {
        if (keypoints.integer(0) != expected || expected >= count)
          refuse(where + "'s keypoints are not numbered 0.." + std::to_string(count - 1));
        cv::KeyPoint kp;
        kp.pt = cv::Point2f(static_cast<float>(keypoints.real(1)), static_cast<float>(keypoints.real(2)));
        kp.size = static_cast<float>(keypoints.real(5));
        kp.angle = static_cast<float>(keypoints.real(6));
        kp.response = static_cast<float>(keypoints.real(7));
        kp.octave = storedAs<int>(keypoints.integer(8), path, field("octave"), 0, pyramid.levels - 1);
        frame.keypoints.push_back(kp);
        frame.points.emplace_back(static_cast<float>(keypoints.real(3)), static_cast<float>(keypoints.real(4)));
        frame.labels.push_back({storedAs<int>(keypoints.integer(9), path, field("class_id")),
                                storedAs<int>(keypoints.integer(10), path, field("detection_id"))});
        frame.colours.emplace_back(storedAs<uint8_t>(keypoints.integer(13), path, field("blue")),
                                   storedAs<uint8_t>(keypoints.integer(12), path, field("green")),
                                   storedAs<uint8_t>(keypoints.integer(11), path, field("red")));
        if (has_depth) {
          if (keypoints.isNull(14) || keypoints.isNull(15)) refuse(where + " has depth but a keypoint without it");
          frame.depth.push_back(static_cast<float>(keypoints.real(14)));
          frame.u_right.push_back(static_cast<float>(keypoints.real(15)));
        }
        descriptorFrom(keypoints.blob(16), path, where).copyTo(frame.descriptors.row(static_cast<int>(expected)));
        ++expected;
      }
      keypoints.reset();
      if (expected != count)
        refuse(where + " has " + std::to_string(expected) + " keypoints, keypoint_count says " + std::to_string(count));
      frame.finalizeFeatures(bounds);
      KeyFrame* keyframe = map.restoreKeyFrame(id, frame);
      keyframe->not_erase = not_erase.count(id) > 0;
    }
  }
  // A run that never initialised saves an empty map; there is nothing to start from.
  if (map.allKeyFrames().empty())
    throw InputError(path, 0, "the map has no keyframes (the run that saved it never initialised)");

  // Spanning tree: one root, every parent a keyframe of the map, no cycle.
  int roots = 0;
  for (const auto& [id, parent] : parent_of) {
    if (parent < 0) {
      ++roots;
      continue;
    }
    if (!map.keyFrameById(parent)) refuse("keyframe " + std::to_string(id) + "'s parent " + std::to_string(parent) + " is not in the map");
    long walk = id;
    for (size_t steps = 0; walk >= 0; ++steps) {
      if (steps > parent_of.size()) refuse("the spanning tree has a cycle through keyframe " + std::to_string(id));
      walk = parent_of.at(walk);
    }
  }
  if (roots != 1) refuse("the spanning tree has " + std::to_string(roots) + " roots, not 1");
  for (const auto& [id, parent] : parent_of)
    if (parent >= 0) map.keyFrameById(id)->changeParent(map.keyFrameById(parent));

  auto keyframeAt = [&](long long id, const std::string& naming) {
    KeyFrame* keyframe = map.keyFrameById(static_cast<long>(id));
    if (!keyframe) refuse(naming + " names keyframe " + std::to_string(id) + ", which is not in the map");
    return keyframe;
  };
  {
    SqliteStatement words = db.prepare("SELECT keyframe_id, word_id, weight FROM bow_words");
    while (words.step()) {
      KeyFrame* keyframe = keyframeAt(words.integer(0), "the bow_words table");
      const auto word = storedAs<WordId>(words.integer(1), path, [&] {
        return "keyframe " + std::to_string(keyframe->id()) + "'s bow word_id";
      });
      keyframe->bow[word] = words.real(2);
    }
    SqliteStatement features = db.prepare("SELECT keyframe_id, node_id, idx FROM bow_features ORDER BY keyframe_id, node_id, idx");
    while (features.step()) {
      KeyFrame* keyframe = keyframeAt(features.integer(0), "the bow_features table");
      if (features.integer(2) < 0 || static_cast<size_t>(features.integer(2)) >= keyframe->size())
        refuse("the bow_features table names keypoint " + std::to_string(features.integer(2)) + " of keyframe " + std::to_string(keyframe->id()));
      const auto node = storedAs<NodeId>(features.integer(1), path, [&] {
        return "keyframe " + std::to_string(keyframe->id()) + "'s bow node_id";
      });
      keyframe->bow_features[node].push_back(static_cast<int>(features.integer(2)));
    }
  }

  // Map points, then their observations (which fill the keyframes' slots).
  {
    SqliteStatement rows = db.prepare(
        "SELECT id, x, y, z, reference_keyframe_id, first_keyframe_id, descriptor, normal_x, normal_y, normal_z, "
        "min_distance, max_distance, visible, found, class_id, class_confidence, red, green, blue, "
        "confirmed_min_observations FROM map_points ORDER BY id");
    long previous_id = -1;
    while (rows.step()) {
      const long id = storedId(rows.integer(0), path, "map point id");
      if (id <= previous_id) refuse("map point id " + std::to_string(id) + " is not unique or not >= 0");
      previous_id = id;
      const std::string where = "map point " + std::to_string(id);
      KeyFrame* reference = keyframeAt(rows.integer(4), where + "'s reference");
      MapPoint* point = map.restoreMapPoint(id, Vec3(rows.real(1), rows.real(2), rows.real(3)), reference,
                                            storedId(rows.integer(5), path, where + "'s first_keyframe_id"));
      MapPoint::SavedState state;
      if (!rows.isNull(6)) state.descriptor = descriptorFrom(rows.blob(6), path, where);
      state.normal = Vec3(rows.real(7), rows.real(8), rows.real(9));
      state.min_distance = rows.real(10);
      state.max_distance = rows.real(11);
      auto field = [&](const char* column) { return [&, column] { return where + "'s " + column; }; };
      state.visible = storedAs<int>(rows.integer(12), path, field("visible"));
      state.found = storedAs<int>(rows.integer(13), path, field("found"));
      state.class_id = storedAs<int>(rows.integer(14), path, field("class_id"));
      state.class_confidence = rows.real(15);
      state.colour = cv::Vec3b(storedAs<uint8_t>(rows.integer(18), path, field("blue")),
                               storedAs<uint8_t>(rows.integer(17), path, field("green")),
                               storedAs<uint8_t>(rows.integer(16), path, field("red")));
      state.confirmed_min_observations = storedAs<int>(rows.integer(19), path, field("confirmed_min_observations"));
      point->restoreState(state);
    }
  }
  std::map<long, MapPoint*> point_by_id;
  for (MapPoint* point : map.mapPoints()) point_by_id[point->id()] = point;
  {
    SqliteStatement rows = db.prepare("SELECT map_point_id, keyframe_id, idx FROM observations ORDER BY map_point_id, keyframe_id");
    while (rows.step()) {
      auto it = point_by_id.find(static_cast<long>(rows.integer(0)));
      if (it == point_by_id.end()) refuse("the observations table names map point " + std::to_string(rows.integer(0)) + ", which is not in the map");
      KeyFrame* keyframe = keyframeAt(rows.integer(1), "the observations table");
      const long long index = rows.integer(2);
      const std::string where = "map point " + std::to_string(it->first) + "'s observation in keyframe " + std::to_string(keyframe->id());
      if (index < 0 || static_cast<size_t>(index) >= keyframe->size()) refuse(where + " names keypoint " + std::to_string(index));
      if (keyframe->mapPoint(static_cast<size_t>(index)))
        refuse(where + ": keypoint " + std::to_string(index) + " already holds map point " +
               std::to_string(keyframe->mapPoint(static_cast<size_t>(index))->id()));
      it->second->addObservation(keyframe, static_cast<int>(index));
      keyframe->setMapPoint(static_cast<size_t>(index), it->second);
    }
  }
  for (const auto& [id, point] : point_by_id) {
    if (point->observationCount() == 0) refuse("map point " + std::to_string(id) + " has no observation");
    if (point->keypointIn(point->reference()) < 0)
      refuse("map point " + std::to_string(id) + "'s reference keyframe does not observe it");
  }

  {
    SqliteStatement rows = db.prepare("SELECT keyframe_id, other_id, weight FROM covisibility ORDER BY keyframe_id, other_id");
    while (rows.step()) {
      KeyFrame* keyframe = keyframeAt(rows.integer(0), "the covisibility table");
      KeyFrame* other = keyframeAt(rows.integer(1), "the covisibility table");
      if (keyframe == other) refuse("keyframe " + std::to_string(keyframe->id()) + " is covisible with itself");
      keyframe->addConnection(other, storedAs<int>(rows.integer(2), path, [&] {
                                return "the covisibility weight of keyframe " + std::to_string(keyframe->id()) +
                                       " with keyframe " + std::to_string(other->id());
                              }));
    }
    SqliteStatement loops = db.prepare("SELECT keyframe_id, other_id FROM loop_edges");
    while (loops.step()) keyframeAt(loops.integer(0), "the loop_edges table")->addLoopEdge(keyframeAt(loops.integer(1), "the loop_edges table"));
  }

  if (class_names) {
    class_names->clear();
    SqliteStatement rows = db.prepare("SELECT class_id, name FROM classes ORDER BY class_id");
    while (rows.step()) {
      if (rows.integer(0) != static_cast<long long>(class_names->size())) refuse("class ids are not numbered from 0");
      class_names->push_back(rows.text(1));
    }
  }
  if (objects) {
    objects->clear();
    SqliteStatement rows = db.prepare("SELECT * FROM objects ORDER BY id");
    SqliteStatement members = db.prepare("SELECT map_point_id, rejected FROM object_points WHERE object_id = ? ORDER BY map_point_id");
    SqliteStatement seen_by = db.prepare("SELECT keyframe_id FROM object_keyframes WHERE object_id = ? ORDER BY keyframe_id");
    SqliteStatement merged = db.prepare("SELECT class_name FROM object_merged_classes WHERE object_id = ? ORDER BY class_name");
    // A map saved before the writer left out the members it does not save (or
    // a crafted one) may name points or keyframes the file does not hold:
    // those rows are left out, not refused.
    long missing = 0, missing_keyframes = 0;
    std::string first_missing, first_missing_keyframe;
    while (rows.step()) {
      ObjectLandmark object;
      const long long id = rows.integer(0);
      object.class_id =
          storedAs<int>(rows.integer(1), path, [&] { return "object " + std::to_string(id) + "'s class_id"; });
      object.class_name = rows.text(2);
      object.confidence = rows.real(3);
      int column = 4;
      for (Vec3* v : {&object.centroid, &object.box_min, &object.box_max})
        for (int k = 0; k < 3; ++k) (*v)(k) = rows.real(column++);
      members.bind(1, id);
      while (members.step()) {
        const long point = static_cast<long>(members.integer(0));
        if (point_by_id.count(point) == 0) {
          if (missing++ == 0) first_missing = "object " + std::to_string(id) + ", point " + std::to_string(point);
          continue;
        }
        (members.integer(1) ? object.rejected_point_ids : object.point_ids).push_back(point);
      }
      members.reset();
      seen_by.bind(1, id);
      while (seen_by.step()) {
        const long long keyframe = seen_by.integer(0);
        if (!map.keyFrameById(static_cast<long>(keyframe))) {
          if (missing_keyframes++ == 0)
            first_missing_keyframe = "object " + std::to_string(id) + ", keyframe " + std::to_string(keyframe);
          continue;
        }
        object.keyframe_ids.push_back(static_cast<long>(keyframe));
      }
      seen_by.reset();
      merged.bind(1, id);
      while (merged.step()) object.merged_classes.push_back(merged.text(0));
      merged.reset();
      objects->push_back(std::move(object));
    }
    if (missing > 0)
      spdlog::warn("{}: {} object_points rows name map points the map does not hold (the first: {}); they are left out",
                   path, missing, first_missing);
    if (missing_keyframes > 0)
      spdlog::warn("{}: {} object_keyframes rows name keyframes the map does not hold (the first: {}); they are "
                   "left out", path, missing_keyframes, first_missing_keyframe);
  }
}

}  // namespace vslam
