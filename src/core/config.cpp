#include "vslam/core/config.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

// Reads typed values out of one YAML file, naming file and line on failure.
class YamlReader {
 public:
  explicit YamlReader(std::string path) : path_(std::move(path)) {}

  const YAML::Node& root() const { return root_; }
  void load(const std::string& text) {
    try {
      root_ = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      throw InputError(path_, e.mark.line + 1, "YAML syntax error: " + e.msg);
    }
    if (!root_.IsMap()) throw InputError(path_, 0, "expected a mapping at the top level");
  }

  // A section that is there must be a mapping: yaml-cpp throws its own
  // BadSubscript for a key looked up in a scalar or a list ("camera: 3"; found
  // by the config fuzz target).
  YAML::Node section(const char* name) const {
    const YAML::Node node = root_[name];
    if (node && !node.IsMap())
      throw InputError(path_, node.Mark().line + 1, std::string("section '") + name + "' must be a mapping of keys");
    return node;
  }

  template <typename T>
  void required(const YAML::Node& parent, const std::string& section, const char* key, T& out) const {
    const YAML::Node node = parent[key];
    if (!node) {
      const int line = parent ? parent.Mark().line + 1 : 0;
      throw InputError(path_, line, "missing required key '" + qualified(section, key) + "'");
    }
    read(node, section, key, out);
  }

  // The line of `key` in `parent`, for an error about its value; the
  // section's own line when the key is not there (a default out of range),
  // 0 when neither is. A section's mark is its first key's, so range checks
  // need this to name a later key's line.
  int lineOf(const YAML::Node& parent, const char* key) const {
    if (!parent) return 0;
    const YAML::Node node = parent[key];
    return (node ? node.Mark().line : parent.Mark().line) + 1;
  }

  template <typename T>
  void optional(const YAML::Node& parent, const std::string& section, const char* key, T& out) const {
    if (!parent) return;
    const YAML::Node node = parent[key];
    if (node) read(node, section, key, out);
  }

 private:
  static std::string qualified(const std::string& section, const char* key) {
    return section.empty() ? key : section + "." + key;
  }
  template <typename T>
  void read(const YAML::Node& node, const std::string& section, const char* key, T& out) const {
    try {
      out = node.as<T>();
    } catch (const YAML::Exception&) {
      throw InputError(path_, node.Mark().line + 1,
                       "key '" + qualified(section, key) + "' has the wrong type (expected " + typeName<T>() + ")");
    }
    // YAML spells infinity and NaN .inf and .nan; no parameter means either.
    if constexpr (std::is_same_v<T, double>) {
      if (!std::isfinite(out))
        throw InputError(path_, node.Mark().line + 1, "key '" + qualified(section, key) + "' is not a finite number");
    }
    if constexpr (std::is_same_v<T, std::vector<double>>) {
      for (double value : out)
        if (!std::isfinite(value))
          throw InputError(path_, node.Mark().line + 1,
                           "key '" + qualified(section, key) + "' holds a number that is not finite");
    }
  }
  template <typename T>
  static const char* typeName() {
    if constexpr (std::is_same_v<T, int>) return "an integer";
    else if constexpr (std::is_same_v<T, double>) return "a number";
    else if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_same_v<T, std::string>) return "a string";
    else if constexpr (std::is_same_v<T, std::vector<double>>) return "a list of numbers";
    else return "a list of strings";
  }

  std::string path_;
  YAML::Node root_;
};

// A rigid transform written as the 12 numbers of its 3x4 matrix [R | t], row
// by row (a KITTI pose line). R must be a rotation to 1e-6: a matrix that is
// not is an error, not something to round silently.
SE3 rigidTransformFromRows(const std::vector<double>& rows, const std::string& path, int line, const std::string& key) {
  if (rows.size() != 12)
    throw InputError(path, line,
                     key + " must hold 12 numbers, the 3x4 matrix [R | t] row by row, not " +
                         std::to_string(rows.size()));
  Mat3 R;
  Vec3 t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = rows[4 * r + c];
    t(r) = rows[4 * r + 3];
  }
  constexpr double kTolerance = 1e-6;
  const double off_orthonormal = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (off_orthonormal > kTolerance || R.determinant() < 0)
    throw InputError(path, line,
                     key + ": its 3x3 part is not a rotation (R^T R differs from the identity by " +
                         std::to_string(off_orthonormal) + ", determinant " + std::to_string(R.determinant()) +
                         "); give an orthonormal matrix of determinant +1");
  // Orthonormal to the digits written; made so to machine precision.
  return SE3(Quat(R).normalized(), t);
}

