// `vslam eval`: scores an estimated trajectory against ground truth (ATE, RPE,
// and for KITTI files the KITTI odometry benchmark's error).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/eval/kitti_odometry_metric.hpp"
#include "vslam/eval/rpe.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam::app {
namespace {

struct EvalOptions {
  std::string estimate_path;
  std::string groundtruth_path;
  std::string align = "auto";
  std::string format = "tum";
  std::string json_path;
  std::string config_path;  // its evaluation section (the ground truth's camera offset), "" for none
  double max_dt = 0.02;
  double time_offset_s = 0.0;  // added to the estimate's timestamps, as evaluate_ate.py's --offset
  double rpe_delta = 0.0;  // 0 = 1 s (TUM) or 100 m (KITTI)
  bool kitti_metrics = false;
  std::vector<double> kitti_lengths;  // empty: the benchmark's 100, 200, ..., 800 m
};

// A trajectory file's poses and, for KITTI files, the frame of each line.
struct TrajectoryFile {
  std::vector<StampedPose> poses;
  std::vector<int> frames;     // KITTI: from the frame index file beside it, else line i is frame i
  std::string frames_path;     // the frame index file read, "" if none
};

TrajectoryFile readTrajectory(const std::string& path, const std::string& format) {
  TrajectoryFile file;
  if (format != "kitti") {
    file.poses = readTumTrajectory(path);
  } else {
    try {
      file.poses = readKittiTrajectory(path);
    } catch (const InputError& e) {
      // A run folder's trajectory.txt is TUM; its KITTI twin is beside it.
      const std::filesystem::path twin = std::filesystem::path(path).parent_path() / "trajectory_kitti.txt";
      if (std::filesystem::path(path).filename() == "trajectory.txt" && std::filesystem::exists(twin))
        throw InputError(std::string(e.what()) + "; the run's KITTI-format trajectory is " + twin.string());
      throw;
    }
    const std::string frames_path = kittiFrameIndexPath(path);
    if (std::filesystem::exists(frames_path)) {
      file.frames = readFrameIndexFile(frames_path);
      file.frames_path = frames_path;
      if (file.frames.size() != file.poses.size())
        throw InputError(frames_path, 0,
                         "lists " + std::to_string(file.frames.size()) + " frames but " + path + " has " +
                             std::to_string(file.poses.size()) + " poses (one frame index a pose expected)");
    } else {
      for (size_t i = 0; i < file.poses.size(); ++i) file.frames.push_back(static_cast<int>(i));
    }
  }
  if (file.poses.empty()) throw InputError(path, 0, "holds no poses");
  return file;
}

// The poses of the frames both files have, in frame order, so that line k of
// one pairs with line k of the other.
void pairByFrame(const TrajectoryFile& estimate, const TrajectoryFile& groundtruth,
                 std::vector<StampedPose>& estimate_paired, std::vector<StampedPose>& groundtruth_paired) {
  size_t g = 0;
  for (size_t e = 0; e < estimate.poses.size(); ++e) {
    while (g < groundtruth.frames.size() && groundtruth.frames[g] < estimate.frames[e]) ++g;
    if (g == groundtruth.frames.size()) break;
    if (groundtruth.frames[g] != estimate.frames[e]) continue;
    estimate_paired.push_back(estimate.poses[e]);
    groundtruth_paired.push_back(groundtruth.poses[g]);
  }
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6f", value);
  return text;
}

// "auto": the alignment the run's own report.json (beside the estimate) calls
// for: Sim(3) for a monocular run, whose scale is arbitrary, SE(3) for RGB-D.
// A file outside a run folder is taken as metric (SE(3)), and the output says so.
Alignment chooseAlignment(const EvalOptions& options, std::string& why) {
  if (options.align == "sim3") return Alignment::Sim3;
  if (options.align == "se3") return Alignment::SE3;
  const std::filesystem::path report = std::filesystem::path(options.estimate_path).parent_path() / "report.json";
  std::ifstream in(report);
  if (!in) {
    why = "no report.json beside the estimate: taken as metric";
    return Alignment::SE3;
  }
  nlohmann::json json;
  try {
    in >> json;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(report.string(), 0, std::string("not valid JSON (") + e.what() + "); pass --align se3|sim3");
  }
  const std::string mode = json.contains("mode") && json["mode"].is_string() ? json["mode"].get<std::string>() : "";
  if (mode == "mono") {
    why = "monocular run (" + report.string() + ")";
    return Alignment::Sim3;
  }
  if (mode == "rgbd") {
    why = "RGB-D run (" + report.string() + ")";
    return Alignment::SE3;
  }
  throw InputError(report.string(), 0, "has no \"mode\" of mono or rgbd; pass --align se3|sim3");
}

std::string lengthsText(const std::vector<double>& lengths) {
  std::string text;
  for (double length : lengths) {
    char value[32];
    std::snprintf(value, sizeof(value), "%g", length);
    text += (text.empty() ? "" : ", ") + std::string(value);
  }
  return text + " m";
}

// The KITTI odometry benchmark's error over the ground truth's frames; `scale`
// is the ATE's Sim(3) scale for a monocular estimate, else 1.
KittiOdometryResult kittiMetrics(const EvalOptions& options, const TrajectoryFile& estimate,
                                 const TrajectoryFile& groundtruth, double scale) {
  const int first_frame = groundtruth.frames.front();
  for (size_t k = 0; k < groundtruth.frames.size(); ++k)
    if (groundtruth.frames[k] != first_frame + static_cast<int>(k))
      throw InputError(groundtruth.frames_path, static_cast<int>(k + 1),
                       "--kitti-metrics needs the ground truth of every frame, and frame " +
                           std::to_string(first_frame + k) + " is missing (pass the sequence's poses/NN.txt)");
  std::vector<SE3> groundtruth_poses;
  for (const StampedPose& pose : groundtruth.poses) groundtruth_poses.push_back(pose.T_wc);
  std::vector<std::optional<SE3>> estimate_poses(groundtruth_poses.size());
  for (size_t e = 0; e < estimate.poses.size(); ++e) {
    const int k = estimate.frames[e] - first_frame;
    if (k >= 0 && k < static_cast<int>(estimate_poses.size())) estimate_poses[k] = estimate.poses[e].T_wc;
  }
  KittiOdometryOptions metric_options;
  if (!options.kitti_lengths.empty()) metric_options.lengths_m = options.kitti_lengths;
  metric_options.scale = scale;
  return computeKittiOdometryError(groundtruth_poses, estimate_poses, metric_options);
}

void printKittiMetrics(const KittiOdometryResult& result, Alignment alignment, double scale) {
  std::cout << "KITTI odometry (" << (result.standard_lengths ? "the benchmark's" : "NON-STANDARD") << " lengths "
            << lengthsText(result.lengths_m) << ", a subsequence every 10 frames";
  if (alignment == Alignment::Sim3)
    std::cout << "; Sim(3)-aligned first: estimate scaled by " << number(scale)
              << ", the ATE's scale, as monocular results are quoted";
  std::cout << "): ";
  if (!result.available) {
    std::cout << "none (" << result.unavailable_reason << ")\n";
    return;
  }
  std::cout << "translation " << number(result.translation_error_pct) << " %, rotation "
            << number(result.rotation_error_deg_per_100m) << " deg/100m over " << result.subsequences
            << " subsequences";
  for (const KittiLengthError& length : result.per_length) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g m", length.length_m);
    std::cout << (&length == &result.per_length.front() ? " (" : ", ") << text << ": " << length.subsequences;
  }
  std::cout << ")";
  if (result.subsequences_without_estimate > 0)
    std::cout << "; " << result.subsequences_without_estimate
              << " more not scored: their first or last frame has no estimate";
  std::cout << "\n";
  if (!result.standard_lengths)
    std::cout << "note: not comparable with KITTI benchmark figures, which use 100, 200, ..., 800 m\n";
}

