#include "vslam/render/run_renders.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/render/map_render.hpp"
#include "vslam/render/trajectory_plot.hpp"

namespace fs = std::filesystem;

namespace vslam {
namespace {

// Numbers of each non-comment line; InputError names the file and line.
std::vector<std::pair<int, std::vector<double>>> readNumberLines(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  std::vector<std::pair<int, std::vector<double>>> rows;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> numbers;
    std::string field;
    while (fields >> field) {
      try {
        size_t used = 0;
        numbers.push_back(std::stod(field, &used));
        if (used != field.size()) throw std::invalid_argument(field);
      } catch (const std::exception&) {
        throw InputError(path, line_number, "not a number: \"" + field + "\"");
      }
    }
    rows.push_back({line_number, numbers});
  }
  return rows;
}

// TUM lines have 8 numbers; a keyframe file may put an id in front (9). The
// pose is always the last seven, the timestamp the one before them.
std::vector<StampedPose> readPoses(const std::string& path) {
  std::vector<StampedPose> poses;
  for (const auto& [line_number, numbers] : readNumberLines(path)) {
    if (numbers.size() != 8 && numbers.size() != 9)
      throw InputError(path, line_number,
                       "expected \"timestamp tx ty tz qx qy qz qw\" (8 numbers), got " + std::to_string(numbers.size()));
    const size_t first = numbers.size() - 8;  // the timestamp's column
    const double* pose = numbers.data() + first + 1;
    StampedPose stamped;
    stamped.timestamp = numbers[first];
    stamped.T_wc = SE3(Quat(pose[6], pose[3], pose[4], pose[5]), Vec3(pose[0], pose[1], pose[2]));
    poses.push_back(stamped);
  }
  std::stable_sort(poses.begin(), poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  return poses;
}

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, 0, std::string("invalid JSON: ") + e.what());
  }
}

struct RunReport {
  std::string sequence = "run";
  std::string mode;
  double ate_rmse_m = -1.0;  // < 0: not in the report
  std::string groundtruth_file;
};

RunReport readReport(const std::string& path) {
  RunReport report;
  const nlohmann::json json = readJson(path);
  if (!json.is_object()) throw InputError(path, 0, "expected a JSON object");
  if (json.contains("sequence") && json["sequence"].is_string()) report.sequence = json["sequence"];
  if (json.contains("mode") && json["mode"].is_string()) report.mode = json["mode"];
  if (json.contains("groundtruth_file") && json["groundtruth_file"].is_string())
    report.groundtruth_file = json["groundtruth_file"];
  // "ate" is the RMSE in metres, or an object holding it as "rmse" / "rmse_m".
  if (json.contains("ate")) {
    const nlohmann::json& ate = json["ate"];
    if (ate.is_number()) report.ate_rmse_m = ate;
    for (const char* key : {"rmse", "rmse_m"})
      if (ate.is_object() && ate.contains(key) && ate[key].is_number()) report.ate_rmse_m = ate[key];
  }
  return report;
}

std::string formatAte(double rmse_m) {
  char text[64];
  if (rmse_m < 1.0)
    std::snprintf(text, sizeof text, "ATE RMSE %.2f cm", 100.0 * rmse_m);
  else
    std::snprintf(text, sizeof text, "ATE RMSE %.2f m", rmse_m);
  return text;
}

std::string titlePrefix(const RunReport& report) {
  return report.mode.empty() ? report.sequence : report.sequence + " — " + report.mode;
}

// Where report.json's groundtruth_file points: as written (absolute, or
// relative to the working directory), else relative to the run folder.
std::string resolveGroundTruth(const std::string& file, const fs::path& run_dir) {
  if (file.empty()) return "";
  if (fs::path(file).is_absolute() || fs::exists(file)) return file;
  return (run_dir / file).string();
}