Config loadVslamYaml(const std::string& text, const std::string& path) {
  YamlReader reader(path);
  reader.load(text);
  Config config;
  config.source = path;

  const YAML::Node cam = reader.section("camera");
  if (!cam) throw InputError(path, 0, "missing required section 'camera'");
  PinholeCamera& c = config.camera;
  reader.optional(cam, "camera", "name", c.name);
  reader.required(cam, "camera", "width", c.width);
  reader.required(cam, "camera", "height", c.height);
  reader.required(cam, "camera", "fx", c.fx);
  reader.required(cam, "camera", "fy", c.fy);
  reader.required(cam, "camera", "cx", c.cx);
  reader.required(cam, "camera", "cy", c.cy);
  reader.optional(cam, "camera", "k1", c.k1);
  reader.optional(cam, "camera", "k2", c.k2);
  reader.optional(cam, "camera", "p1", c.p1);
  reader.optional(cam, "camera", "p2", c.p2);
  reader.optional(cam, "camera", "k3", c.k3);
  reader.optional(cam, "camera", "fps", c.fps);
  reader.optional(cam, "camera", "depth_factor", c.depth_factor);
  reader.optional(cam, "camera", "bf", c.bf);
  reader.optional(cam, "camera", "th_depth", c.th_depth);
  reader.optional(cam, "camera", "max_depth_m", c.max_depth_m);
  reader.optional(cam, "camera", "readout_s", c.readout_s);
  if (c.bf < 0 || c.th_depth <= 0 || c.max_depth_m <= 0)
    throw InputError(path, cam.Mark().line + 1, "camera bf must be >= 0, th_depth and max_depth_m > 0");
  if (!(c.readout_s >= 0 && c.readout_s < 1))  // only a value in the file can be out of range
    throw InputError(path, cam["readout_s"].Mark().line + 1,
                     "camera readout_s must be in [0, 1) seconds (0: global shutter)");
  if (c.width <= 0 || c.height <= 0 || c.fx <= 0 || c.fy <= 0)
    throw InputError(path, cam.Mark().line + 1, "camera width, height, fx and fy must be positive");

  const YAML::Node orb = reader.section("orb");
  reader.optional(orb, "orb", "n_features", config.orb.n_features);
  reader.optional(orb, "orb", "n_levels", config.orb.n_levels);
  reader.optional(orb, "orb", "scale_factor", config.orb.scale_factor);
  reader.optional(orb, "orb", "fast_threshold", config.orb.fast_threshold);
  reader.optional(orb, "orb", "fast_min_threshold", config.orb.fast_min_threshold);

  const YAML::Node init = reader.section("initializer");
  reader.optional(init, "initializer", "homography_ratio", config.initializer.homography_ratio);
  reader.optional(init, "initializer", "ransac_iterations", config.initializer.ransac_iterations);
  reader.optional(init, "initializer", "sigma_px", config.initializer.sigma_px);
  reader.optional(init, "initializer", "min_matches", config.initializer.min_matches);
  reader.optional(init, "initializer", "min_parallax_deg", config.initializer.min_parallax_deg);
  reader.optional(init, "initializer", "min_triangulated", config.initializer.min_triangulated);
  reader.optional(init, "initializer", "max_translation_direction_std_deg",
                  config.initializer.max_translation_direction_std_deg);
  // 0 or less would refuse every motion from F: the map would never start from one
  // (a NaN the reader already refuses as not finite).
  const double direction_bound = config.initializer.max_translation_direction_std_deg;
  if (!(direction_bound > 0 && direction_bound <= 180))
    throw InputError(path, reader.lineOf(init, "max_translation_direction_std_deg"),
                     "initializer.max_translation_direction_std_deg must lie in (0, 180] degrees, not " +
                         std::to_string(direction_bound));
  reader.optional(init, "initializer", "window_max_level", config.initializer.window_max_level);
  if (config.initializer.window_max_level < 0 || config.initializer.window_max_level >= config.orb.n_levels)
    throw InputError(path, reader.lineOf(init, "window_max_level"),
                     "initializer.window_max_level must be a pyramid level, 0 to orb.n_levels - 1 (" +
                         std::to_string(config.orb.n_levels - 1) + "), not " +
                         std::to_string(config.initializer.window_max_level));

  const YAML::Node trk = reader.section("tracking");
  reader.optional(trk, "tracking", "max_frames_between_keyframes", config.tracking.max_frames_between_keyframes);
  reader.optional(trk, "tracking", "min_tracked_points", config.tracking.min_tracked_points);
  reader.optional(trk, "tracking", "ref_ratio", config.tracking.ref_ratio);
  reader.optional(trk, "tracking", "min_inliers", config.tracking.min_inliers);

  const YAML::Node map = reader.section("mapping");
  reader.optional(map, "mapping", "min_observations", config.mapping.min_observations);
  reader.optional(map, "mapping", "min_found_ratio", config.mapping.min_found_ratio);
  reader.optional(map, "mapping", "redundant_keyframe_ratio", config.mapping.redundant_keyframe_ratio);
  reader.optional(map, "mapping", "local_ba_iterations", config.mapping.local_ba_iterations);
  reader.optional(map, "mapping", "min_parallax_deg", config.mapping.min_parallax_deg);
  const double min_parallax = config.mapping.min_parallax_deg;
  if (!(min_parallax > 0 && min_parallax < 90))
    throw InputError(path, reader.lineOf(map, "min_parallax_deg"),
                     "mapping.min_parallax_deg must lie in (0, 90) degrees, not " + std::to_string(min_parallax));
  reader.optional(map, "mapping", "min_triangulation_neighbours", config.mapping.min_triangulation_neighbours);
  if (config.mapping.min_triangulation_neighbours < 0)
    throw InputError(path, reader.lineOf(map, "min_triangulation_neighbours"),
                     "mapping.min_triangulation_neighbours must be 0 or more, not " +
                         std::to_string(config.mapping.min_triangulation_neighbours));

  const YAML::Node loop = reader.section("loop");
  reader.optional(loop, "loop", "enabled", config.loop.enabled);
  reader.optional(loop, "loop", "consistency", config.loop.consistency);
  reader.optional(loop, "loop", "final_ba", config.loop.final_ba);
  reader.optional(loop, "loop", "final_ba_iterations", config.loop.final_ba_iterations);
  reader.optional(loop, "loop", "refine_frames", config.loop.refine_frames);
  reader.optional(loop, "loop", "vocabulary", config.loop.vocabulary);

  const YAML::Node det = reader.section("detector");
  DetectorParams& d = config.detector;
  reader.optional(det, "detector", "model", d.model);
  reader.optional(det, "detector", "cfg", d.cfg);
  reader.optional(det, "detector", "weights", d.weights);
  reader.optional(det, "detector", "names", d.names);
  reader.optional(det, "detector", "input_size", d.input_size);
  reader.optional(det, "detector", "confidence_threshold", d.confidence_threshold);
  reader.optional(det, "detector", "nms_threshold", d.nms_threshold);
  reader.optional(det, "detector", "min_box_px", d.min_box_px);
  reader.optional(det, "detector", "box_features", d.box_features);
  reader.optional(det, "detector", "dnn_target", d.dnn_target);
  reader.optional(det, "detector", "dynamic_classes", d.dynamic_classes);
  reader.optional(det, "detector", "moving_classes", d.moving_classes);
  if (det && det["detect_every"]) {
    const YAML::Node node = det["detect_every"];
    std::string text;
    reader.optional(det, "detector", "detect_every", text);
    const std::optional<DetectEvery> every = parseDetectEvery(text);
    if (!every)
      throw InputError(path, node.Mark().line + 1,
                       "detector.detect_every must be a whole number >= 1, 'keyframes' or 'auto', not '" + text + "'");
    d.detect_every = *every;
  }
  reader.optional(det, "detector", "max_box_age", d.max_box_age);
  reader.optional(det, "detector", "dnn_threads", d.dnn_threads);
  reader.optional(det, "detector", "box_filter", d.box_filter);
  if (d.max_box_age < 0 || d.dnn_threads < 0)
    throw InputError(path, det.Mark().line + 1, "detector.max_box_age and detector.dnn_threads must be >= 0");
  if (!isBoxFilter(d.box_filter))
    throw InputError(path, det.Mark().line + 1,
                     "detector.box_filter must be 'paper', 'reuse' or 'label', not '" + d.box_filter + "'");

  const YAML::Node evaluation = reader.section("evaluation");
  if (evaluation && evaluation["groundtruth_camera_in_body"]) {
    std::vector<double> rows;
    reader.optional(evaluation, "evaluation", "groundtruth_camera_in_body", rows);
    config.evaluation.groundtruth_camera_in_body =
        rigidTransformFromRows(rows, path, reader.lineOf(evaluation, "groundtruth_camera_in_body"),
                               "evaluation.groundtruth_camera_in_body");
  }
  return config;
}

