// The kidnapped camera (issue 16): fr1_xyz (monocular) and fr3_teddy
// (monocular and RGB-D) played in six pieces with the camera teleported
// between them, four times back to places already mapped and once forward to
// frames never seen. Each jump is covered by three black frames (a jump alone
// need not lose tracking on fr1_xyz: matching the reference keyframe can
// bridge it, docs/LOOP_CLOSING.md), so every jump is a loss, and the camera
// must be relocalised within its first 3 frames, at a pose within 3 cm of the
// ground truth once the whole run is aligned to it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

struct Piece {
  size_t first, last;  // sequence frames, inclusive
};

// The first piece builds the map; after it: back, forward (400-529 were never
// seen; frame 400 is 9 cm from the nearest mapped camera in the ground truth),
// back, back into the forward piece, back to the start. A forward jump to
// frame 300, 16 cm from any mapped camera, relocalises as fast but 1-4 cm off
// (docs/BENCHMARKS.md, issue 16).
const std::vector<Piece> kFr1XyzPieces = {{0, 149}, {30, 119}, {400, 529}, {60, 139}, {430, 509}, {0, 99}};
// fr3_teddy: only its first 200 frames are in ../shared, a 1.5 m arc around
// the teddy bear at about 1 cm per frame that never comes back, so the pieces
// are shorter than fr1_xyz's (30-50 frames after the 80 that build the map)
// and every place revisited is one the run itself mapped earlier. After the
// first piece: back, forward (80-82 skipped, 83-132 never seen: frame 83 is
// 4.4 cm from frame 79, the nearest mapped camera, and 14 cm from frame 69,
// where the threaded monocular run's last keyframe of the first piece falls),
// back, back into the forward piece, back to the start (frame 5: frames 0-4
// have no ground truth within 0.02 s). Forward jumps relocalise at once up to
// about 24 cm from the nearest keyframe and not from 25 cm on. A jump to frame
// 92 (13.8 cm from frame 79, 23.6 cm from frame 69) relocalised in 10 of 10
// threaded runs with the window search's threshold at 60, and in 0 of 3 at 55,
// where the keyframes fall differently; frames 86 and 88 also failed 3 of 3.
// With the detector on, the forward jump was not relocalised (docs/BENCHMARKS.md).
const std::vector<Piece> kFr3TeddyPieces = {{0, 79}, {20, 59}, {83, 132}, {40, 74}, {98, 127}, {5, 44}};
constexpr int kBlackFrames = 3;
constexpr int kMaxRelocalisationLatency = 2;  // frames lost after the jump: relocalised by its 3rd frame
constexpr double kMaxRelocalisedError = 0.03;

struct Jump {
  int latency = -1;           // real frames after the jump before the relocalised one (0: the first)
  double stamp = 0;           // restamped time of the relocalised frame
  SE3 T_wc;                   // its pose as Tracking relocalised it
  double error_m = -1;        // after the run's Sim(3) alignment to the ground truth
  double final_error_m = -1;  // the same frame in the run's final trajectory
};

struct KidnappedRun {
  std::vector<Piece> pieces;  // as played, for the printout
  std::vector<Jump> jumps;
  int relocalisations = 0;
  Alignment alignment = Alignment::Sim3;  // of the run to the ground truth
  double frame_ate_m = 0;
  std::vector<double> piece_median_error_m;  // of the frames tracked in each piece
};

// Nearest ground-truth pose of a frame, within 0.02 s (TUM's association).
const StampedPose* groundTruthOf(const Sequence& sequence, double timestamp) {
  const StampedPose* nearest = nullptr;
  for (const StampedPose& pose : sequence.groundtruth)
    if (!nearest || std::abs(pose.timestamp - timestamp) < std::abs(nearest->timestamp - timestamp)) nearest = &pose;
  return nearest && std::abs(nearest->timestamp - timestamp) < 0.02 ? nearest : nullptr;
}

enum class Detector { Off, Default };

