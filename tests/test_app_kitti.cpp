// KITTI runs and `vslam eval --format kitti` end to end (issue 18): the run
// folder's trajectory_kitti.txt with its frame index file and the ground truth
// of the same frames, the KITTI odometry figures in report.json (null with a
// reason when the road is too short, never 0), and eval's pairing by frame and
// --kitti-metrics.
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/eval/kitti_odometry_metric.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

using test::contains;
using test::quoted;
using test::slurp;
using Outcome = test::CliOutcome;

Outcome vslam(const std::string& args) {
  return test::runFromProjectRoot(test::vslamBinary() + " " + args, test::callDir("app_kitti_"));
}

std::string officialPoses() { return (test::sharedData() / "kitti" / "poses" / "00.txt").string(); }

TEST(KittiRun, WritesTheKittiTrajectoryWithItsFramesAndNoFigureForAShortRoad) {
  const fs::path out = test::scratchDir("app_kitti_run") / "run";
  const Outcome run = vslam("run --seq kitti/00 --max-frames 30 --detector none --no-render --out " +
                            quoted(out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));

  // One line per tracked frame, the same poses as trajectory.txt; the frames
  // without a line are exactly the lost ones.
  const std::vector<StampedPose> tum = readTumTrajectory((out / "trajectory.txt").string());
  const std::vector<StampedPose> kitti = readKittiTrajectory((out / "trajectory_kitti.txt").string());
  const std::vector<int> frames = readFrameIndexFile((out / "trajectory_kitti_frames.txt").string());
  ASSERT_GT(tum.size(), 3u);
  ASSERT_EQ(kitti.size(), tum.size());
  ASSERT_EQ(frames.size(), tum.size());
  for (size_t i = 0; i < tum.size(); ++i) {
    EXPECT_NEAR(0.1 * frames[i], tum[i].timestamp, 1e-6) << i;  // times.txt: 0.1 s steps
    EXPECT_LT((kitti[i].T_wc.t - tum[i].T_wc.t).norm(), 1e-6) << i;
    EXPECT_LT((kitti[i].T_wc.R - tum[i].T_wc.R).cwiseAbs().maxCoeff(), 1e-6) << i;
  }
  std::vector<int> lost = report["frames_lost"].get<std::vector<int>>();
  std::vector<int> all_frames = frames;
  all_frames.insert(all_frames.end(), lost.begin(), lost.end());
  std::sort(all_frames.begin(), all_frames.end());
  ASSERT_EQ(all_frames.size(), 30u);
  for (int k = 0; k < 30; ++k) EXPECT_EQ(all_frames[k], k);

  // The ground truth of the same frames, line for line (evo_ape kitti and the devkit want equal counts).
  const std::vector<StampedPose> official = readKittiTrajectory(officialPoses());
  const std::vector<StampedPose> groundtruth = readKittiTrajectory((out / "groundtruth_kitti.txt").string());
  ASSERT_EQ(groundtruth.size(), frames.size());
  for (size_t i = 0; i < frames.size(); ++i)
    EXPECT_LT((groundtruth[i].T_wc.t - official[frames[i]].T_wc.t).norm(), 1e-6) << i;
  EXPECT_EQ(readFrameIndexFile((out / "groundtruth_kitti_frames.txt").string()), frames);

  const nlohmann::json& files = report["kitti_trajectory"];
  EXPECT_EQ(files["file"], "trajectory_kitti.txt");
  EXPECT_EQ(files["frames_file"], "trajectory_kitti_frames.txt");
  EXPECT_EQ(files["poses"].get<size_t>(), frames.size());
  EXPECT_EQ(files["frames_without_pose"].get<size_t>(), 30 - frames.size());
  // 30 frames are 25.7 m of road: no 100 m subsequence, so no figure, and why.
  const nlohmann::json& metric = report["kitti_odometry"];
  ASSERT_TRUE(metric.is_object()) << report.dump(2);
  EXPECT_EQ(metric["available"], false);
  EXPECT_TRUE(metric["translation_error_pct"].is_null());
  EXPECT_TRUE(metric["rotation_error_deg_per_100m"].is_null());
  EXPECT_TRUE(contains(metric["reason"].get<std::string>(), "over 30 frames; no subsequence of 100.0 m")) << metric;
  EXPECT_EQ(metric["alignment"], "sim3");
  EXPECT_TRUE(contains(run.out, "KITTI odometry:     none (the ground truth covers")) << run.out;

  // eval takes the KITTI file directly and pairs it by frame with the official poses...
  const std::string est = (out / "trajectory_kitti.txt").string();
  const Outcome eval = vslam("eval --format kitti --est " + quoted(est) + " --gt " + quoted(officialPoses()));
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_TRUE(contains(eval.out, "paired by frame (" + (out / "trajectory_kitti_frames.txt").string() + "): " +
                                     std::to_string(frames.size()) + " of " + std::to_string(frames.size())))
      << eval.out;
  EXPECT_TRUE(contains(eval.out, "alignment: sim3 (monocular run")) << eval.out;
  EXPECT_TRUE(contains(eval.out, "ATE (sim3 alignment, " + std::to_string(frames.size()) + " pairs")) << eval.out;
  // ... and with the folder's own ground truth, to the same ATE.
  const Outcome own = vslam("eval --format kitti --est " + quoted(est) + " --gt " +
                            quoted((out / "groundtruth_kitti.txt").string()));
  ASSERT_EQ(own.exit_code, 0) << own.err;
  const auto ateLine = [](const std::string& text) { return text.substr(text.find("ATE ("), 120); };
  EXPECT_EQ(ateLine(own.out), ateLine(eval.out));

  // The run's frames are 0..29, the 100 m subsequences of 00 start at 0..40 and end at 137..184.
  const Outcome metrics = vslam("eval --format kitti --kitti-metrics --est " + quoted(est) + " --gt " +
                                quoted(officialPoses()));
  ASSERT_EQ(metrics.exit_code, 0) << metrics.err;
  EXPECT_TRUE(contains(metrics.out, "none (none of the 5 subsequences has an estimate at both its first and last "
                                    "frame)"))
      << metrics.out;

  // The TUM file with --format kitti: refused, pointing at the KITTI one.
  const Outcome tum_as_kitti = vslam("eval --format kitti --est " + quoted((out / "trajectory.txt").string()) +
                                     " --gt " + quoted(officialPoses()));
  EXPECT_EQ(tum_as_kitti.exit_code, 2);
  EXPECT_TRUE(contains(tum_as_kitti.err, "the run's KITTI-format trajectory is " + est)) << tum_as_kitti.err;
}

