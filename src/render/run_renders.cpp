#include "vslam/render/run_renders.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/render/map_render.hpp"
#include "vslam/render/trajectory_plot.hpp"

namespace fs = std::filesystem;

namespace vslam {
namespace {

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
  // "ate" is the RMSE in metres, or an object holding it as "rmse" / "rmse_m",
  // or `vslam run`'s {"frames": {"rmse_m"}, "keyframes": {...}} (the frames' one).
  if (json.contains("ate")) {
    const nlohmann::json& ate = json["ate"];
    if (ate.is_number()) report.ate_rmse_m = ate;
    const nlohmann::json* holder = &ate;
    if (ate.is_object() && ate.contains("frames") && ate["frames"].is_object()) holder = &ate["frames"];
    for (const char* key : {"rmse", "rmse_m"})
      if (holder->is_object() && holder->contains(key) && (*holder)[key].is_number())
        report.ate_rmse_m = (*holder)[key];
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

// Where report.json's groundtruth_file points: an absolute path as written; a
// relative one in the run folder (`vslam run` writes groundtruth.txt there),
// else relative to the working directory.
std::string resolveGroundTruth(const std::string& file, const fs::path& run_dir) {
  if (file.empty() || fs::path(file).is_absolute()) return file;
  const fs::path in_run_dir = run_dir / file;
  return fs::exists(in_run_dir) || !fs::exists(file) ? in_run_dir.string() : file;
}

// The estimate aligned to the ground truth (the ATE's alignment: Sim(3) for
// monocular runs), restricted to the associated poses, and the ground truth
// over the estimate's time span.
TrajectoryPlotInput alignedTrajectory(const std::vector<StampedPose>& estimate,
                                      const std::vector<StampedPose>& groundtruth, bool with_scale,
                                      double& ate_rmse_m, std::optional<Sim3>& to_groundtruth) {
  TrajectoryPlotInput input;
  AteOptions options;
  options.alignment = with_scale ? Alignment::Sim3 : Alignment::SE3;
  AteResult ate;
  try {
    ate = computeAte(estimate, groundtruth, options);
  } catch (const InputError& e) {
    spdlog::warn("render: {}; plotting the estimate alone", e.what());
    for (const auto& pose : estimate) input.estimate.push_back(pose.T_wc.t);
    return input;
  }
  for (size_t i = 0; i < ate.pairs_idx.size(); ++i) {
    input.estimate.push_back(ate.alignment * estimate[ate.pairs_idx[i].first].T_wc.t);
    input.error_m.push_back(ate.errors_m[i]);
  }
  ate_rmse_m = ate.rmse_m;
  to_groundtruth = ate.alignment;
  const double first = estimate.front().timestamp - 0.5, last = estimate.back().timestamp + 0.5;
  for (const auto& pose : groundtruth)
    if (pose.timestamp >= first && pose.timestamp <= last) input.groundtruth.push_back(pose.T_wc.t);
  return input;
}

// Moves the whole map by the similarity S (estimate -> ground-truth frame);
// object boxes become the axis-aligned boxes of their moved corners.
void alignMap(const Sim3& S, MapRenderInput& map) {
  for (MapRenderPoint& point : map.points) point.position = S * point.position;
  for (MapRenderKeyframe& keyframe : map.keyframes)
    keyframe.T_wc = SE3(S.R * keyframe.T_wc.R, S * keyframe.T_wc.t);
  for (Vec3& position : map.trajectory) position = S * position;
  for (MapRenderObject& object : map.objects) {
    Vec3 low = Vec3::Constant(std::numeric_limits<double>::max()), high = -low;
    for (int corner = 0; corner < 8; ++corner) {
      const Vec3 p(corner & 1 ? object.box_max.x() : object.box_min.x(), corner & 2 ? object.box_max.y() : object.box_min.y(),
                   corner & 4 ? object.box_max.z() : object.box_min.z());
      low = low.cwiseMin(S * p);
      high = high.cwiseMax(S * p);
    }
    object.box_min = low;
    object.box_max = high;
  }
}

// Ground truth in TUM format; another format (KITTI poses) is reported and skipped.
std::vector<StampedPose> readGroundTruth(const std::string& path) {
  try {
    return readTumTrajectory(path);
  } catch (const InputError& e) {
    spdlog::warn("render: ground truth not in TUM format ({}); plotting the estimate alone", e.what());
    return {};
  }
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

// The names among `names` that exist in `dir`, joined by ", ".
std::string presentFiles(const fs::path& dir, std::initializer_list<const char*> names) {
  std::string present;
  for (const char* name : names)
    if (fs::exists(dir / name)) present += (present.empty() ? "" : ", ") + std::string(name);
  return present;
}

}  // namespace

std::vector<std::string> renderRunFolder(const std::string& run_dir_text, const std::string& out_dir) {
  const fs::path run_dir(run_dir_text);
  if (!fs::is_directory(run_dir)) throw InputError(run_dir_text, 0, "not a run folder (no such directory)");
  fs::create_directories(out_dir);
  std::vector<std::string> written;
  auto note = [&](const char* name) { written.push_back((fs::path(out_dir) / name).string()); };

  RunReport report;
  if (fs::exists(run_dir / "report.json")) report = readReport((run_dir / "report.json").string());

  std::vector<StampedPose> estimate;
  // The ATE's alignment, applied to the map too so that its axes are metres in
  // the ground truth's frame (a monocular map has an arbitrary scale).
  std::optional<Sim3> to_groundtruth;
  if (fs::exists(run_dir / "trajectory.txt")) estimate = readTumTrajectory((run_dir / "trajectory.txt").string());
  if (!estimate.empty()) {
    TrajectoryPlotInput input;
    const std::string groundtruth_path = resolveGroundTruth(report.groundtruth_file, run_dir);
    double computed_ate = -1.0;
    std::vector<StampedPose> groundtruth;
    if (!groundtruth_path.empty()) {
      groundtruth = readGroundTruth(groundtruth_path);
    }
    if (!groundtruth.empty()) {
      input = alignedTrajectory(estimate, groundtruth, report.mode == "mono", computed_ate, to_groundtruth);
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
  } else if (fs::exists(run_dir / "trajectory.txt")) {
    spdlog::info("render: trajectory.txt in {} holds no poses (no frame was tracked); no trajectory plots",
                 run_dir_text);
  } else {
    spdlog::info("render: no trajectory.txt in {}; no trajectory plots", run_dir_text);
  }

  MapRenderInput map;
  if (fs::exists(run_dir / "map.ply"))
    for (const PlyPoint& point : readMapPly((run_dir / "map.ply").string()))
      map.points.push_back({point.position, point.bgr, point.class_id});
  if (fs::exists(run_dir / "keyframes.txt"))
    for (const StampedPose& keyframe : readTumTrajectory((run_dir / "keyframes.txt").string()))
      map.keyframes.push_back({keyframe.T_wc});
  if (fs::exists(run_dir / "objects.json")) map.objects = readObjects((run_dir / "objects.json").string());
  for (const auto& pose : estimate) map.trajectory.push_back(pose.T_wc.t);
  if (to_groundtruth) alignMap(*to_groundtruth, map);
  if (!map.points.empty() || !map.keyframes.empty() || !map.objects.empty()) {
    auto count = [](size_t n, const char* noun) { return std::to_string(n) + " " + noun + (n == 1 ? "" : "s"); };
    map.title = titlePrefix(report) + " — map: " + count(map.points.size(), "point") + ", " +
                count(map.keyframes.size(), "keyframe") + ", " + count(map.objects.size(), "object");
    writeMapRenders(map, out_dir);
    note("map_colour.png");
    note("map_classes.png");
    note("map_top.png");
  } else if (const std::string present = presentFiles(run_dir, {"map.ply", "keyframes.txt", "objects.json"});
             !present.empty()) {
    spdlog::info("render: {} in {}: no points, keyframes or objects; no map renders", present, run_dir_text);
  } else {
    spdlog::info("render: no map.ply, keyframes.txt or objects.json in {}; no map renders", run_dir_text);
  }
  return written;
}

}  // namespace vslam