// One "Key: value" line of an ORB-SLAM settings file.
struct SettingsValue {
  std::string text;  // without quotes and trailing comment
  int line = 0;
  bool quoted = false;
};

// ORB-SLAM settings files are OpenCV FileStorage YAML ("%YAML:1.0"); in
// practice a flat list of "Key: value" lines, with indented blocks under
// "Key: !!opencv-matrix" that nothing here reads. They are read line by line:
// cv::FileStorage (OpenCV 4.6) loops forever on some malformed files ("  k1-:3"
// then " r", found by the config fuzz target), and yaml-cpp refuses genuine
// ORB-SLAM2 files (Stereo/EuRoC.yaml writes "data:[...]").
std::map<std::string, SettingsValue> readSettingsLines(const std::string& text, const std::string& path) {
  auto is_blank = [](char c) { return c == ' ' || c == '\t'; };
  auto trim = [&](std::string s) {
    while (!s.empty() && (is_blank(s.back()) || s.back() == '\r')) s.pop_back();
    size_t first = 0;
    while (first < s.size() && is_blank(s[first])) ++first;
    return s.substr(first);
  };
  std::map<std::string, SettingsValue> values;
  std::istringstream in(text);
  std::string raw;
  int line = 0;
  bool block_open = false;  // the last key had no value or a tag: indented lines below are its body
  while (std::getline(in, raw)) {
    ++line;
    if (line == 1) continue;  // "%YAML:1.0", which parseConfig checked
    const std::string content = trim(raw);
    if (content.empty() || content[0] == '#') continue;
    if (is_blank(raw[0])) {
      if (!block_open)
        throw InputError(path, line, "indented line outside a block (expected 'Key: value' at the start of the line)");
      continue;
    }
    if (content == "---" || content == "...")
      throw InputError(path, line, "a settings file holds one YAML document ('" + content + "')");
    if (content[0] == '-')
      throw InputError(path, line, "expected a mapping of keys (Camera.fx: ...) at the top level, not a list");
    // The key ends at the first ':' followed by a blank or the end of the line,
    // else at the first ':' ("Camera.fx:517.3", which OpenCV reads too).
    size_t colon = content.find(':');
    while (colon != std::string::npos && colon + 1 < content.size() && !is_blank(content[colon + 1]))
      colon = content.find(':', colon + 1);
    if (colon == std::string::npos) colon = content.find(':');
    const std::string key = colon == std::string::npos ? std::string() : trim(content.substr(0, colon));
    const bool key_ok = !key.empty() && std::all_of(key.begin(), key.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
    });
    if (!key_ok) throw InputError(path, line, "expected 'Key: value' (a key of letters, digits, '.', '_' or '-')");
    SettingsValue value;
    value.line = line;
    std::string rest = trim(content.substr(colon + 1));
    if (!rest.empty() && (rest[0] == '"' || rest[0] == '\'')) {
      const size_t close = rest.find(rest[0], 1);
      if (close == std::string::npos) throw InputError(path, line, "unterminated quoted value of '" + key + "'");
      const std::string after = trim(rest.substr(close + 1));
      if (!after.empty() && after[0] != '#')
        throw InputError(path, line, "unexpected text after the quoted value of '" + key + "'");
      value.text = rest.substr(1, close - 1);
      value.quoted = true;
    } else {
      // A comment starts at a '#' after a blank.
      for (size_t i = 1; i < rest.size(); ++i)
        if (rest[i] == '#' && is_blank(rest[i - 1])) {
          rest = trim(rest.substr(0, i));
          break;
        }
      value.text = rest;
    }
    block_open = !value.quoted && (value.text.empty() || value.text.rfind("!!", 0) == 0);
    const auto [it, inserted] = values.emplace(key, value);
    if (!inserted)
      throw InputError(path, line, "key '" + key + "' given twice (first on line " + std::to_string(it->second.line) + ")");
  }
  return values;
}

