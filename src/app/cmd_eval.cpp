// `vslam eval`: scores an estimated trajectory against ground truth (ATE and RPE).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "vslam/core/error.hpp"
#include "vslam/eval/ate.hpp"
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
  double max_dt = 0.02;
  double rpe_delta = 0.0;  // 0 = 1 s (TUM) or 100 m (KITTI)
};

std::vector<StampedPose> readTrajectory(const std::string& path, const std::string& format) {
  std::vector<StampedPose> poses = format == "kitti" ? readKittiTrajectory(path) : readTumTrajectory(path);
  if (poses.empty()) throw InputError(path, 0, "holds no poses");
  return poses;
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

int run(const EvalOptions& options) {
  const bool kitti = options.format == "kitti";
  const std::vector<StampedPose> estimate = readTrajectory(options.estimate_path, options.format);
  const std::vector<StampedPose> groundtruth = readTrajectory(options.groundtruth_path, options.format);
  if (kitti && estimate.size() != groundtruth.size())
    spdlog::warn("{} has {} poses and {} has {}; pairing the first {} by index", options.estimate_path, estimate.size(),
                 options.groundtruth_path, groundtruth.size(), std::min(estimate.size(), groundtruth.size()));

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

  if (!options.json_path.empty()) {
    nlohmann::json json = toJson(ate);
    json["alignment"] = toString(ate_options.alignment);
    json["estimate"] = options.estimate_path;
    json["groundtruth"] = options.groundtruth_path;
    nlohmann::json rpe_json = toJson(rpe);
    rpe_json["delta"] = rpe_options.delta;
    json["rpe"] = rpe_json;
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
                  "a line, paired by line)")
      ->check(CLI::IsMember({"tum", "kitti"}))
      ->capture_default_str();
  cli->add_option("--json", options->json_path, "Also write the figures to this JSON file (default: none)");
  cli->add_option("--max-dt", options->max_dt, "Largest timestamp difference of a pair, seconds (tum format)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cli->add_option("--rpe-delta", options->rpe_delta,
                  "RPE interval: seconds (tum) or metres (kitti); 0 = 1 s for tum, 100 m for kitti")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command.cli = cli;
  command.run = [options] { return run(*options); };
  return command;
}

}  // namespace vslam::app