// The estimate aligned to the ground truth (Umeyama; with scale for monocular
// runs), restricted to the associated poses, and the ground truth over the
// estimate's time span.
TrajectoryPlotInput alignedTrajectory(const std::vector<StampedPose>& estimate,
                                      const std::vector<StampedPose>& groundtruth, bool with_scale,
                                      double& ate_rmse_m) {
  TrajectoryPlotInput input;
  const auto pairs = associateByTimestamp(estimate, groundtruth);
  if (pairs.size() < 3) {
    spdlog::warn("render: only {} estimate poses match the ground truth within 0.02 s; plotting the estimate alone",
                 pairs.size());
    for (const auto& pose : estimate) input.estimate.push_back(pose.T_wc.t);
    return input;
  }
  Eigen::Matrix3Xd from(3, pairs.size()), to(3, pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    from.col(i) = estimate[pairs[i].first].T_wc.t;
    to.col(i) = groundtruth[pairs[i].second].T_wc.t;
  }
  const Mat4 similarity = Eigen::umeyama(from, to, with_scale);
  double squared_sum = 0.0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Vec3 aligned = (similarity * from.col(i).homogeneous()).head<3>();
    input.estimate.push_back(aligned);
    input.error_m.push_back((aligned - to.col(i)).norm());
    squared_sum += input.error_m.back() * input.error_m.back();
  }
  ate_rmse_m = std::sqrt(squared_sum / pairs.size());
  const double first = estimate.front().timestamp - 0.5, last = estimate.back().timestamp + 0.5;
  for (const auto& pose : groundtruth)
    if (pose.timestamp >= first && pose.timestamp <= last) input.groundtruth.push_back(pose.T_wc.t);
  return input;
}

std::vector<MapRenderObject> readObjects(const std::string& path) {
  const nlohmann::json json = readJson(path);
  const nlohmann::json& list = json.is_object() && json.contains("objects") ? json["objects"] : json;
  if (!list.is_array()) throw InputError(path, 0, "expected a list of objects");
  std::vector<MapRenderObject> objects;
  for (size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& entry = list[i];
    const std::string where = "object " + std::to_string(i);
    auto vec3 = [&](const char* key) {
      if (!entry.contains(key) || !entry[key].is_array() || entry[key].size() != 3)
        throw InputError(path, 0, where + ": \"" + key + "\" must be a list of 3 numbers");
      return Vec3(entry[key][0].get<double>(), entry[key][1].get<double>(), entry[key][2].get<double>());
    };
    MapRenderObject object;
    object.box_min = vec3("box_min");
    object.box_max = vec3("box_max");
    // "class" is a COCO name or index; an explicit "class_id" wins.
    if (entry.contains("class") && entry["class"].is_string()) {
      object.label = entry["class"];
      object.class_id = cocoClassId(object.label);
    } else if (entry.contains("class") && entry["class"].is_number_integer()) {
      object.class_id = entry["class"];
      object.label = cocoClassName(object.class_id);
    }
    if (entry.contains("class_id") && entry["class_id"].is_number_integer()) object.class_id = entry["class_id"];
    if (object.label.empty()) object.label = cocoClassName(object.class_id);
    if (entry.contains("confidence") && entry["confidence"].is_number()) {
      char confidence[16];
      std::snprintf(confidence, sizeof confidence, " %.2f", entry["confidence"].get<double>());
      object.label += confidence;
    }
    objects.push_back(object);
  }
  return objects;
}

}  // namespace

std::vector<StampedPose> readTumTrajectory(const std::string& path) { return readPoses(path); }