Config loadOrbSlamSettings(const std::string& text, const std::string& path) {
  const std::map<std::string, SettingsValue> values = readSettingsLines(text, path);

  auto number = [&](const char* key, double& out, bool required) {
    const auto it = values.find(key);
    if (it == values.end()) {
      if (required) throw InputError(path, 0, std::string("missing required key '") + key + "'");
      return;
    }
    // The text is trimmed: the whole of it must be the number.
    const SettingsValue& value = it->second;
    char* end = nullptr;
    const double parsed = std::strtod(value.text.c_str(), &end);
    if (value.quoted || value.text.empty() || end != value.text.c_str() + value.text.size())
      throw InputError(path, value.line, std::string("key '") + key + "' has the wrong type (expected a number, got '" +
                                             value.text + "')");
    if (!std::isfinite(parsed)) throw InputError(path, value.line, std::string("key '") + key + "' is not a finite number");
    out = parsed;
  };
  // Settings files may write integers as reals ("640.0"); a fraction or a
  // value beyond int is an error, not a silent cast.
  auto integer = [&](const char* key, int& out) {
    double v = out;
    number(key, v, false);
    // `out` is an int, so only a value read from the file can fail here.
    if (v != std::trunc(v) || v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      throw InputError(path, values.at(key).line, std::string("key '") + key + "' must be an integer, got " + std::to_string(v));
    out = static_cast<int>(v);
  };

  Config config;
  config.source = path;
  config.orb_slam_settings = true;
  PinholeCamera& c = config.camera;
  c.name = std::filesystem::path(path).stem().string();
  number("Camera.fx", c.fx, true);
  number("Camera.fy", c.fy, true);
  number("Camera.cx", c.cx, true);
  number("Camera.cy", c.cy, true);
  number("Camera.k1", c.k1, false);
  number("Camera.k2", c.k2, false);
  number("Camera.p1", c.p1, false);
  number("Camera.p2", c.p2, false);
  number("Camera.k3", c.k3, false);
  number("Camera.fps", c.fps, false);
  // ORB-SLAM2's TUM files omit the image size; the reader fills it from the first image.
  integer("Camera.width", c.width);
  integer("Camera.height", c.height);
  number("DepthMapFactor", c.depth_factor, false);
  number("Camera.bf", c.bf, false);
  number("ThDepth", c.th_depth, false);
  if (c.bf < 0 || c.th_depth <= 0) throw InputError(path, 0, "Camera.bf must be >= 0 and ThDepth > 0");
  integer("ORBextractor.nFeatures", config.orb.n_features);
  number("ORBextractor.scaleFactor", config.orb.scale_factor, false);
  integer("ORBextractor.nLevels", config.orb.n_levels);
  integer("ORBextractor.iniThFAST", config.orb.fast_threshold);
  integer("ORBextractor.minThFAST", config.orb.fast_min_threshold);
  return config;
}

}  // namespace