// 00's ground truth, every position 1 % further out, with frames 0, 5 and 160
// lost: those lines are missing and the frame index file says so.
fs::path writeDriftedCopyWithLostFrames(const std::string& name, double scale) {
  const fs::path dir = test::scratchDir(name);
  std::vector<StampedPose> poses;
  std::vector<int> frames;
  const std::vector<StampedPose> official = readKittiTrajectory(officialPoses());
  for (size_t k = 0; k < official.size(); ++k) {
    if (k == 0 || k == 5 || k == 160) continue;
    StampedPose pose = official[k];
    pose.T_wc.t *= scale;
    poses.push_back(pose);
    frames.push_back(static_cast<int>(k));
  }
  writeKittiTrajectory((dir / "est.txt").string(), poses);
  writeFrameIndexFile((dir / "est_frames.txt").string(), frames);
  return dir;
}

TEST(KittiEval, MetricsPairByFrameAndSkipSubsequencesWithLostEnds) {
  const fs::path dir = writeDriftedCopyWithLostFrames("app_kitti_eval_drift", 1.01);
  const std::string json_path = (dir / "eval.json").string();
  const Outcome eval = vslam("eval --format kitti --align se3 --kitti-metrics --est " +
                             quoted((dir / "est.txt").string()) + " --gt " + quoted(officialPoses()) + " --json " +
                             quoted(json_path));
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_TRUE(contains(eval.out, "197 of 197 estimated poses have ground truth")) << eval.out;
  // Frames 0 and 160 end two of the five subsequences; the three left, by the
  // library on the same poses (its exact values are tested in test_eval_kitti_odometry).
  std::vector<SE3> groundtruth;
  for (const StampedPose& pose : readKittiTrajectory(officialPoses())) groundtruth.push_back(pose.T_wc);
  std::vector<std::optional<SE3>> estimate;
  for (size_t k = 0; k < groundtruth.size(); ++k)
    if (k != 0 && k != 5 && k != 160)
      estimate.emplace_back(SE3(groundtruth[k].R, 1.01 * groundtruth[k].t));
    else
      estimate.emplace_back();
  const KittiOdometryResult expected = computeKittiOdometryError(groundtruth, estimate);
  ASSERT_EQ(expected.subsequences, 3);
  const nlohmann::json json = nlohmann::json::parse(slurp(json_path));
  const nlohmann::json& metric = json["kitti_odometry"];
  EXPECT_EQ(metric["subsequences"], 3);
  EXPECT_EQ(metric["subsequences_without_estimate"], 2);
  EXPECT_NEAR(metric["translation_error_pct"].get<double>(), expected.translation_error_pct, 1e-6);
  EXPECT_GT(expected.translation_error_pct, 0.5);
  EXPECT_EQ(metric["scale"], 1.0);
  EXPECT_TRUE(contains(eval.out, "KITTI odometry (the benchmark's lengths 100, 200, 300, 400, 500, 600, 700, 800 m")) << eval.out;
  EXPECT_TRUE(contains(eval.out, "over 3 subsequences (100 m: 3); 2 more not scored")) << eval.out;
  // The ATE pairs by frame too (by line, frame 1's pose would meet frame 0's ground truth).
  EXPECT_TRUE(contains(eval.out, "ATE (se3 alignment, 197 pairs of 197 estimated poses)")) << eval.out;
  std::vector<StampedPose> estimate_paired, groundtruth_paired;
  for (size_t k = 0; k < groundtruth.size(); ++k)
    if (estimate[k]) {
      estimate_paired.push_back({0.1 * k, *estimate[k]});
      groundtruth_paired.push_back({0.1 * k, groundtruth[k]});
    }
  AteOptions by_index;
  by_index.association = Association::Index;
  EXPECT_NEAR(json["rmse_m"].get<double>(), computeAte(estimate_paired, groundtruth_paired, by_index).rmse_m, 1e-9);

  // Sim(3): a half-size copy is scored with the ATE's scale (2), and says so; nothing is left.
  const fs::path half = writeDriftedCopyWithLostFrames("app_kitti_eval_half", 0.5);
  const Outcome sim3 = vslam("eval --format kitti --align sim3 --kitti-metrics --est " +
                             quoted((half / "est.txt").string()) + " --gt " + quoted(officialPoses()));
  ASSERT_EQ(sim3.exit_code, 0) << sim3.err;
  EXPECT_TRUE(contains(sim3.out, "Sim(3)-aligned first: estimate scaled by 2.000000")) << sim3.out;
  EXPECT_TRUE(contains(sim3.out, "translation 0.000000 %")) << sim3.out;

  // Shorter lengths when asked, labelled as not the benchmark's.
  const Outcome shorter = vslam("eval --format kitti --align se3 --kitti-metrics --kitti-lengths 20,40 --est " +
                                quoted((dir / "est.txt").string()) + " --gt " + quoted(officialPoses()));
  ASSERT_EQ(shorter.exit_code, 0) << shorter.err;
  EXPECT_TRUE(contains(shorter.out, "KITTI odometry (NON-STANDARD lengths 20, 40 m")) << shorter.out;
  EXPECT_TRUE(contains(shorter.out, "note: not comparable with KITTI benchmark figures")) << shorter.out;
}