// Plays `pieces` of the sequence in order, monocular or with depth. An RGB-D
// run is aligned to the ground truth rigidly (its map is metric), a monocular
// one with scale.
KidnappedRun runKidnapped(const Sequence& sequence, const std::vector<Piece>& pieces, SensorMode sensor,
                          bool deterministic, Detector detector = Detector::Off) {
  SystemOptions options;
  options.deterministic = deterministic;
  Config config = sequence.config;
  config.sensor = sensor;
  if (detector == Detector::Off) config.detector.model = "none";
  config.loop.final_ba = false;
  System system(config, options);
  const bool with_depth = sensor == SensorMode::RgbD;

  // Frames get new, increasing timestamps (30 Hz, black frames included); the
  // ground truth of the original frame is restamped the same way.
  const double t0 = sequence.frames[0].timestamp;
  std::vector<StampedPose> groundtruth;
  KidnappedRun run;
  run.pieces = pieces;
  int step = 0;
  const cv::Mat black = cv::Mat::zeros(config.camera.height, config.camera.width, CV_8UC3);
  // A black frame of an RGB-D run has a depth image with no measurement, so
  // that it is not counted as a frame without depth.
  const cv::Mat no_depth = with_depth ? cv::Mat::zeros(black.size(), CV_32F) : cv::Mat();
  for (size_t p = 0; p < pieces.size(); ++p) {
    if (p > 0) {
      for (int k = 0; k < kBlackFrames; ++k) {
        const int index = -static_cast<int>(p * kBlackFrames + k) - 1;
        EXPECT_FALSE(system.processFrame(index, t0 + step++ / 30.0, black, no_depth));
      }
      run.jumps.emplace_back();
    }
    for (size_t i = pieces[p].first; i <= pieces[p].last; ++i) {
      const double stamp = t0 + step++ / 30.0;
      if (const StampedPose* truth = groundTruthOf(sequence, sequence.frames[i].timestamp))
        groundtruth.push_back({stamp, truth->T_wc});
      const int relocalisations_before = system.stats().relocalisations;
      const cv::Mat colour = sequence.loadColor(i);
      const bool depth_here = with_depth && !sequence.frames[i].depth_path.empty();
      system.processFrame(sequence.frames[i].index, stamp, colour,
                          depth_here ? sequence.loadDepthMeters(i, colour.size()) : cv::Mat());
      if (p == 0 || run.jumps.back().latency >= 0) continue;
      if (system.stats().relocalisations > relocalisations_before) {
        Jump& jump = run.jumps.back();
        jump.latency = static_cast<int>(i - pieces[p].first);
        jump.stamp = stamp;
        for (const StampedPose& pose : system.frameTrajectory())
          if (pose.timestamp == stamp) jump.T_wc = pose.T_wc;
      }
    }
  }
  system.finish();
  run.relocalisations = system.stats().relocalisations;

  AteOptions ate_options;
  ate_options.alignment = with_depth ? Alignment::SE3 : Alignment::Sim3;
  const AteResult ate = computeAte(system.frameTrajectory(), groundtruth, ate_options);
  run.alignment = ate_options.alignment;
  run.frame_ate_m = ate.rmse_m;
  std::map<double, SE3> truth_at;
  for (const StampedPose& pose : groundtruth) truth_at[pose.timestamp] = pose.T_wc;
  // Steps of each piece's first and last frame, for the per-piece medians.
  const std::vector<StampedPose> frames = system.frameTrajectory();
  std::vector<std::vector<double>> piece_errors(pieces.size());
  for (size_t k = 0; k < ate.pairs_idx.size(); ++k) {
    const long frame_step = std::lround((frames[ate.pairs_idx[k].first].timestamp - t0) * 30.0);
    long first_step = 0;
    for (size_t p = 0; p < pieces.size(); ++p) {
      if (p > 0) first_step += kBlackFrames;
      const long count = static_cast<long>(pieces[p].last - pieces[p].first + 1);
      if (frame_step >= first_step && frame_step < first_step + count) piece_errors[p].push_back(ate.errors_m[k]);
      first_step += count;
    }
  }
  for (std::vector<double>& errors : piece_errors) {
    std::sort(errors.begin(), errors.end());
    run.piece_median_error_m.push_back(errors.empty() ? -1 : errors[errors.size() / 2]);
  }
  for (Jump& jump : run.jumps) {
    auto truth = truth_at.find(jump.stamp);
    if (jump.latency < 0 || truth == truth_at.end()) continue;
    jump.error_m = (ate.alignment * jump.T_wc.t - truth->second.t).norm();
    for (const StampedPose& pose : system.frameTrajectory())
      if (pose.timestamp == jump.stamp) jump.final_error_m = (ate.alignment * pose.T_wc.t - truth->second.t).norm();
  }
  return run;
}

