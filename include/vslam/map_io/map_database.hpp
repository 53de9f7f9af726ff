#pragma once
// Saved maps: the whole map of a run in one SQLite file (docs/MAPS.md lists
// every table and column), so that a later run can localise in it or extend it.
//
// Saving writes a temporary file in one transaction and renames it over the
// final name, so a crash or a Ctrl-C never leaves half a map. Loading first
// checks the file (SQLite's integrity check, the schema version, then our own
// consistency checks) and refuses it with one InputError line naming the file
// and the reason; only a file that passes is turned back into a Map.
#include <string>
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/config.hpp"
#include "vslam/map/object_map.hpp"

namespace vslam {

class Map;
struct ScalePyramid;

// The version of the tables written here; a reader refuses a larger one.
inline constexpr int kMapSchemaVersion = 1;

// What a map is made with, and a run that uses it must share: the sensor
// mode, camera, ORB pyramid and vocabulary (checkMapCompatible compares them).
struct MapIdentity {
  SensorMode mode = SensorMode::Monocular;
  PinholeCamera camera;
  int orb_levels = 8;
  double orb_scale_factor = 1.2;
  std::string vocabulary_checksum;  // vocabularyChecksum() of the run's vocabulary; "none" without one
};

// The identity of a run with `config` and the vocabulary file at
// `vocabulary_path` ("" for none): what it saves in a map and what it needs
// of a map it loads. Reads the vocabulary file (vocabularyChecksum).
MapIdentity mapIdentityOf(const Config& config, const std::string& vocabulary_path);

// What a map file says about itself (the map_info and camera tables): the
// identity of the run that saved it, and more.
struct MapFileHeader : MapIdentity {
  MapFileHeader() = default;
  explicit MapFileHeader(const MapIdentity& identity) : MapIdentity(identity) {}

  int schema_version = kMapSchemaVersion;
  std::string vocabulary_file;  // for people: where the vocabulary came from
  std::string sequence;         // for people: the sequence it was made from
  std::string created_utc;      // for people: ISO 8601
};

// Row counts, for `vslam map info`.
struct MapFileCounts {
  long keyframes = 0, keypoints = 0, map_points = 0, observations = 0;
  long covisibility_edges = 0, spanning_tree_edges = 0, loop_edges = 0, objects = 0, classes = 0;
};

// Identity of a vocabulary file: FNV-1a 64 of its bytes, as 16 hex digits;
// "none" for an empty path. Throws InputError when the file cannot be read.
std::string vocabularyChecksum(const std::string& path);

const char* toString(SensorMode mode);

// Writes the live keyframes and map points of `map` with their graph, the
// object landmarks and the detector's class names to `path` (caller holds the
// map lock). An object's points and keyframes that the file does not hold (a
// point no live keyframe sees, one culled since the objects were grouped) are
// left out. Throws InputError naming `path` when it cannot be written; the
// file is then left as it was.
void saveMapDatabase(const std::string& path, const Map& map, const MapFileHeader& header,
                     const std::vector<ObjectLandmark>& objects, const std::vector<std::string>& class_names);

// Opens `path` read-only and checks it (SQLite's integrity check, our tables,
// the schema version); returns its header. Throws InputError.
MapFileHeader readMapHeader(const std::string& path);
MapFileCounts readMapCounts(const std::string& path);

// Throws InputError naming `path` when the map was made with another camera,
// sensor mode, ORB pyramid or vocabulary than `required` (the run's identity).
void checkMapCompatible(const std::string& path, const MapFileHeader& header, const MapIdentity& required);

// Reads the map into `map` (empty), its keyframes seeing through `camera` and
// `pyramid` (which outlive it); checks every link first (consistency). The
// stored object landmarks go to `objects` when given. Throws InputError.
void loadMapDatabase(const std::string& path, Map& map, const PinholeCamera& camera, const ScalePyramid& pyramid,
                     std::vector<ObjectLandmark>* objects = nullptr, std::vector<std::string>* class_names = nullptr);

// A scale pyramid as the ORB extractor builds it (scale_factor^level), for
// reading a map without an extractor.
ScalePyramid makeScalePyramid(int levels, double scale_factor);

}  // namespace vslam