int run(const EvalOptions& options) {
  const bool kitti = options.format == "kitti";
  if (options.kitti_metrics && !kitti)
    throw InputError("--kitti-metrics needs --format kitti (KITTI trajectories, paired by frame)");
  const TrajectoryFile estimate_file = readTrajectory(options.estimate_path, options.format);
  TrajectoryFile groundtruth_file = readTrajectory(options.groundtruth_path, options.format);
  if (!options.config_path.empty()) {
    const Config config = loadConfig(options.config_path);
    if (const std::optional<SE3>& camera_in_body = config.evaluation.groundtruth_camera_in_body) {
      for (StampedPose& pose : groundtruth_file.poses) pose.T_wc = pose.T_wc * *camera_in_body;
      std::cout << "ground truth taken to the camera by " << options.config_path
                << "'s evaluation.groundtruth_camera_in_body\n";
    }
  }
  std::vector<StampedPose> estimate = estimate_file.poses, groundtruth = groundtruth_file.poses;
  if (options.time_offset_s != 0.0) {
    if (kitti) throw InputError("--offset shifts timestamps; --format kitti pairs by frame and has none");
    for (StampedPose& pose : estimate) pose.timestamp += options.time_offset_s;
    std::cout << "estimate timestamps shifted by " << number(options.time_offset_s) << " s (--offset)\n";
  }
  if (kitti) {
    estimate.clear();
    groundtruth.clear();
    pairByFrame(estimate_file, groundtruth_file, estimate, groundtruth);
    if (!estimate_file.frames_path.empty() || !groundtruth_file.frames_path.empty())
      std::cout << "paired by frame (" << (estimate_file.frames_path.empty() ? groundtruth_file.frames_path
                                                                               : estimate_file.frames_path)
                << "): " << estimate.size() << " of " << estimate_file.poses.size()
                << " estimated poses have ground truth\n";
    else if (estimate_file.poses.size() != groundtruth_file.poses.size())
      spdlog::warn("{} has {} poses and {} has {}, and no frame index file ({}) says which frames they are; "
                   "pairing the first {} by line",
                   options.estimate_path, estimate_file.poses.size(), options.groundtruth_path,
                   groundtruth_file.poses.size(), kittiFrameIndexPath(options.estimate_path), estimate.size());
  }

  AteOptions ate_options;
  std::string why;
  ate_options.alignment = chooseAlignment(options, why);
  if (!why.empty()) std::cout << "alignment: " << toString(ate_options.alignment) << " (" << why << ")\n";
  ate_options.association = kitti ? Association::Index : Association::Timestamp;
  ate_options.max_time_diff = options.max_dt;
  AteResult ate;
  try {
    ate = computeAte(estimate, groundtruth, ate_options);
  } catch (const InputError& e) {
    throw InputError(options.estimate_path, 0,
                     std::string(e.what()) + " (ground truth: " + options.groundtruth_path + ")");
  }

  RpeOptions rpe_options;
  rpe_options.association = ate_options.association;
  rpe_options.max_time_diff = options.max_dt;
  rpe_options.delta = options.rpe_delta > 0 ? options.rpe_delta : (kitti ? 100.0 : 1.0);
  rpe_options.scale = ate.scale;  // 1 unless Sim(3): a monocular estimate's metric scale
  const RpeResult rpe = computeRpe(estimate, groundtruth, rpe_options);
  std::optional<KittiOdometryResult> kitti_result;
  if (options.kitti_metrics) kitti_result = kittiMetrics(options, estimate_file, groundtruth_file, ate.scale);

  std::cout << "ATE (" << toString(ate_options.alignment) << " alignment, " << ate.pairs << " pairs of "
            << estimate.size() << " estimated poses): rmse " << number(ate.rmse_m) << " m, mean " << number(ate.mean_m)
            << " m, median " << number(ate.median_m) << " m, std " << number(ate.std_m) << " m, min "
            << number(ate.min_m) << " m, max " << number(ate.max_m) << " m, scale " << number(ate.scale) << "\n";
  const std::string delta_text = number(rpe_options.delta) + (kitti ? " m" : " s");
  if (rpe.pairs > 0)
    std::cout << "RPE (interval " << delta_text << ", " << rpe.pairs << " pairs): translation rmse "
              << number(rpe.trans_rmse) << " " << rpe.trans_units << ", mean " << number(rpe.trans_mean) << " "
              << rpe.trans_units << "; rotation rmse " << number(rpe.rot_rmse_deg) << " " << rpe.rot_units << ", mean "
              << number(rpe.rot_mean_deg) << " " << rpe.rot_units << "\n";
  else
    std::cout << "RPE (interval " << delta_text << "): no pose pairs that far apart\n";
  if (kitti_result)
    printKittiMetrics(*kitti_result, ate_options.alignment, ate.scale);

  if (!options.json_path.empty()) {
    nlohmann::json json = toJson(ate);
    json["alignment"] = toString(ate_options.alignment);
    json["estimate"] = options.estimate_path;
    json["groundtruth"] = options.groundtruth_path;
    if (!options.config_path.empty()) json["config"] = options.config_path;
    json["time_offset_s"] = options.time_offset_s;
    nlohmann::json rpe_json = toJson(rpe);
    rpe_json["delta"] = rpe_options.delta;
    json["rpe"] = rpe_json;
    if (kitti_result) {
      nlohmann::json kitti_json = toJson(*kitti_result);
      kitti_json["scale"] = ate.scale;  // applied to the estimate (Sim(3) alignment), else 1
      json["kitti_odometry"] = kitti_json;
    }
    std::ofstream out(options.json_path);
    if (!(out << json.dump(2) << "\n")) throw InputError(options.json_path, 0, "cannot write file");
  }
  return 0;
}

}  // namespace