TEST(KittiEval, BadFrameIndexFilesAndOptionsExitTwoWithOneLine) {
  const fs::path dir = writeDriftedCopyWithLostFrames("app_kitti_eval_bad", 1.0);
  const std::string est = quoted((dir / "est.txt").string());
  const std::string frames = (dir / "est_frames.txt").string();
  std::ofstream(frames) << "0\n1\n";
  const Outcome count = vslam("eval --format kitti --est " + est + " --gt " + quoted(officialPoses()));
  EXPECT_EQ(count.exit_code, 2);
  EXPECT_EQ(count.err, "error: " + frames + ": lists 2 frames but " + (dir / "est.txt").string() +
                           " has 197 poses (one frame index a pose expected)\n");
  std::ofstream(frames) << "0\n2\n1\n";
  const Outcome order = vslam("eval --format kitti --est " + est + " --gt " + quoted(officialPoses()));
  EXPECT_EQ(order.exit_code, 2);
  EXPECT_EQ(order.err, "error: " + frames + ":3: frame index 1 does not increase (previous line has 2)\n");
  std::ofstream(frames) << "0\n-1\n";
  const Outcome negative = vslam("eval --format kitti --est " + est + " --gt " + quoted(officialPoses()));
  EXPECT_EQ(negative.err, "error: " + frames + ":2: frame index '-1' is not a non-negative integer\n");

  const Outcome tum = vslam("eval --kitti-metrics --est " + est + " --gt " + quoted(officialPoses()));
  EXPECT_EQ(tum.exit_code, 2);
  EXPECT_EQ(tum.err, "error: --kitti-metrics needs --format kitti (KITTI trajectories, paired by frame)\n");
}

}  // namespace
}  // namespace vslam