// Every jump relocalised by its third frame; the relocalised pose within 3 cm
// for the jumps numbered in `position_checked` (1-based).
void expectEveryJumpRelocalised(const KidnappedRun& run, const std::set<size_t>& position_checked) {
  EXPECT_EQ(run.relocalisations, static_cast<int>(run.pieces.size()) - 1);
  ASSERT_EQ(run.jumps.size(), run.pieces.size() - 1);
  for (size_t j = 0; j < run.jumps.size(); ++j) {
    const Jump& jump = run.jumps[j];
    // Printed for docs/BENCHMARKS.md (issue 16).
    std::printf("jump %zu to frame %zu: relocalised after %d frame(s), %.2f cm from the ground truth (%.2f cm in "
                "the final trajectory)\n",
                j + 1, run.pieces[j + 1].first, jump.latency, 100 * jump.error_m, 100 * jump.final_error_m);
    EXPECT_GE(jump.latency, 0) << "jump " << j + 1 << " never relocalised";
    EXPECT_LE(jump.latency, kMaxRelocalisationLatency) << "jump " << j + 1;
    EXPECT_GE(jump.error_m, 0) << "jump " << j + 1 << ": no ground truth or no pose";
    if (position_checked.count(j + 1)) EXPECT_LT(jump.error_m, kMaxRelocalisedError) << "jump " << j + 1;
  }
  std::printf("frame ATE (%s) %.2f cm; median error per piece:", toString(run.alignment), 100 * run.frame_ate_m);
  for (double error : run.piece_median_error_m) std::printf(" %.2f", 100 * error);
  std::printf(" cm\n");
}

Sequence fr1Xyz() { return test::openSharedSequence("tum/fr1_xyz"); }
Sequence fr3Teddy() { return test::openSharedSequence("tum/fr3_teddy"); }

TEST(SlamKidnapped, Fr1XyzRelocalisesEveryJumpDeterministic) {
  expectEveryJumpRelocalised(runKidnapped(fr1Xyz(), kFr1XyzPieces, SensorMode::Monocular, true), {1, 2, 3, 4, 5});
}

// Threaded, jumps 2 and 4 (into the map built after the forward jump) were
// 1.9-3.3 cm off over six runs on 2 Dec and were held to 3 cm in deterministic
// mode only. On 3 Dec (every frame posed again) 16 threaded runs, 6 of them
// beside a second test, put them at most 2.47 cm off, so the bound now holds
// for every jump (docs/BENCHMARKS.md, issue 16). That was too few runs: on
// 4 Dec jump 4 went over 3 cm in 2 of 65 runs (3.46 and 3.91 cm) and in one CI
// run (3.43 cm), where the live map's keyframe near frame 430 is 2-3 cm off.
// The bound is the and stays; this test fails about 3 % of runs until
// the live map is better there (docs/BENCHMARKS.md, "Stop 38").
TEST(SlamKidnapped, Fr1XyzRelocalisesEveryJumpThreaded) {
  expectEveryJumpRelocalised(runKidnapped(fr1Xyz(), kFr1XyzPieces, SensorMode::Monocular, false), {1, 2, 3, 4, 5});
}

// Issue 16: fr1_xyz keeps relocalising every jump with the detector on too
// (the default detector: auto rate, labels only).
TEST(SlamKidnapped, Fr1XyzWithTheDefaultDetectorRelocalisesEveryJumpThreaded) {
  expectEveryJumpRelocalised(
      runKidnapped(fr1Xyz(), kFr1XyzPieces, SensorMode::Monocular, false, Detector::Default), {1, 2, 3, 4, 5});
}

TEST(SlamKidnapped, Fr3TeddyRelocalisesEveryJumpDeterministic) {
  expectEveryJumpRelocalised(runKidnapped(fr3Teddy(), kFr3TeddyPieces, SensorMode::Monocular, true), {1, 2, 3, 4, 5});
}

TEST(SlamKidnapped, Fr3TeddyRelocalisesEveryJumpThreaded) {
  expectEveryJumpRelocalised(runKidnapped(fr3Teddy(), kFr3TeddyPieces, SensorMode::Monocular, false), {1, 2, 3, 4, 5});
}

// With depth the map is metric from frame 0, and the run is aligned without scale.
TEST(SlamKidnapped, Fr3TeddyRgbdRelocalisesEveryJumpDeterministic) {
  expectEveryJumpRelocalised(runKidnapped(fr3Teddy(), kFr3TeddyPieces, SensorMode::RgbD, true), {1, 2, 3, 4, 5});
}

TEST(SlamKidnapped, Fr3TeddyRgbdRelocalisesEveryJumpThreaded) {
  expectEveryJumpRelocalised(runKidnapped(fr3Teddy(), kFr3TeddyPieces, SensorMode::RgbD, false), {1, 2, 3, 4, 5});
}

// With the detector on: the paper's filter every frame made fewer RGB-D
// keyframes and missed the forward jump (stop 24). The default detector
// (auto rate, labels only) tracks on the detector-off keypoints.
TEST(SlamKidnapped, Fr3TeddyRgbdWithTheDefaultDetectorRelocalisesEveryJumpThreaded) {
  expectEveryJumpRelocalised(runKidnapped(fr3Teddy(), kFr3TeddyPieces, SensorMode::RgbD, false, Detector::Default),
                             {1, 2, 3, 4, 5});
}

}  // namespace
}  // namespace vslam