Command addEvalCommand(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  Command command;
  CLI::App* cli = app.add_subcommand("eval", "Score an estimated trajectory against ground truth (ATE, RPE)");
  cli->add_option("--est", options->estimate_path, "Estimated trajectory (camera-to-world poses)")->required();
  cli->add_option("--gt", options->groundtruth_path, "Ground-truth trajectory")->required();
  cli->add_option("--align", options->align,
                  "Alignment: se3 for metric runs, sim3 (with scale) for monocular ones; auto: from the run's "
                  "report.json beside --est (mono: sim3, rgbd: se3; no report: se3)")
      ->check(CLI::IsMember({"auto", "se3", "sim3"}))
      ->capture_default_str();
  cli->add_option("--format", options->format,
                  "File format: tum ('timestamp tx ty tz qx qy qz qw', paired by timestamp) or kitti (12 numbers "
                  "a line, paired by frame: line i is frame i, or as listed in NAME_frames.txt beside NAME.txt)")
      ->check(CLI::IsMember({"tum", "kitti"}))
      ->capture_default_str();
  cli->add_option("--config", options->config_path,
                  "A config whose evaluation section applies to --gt: groundtruth_camera_in_body takes ground "
                  "truth given for another body (Bonn RGB-D Dynamic's markers: config/bonn.yaml) to the camera. "
                  "A run folder's groundtruth.txt is the camera's already");
  cli->add_option("--json", options->json_path, "Also write the figures to this JSON file (default: none)");
  cli->add_option("--max-dt", options->max_dt, "Largest timestamp difference of a pair, seconds (tum format)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cli->add_option("--offset", options->time_offset_s,
                  "Seconds added to the estimate's timestamps before pairing (tum format), as the TUM "
                  "benchmark's evaluate_ate.py --offset: for a camera whose timestamps are known to be off "
                  "its ground truth's clock. Scores at 0 are the ones to quote")
      ->capture_default_str();
  cli->add_option("--rpe-delta", options->rpe_delta,
                  "RPE interval: seconds (tum) or metres (kitti); 0 = 1 s for tum, 100 m for kitti")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli->add_flag("--kitti-metrics", options->kitti_metrics,
                "With --format kitti: the KITTI odometry benchmark's translational (%) and rotational (deg/100m) "
                "errors over subsequences of 100, 200, ..., 800 m (after the Sim(3) scale for a monocular run)");
  cli->add_option("--kitti-lengths", options->kitti_lengths,
                  "Subsequence lengths in metres for --kitti-metrics instead of 100,...,800 (NON-STANDARD: said "
                  "so in the output; for sequences shorter than 100 m)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  command.cli = cli;
  command.run = [options] { return run(*options); };
  return command;
}

}  // namespace vslam::app