std::vector<std::pair<size_t, size_t>> associateByTimestamp(const std::vector<StampedPose>& estimate,
                                                            const std::vector<StampedPose>& groundtruth,
                                                            double max_dt) {
  struct Candidate { double dt; size_t estimate, groundtruth; };
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < estimate.size(); ++i) {
    const double t = estimate[i].timestamp;
    auto it = std::lower_bound(groundtruth.begin(), groundtruth.end(), t - max_dt,
                               [](const StampedPose& pose, double time) { return pose.timestamp < time; });
    for (; it != groundtruth.end() && it->timestamp <= t + max_dt; ++it)
      candidates.push_back({std::abs(it->timestamp - t), i, static_cast<size_t>(it - groundtruth.begin())});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.dt < b.dt; });
  std::vector<bool> estimate_used(estimate.size()), groundtruth_used(groundtruth.size());
  std::vector<std::pair<size_t, size_t>> pairs;
  for (const Candidate& c : candidates) {
    if (estimate_used[c.estimate] || groundtruth_used[c.groundtruth]) continue;
    estimate_used[c.estimate] = groundtruth_used[c.groundtruth] = true;
    pairs.push_back({c.estimate, c.groundtruth});
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

std::vector<std::string> renderRunFolder(const std::string& run_dir_text, const std::string& out_dir) {
  const fs::path run_dir(run_dir_text);
  if (!fs::is_directory(run_dir)) throw InputError(run_dir_text, 0, "not a run folder (no such directory)");
  fs::create_directories(out_dir);
  std::vector<std::string> written;
  auto note = [&](const char* name) { written.push_back((fs::path(out_dir) / name).string()); };

  RunReport report;
  if (fs::exists(run_dir / "report.json")) report = readReport((run_dir / "report.json").string());

  std::vector<StampedPose> estimate;
  if (fs::exists(run_dir / "trajectory.txt")) estimate = readPoses((run_dir / "trajectory.txt").string());
  if (!estimate.empty()) {
    TrajectoryPlotInput input;
    const std::string groundtruth_path = resolveGroundTruth(report.groundtruth_file, run_dir);
    double computed_ate = -1.0;
    std::vector<StampedPose> groundtruth;
    if (!groundtruth_path.empty()) {
      // The figures are a by-product of a run: an unreadable ground truth
      // (e.g. a KITTI pose file, not read here yet) costs the comparison, not the figures.
      try {
        groundtruth = readPoses(groundtruth_path);
      } catch (const InputError& e) {
        spdlog::warn("render: ground truth not used: {}", e.what());
      }
    }
    if (!groundtruth.empty()) {
      input = alignedTrajectory(estimate, groundtruth, report.mode == "mono", computed_ate);
    } else {
      if (groundtruth_path.empty()) spdlog::info("render: no groundtruth_file in report.json; plotting the estimate alone");
      for (const auto& pose : estimate) input.estimate.push_back(pose.T_wc.t);
    }
    // The report's ATE is the official number; ours (same rule) stands in when it has none.
    const double ate = report.ate_rmse_m >= 0 ? report.ate_rmse_m : computed_ate;
    input.title = titlePrefix(report) + (ate >= 0 ? " — " + formatAte(ate) : " — estimate (no ground truth)");
    writeTrajectoryPlots(input, out_dir);
    note("trajectory_top.png");
    note("trajectory_3d.png");
  } else {
    spdlog::info("render: no trajectory.txt in {}; no trajectory plots", run_dir_text);
  }

  MapRenderInput map;
  if (fs::exists(run_dir / "map.ply"))
    for (const PlyPoint& point : readMapPly((run_dir / "map.ply").string()))
      map.points.push_back({point.position, point.bgr, point.class_id});
  if (fs::exists(run_dir / "keyframes.txt"))
    for (const StampedPose& keyframe : readPoses((run_dir / "keyframes.txt").string()))
      map.keyframes.push_back({keyframe.T_wc});
  if (fs::exists(run_dir / "objects.json")) map.objects = readObjects((run_dir / "objects.json").string());
  for (const auto& pose : estimate) map.trajectory.push_back(pose.T_wc.t);
  if (!map.points.empty() || !map.keyframes.empty() || !map.objects.empty()) {
    auto count = [](size_t n, const char* noun) { return std::to_string(n) + " " + noun + (n == 1 ? "" : "s"); };
    map.title = titlePrefix(report) + " — map: " + count(map.points.size(), "point") + ", " +
                count(map.keyframes.size(), "keyframe") + ", " + count(map.objects.size(), "object");
    writeMapRenders(map, out_dir);
    note("map_colour.png");
    note("map_classes.png");
    note("map_top.png");
  } else {
    spdlog::info("render: no map.ply, keyframes.txt or objects.json in {}; no map renders", run_dir_text);
  }
  return written;
}

}  // namespace vslam