std::optional<DetectEvery> parseDetectEvery(const std::string& text) {
  DetectEvery every;
  if (text == "keyframes") {
    every.mode = DetectEvery::Mode::KeyFrames;
    return every;
  }
  if (text == "auto") {
    every.mode = DetectEvery::Mode::Auto;
    return every;
  }
  if (text.empty() || text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  every.frames = std::stoi(text);
  if (every.frames < 1) return std::nullopt;
  return every;
}

std::string toString(const DetectEvery& every) {
  switch (every.mode) {
    case DetectEvery::Mode::KeyFrames:
      return "keyframes";
    case DetectEvery::Mode::Auto:
      return "auto";
    case DetectEvery::Mode::Frames:
      break;
  }
  return std::to_string(every.frames);
}

Config loadConfig(const std::string& path) {
  if (fs::is_directory(path)) throw InputError(path, 0, "is a directory, not a config file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open config file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, 0, "read error");
  return parseConfig(text.str(), path);
}

Config parseConfig(const std::string& text, const std::string& source) {
  if (text.rfind("%YAML:", 0) == 0) return loadOrbSlamSettings(text, source);
  return loadVslamYaml(text, source);
}

void requireDepthCamera(const Config& config) {
  if (config.camera.bf > 0) return;
  const char* key = config.orb_slam_settings ? "Camera.bf" : "camera.bf";
  throw InputError(config.source.empty() ? "(default config)" : config.source, 0,
                   std::string("missing required key '") + key +
                       "' for RGB-D (fx times the virtual baseline in metres; ORB-SLAM2 uses 40 for TUM)");
}

std::string resolveVocabularyPath(const std::string& path, const std::string& project_root) {
  namespace fs = std::filesystem;
  if (path.empty() || fs::exists(path) || fs::path(path).is_absolute()) return path;
  const fs::path in_project = fs::path(project_root) / path;
  if (fs::exists(in_project)) return in_project.string();
  if (path == LoopParams::kDefaultVocabulary) return resolveVocabularyPath(LoopParams::kFallbackVocabulary, project_root);
  return path;
}

std::string resolveVocabularyPath(const std::string& path) { return resolveVocabularyPath(path, VSLAM_SOURCE_DIR); }

std::string projectConfigDir() { return std::string(VSLAM_SOURCE_DIR) + "/config"; }

}  // namespace vslam
