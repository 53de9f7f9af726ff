// The monocular start on real data. Bonn RGB-D Dynamic `crowd` (../shared,
// 300 frames; people walk through an office while the camera turns) has a
// short, rotation-heavy baseline. Its consecutive-frame attempts find F
// motions whose translation direction is known only to 5-8 deg; before the
// initializer refused them (issue 16), the map started at frame 9 on such a
// motion and ended 3.3 cm (deterministic) / 4.1-5.3 cm (threaded) off.
// KITTI 00 (200 frames) drives forward at 10 Hz.
// Deterministic mode, so that the figures do not depend on timing.
#include <iostream>
#include <memory>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

// Every frame of `sequence`, monocular, detector off; deterministic (lock-step)
// or threaded as `vslam run` runs.
std::unique_ptr<System> runMonocular(const Sequence& sequence, bool deterministic = true) {
  Config config = sequence.config;
  config.sensor = SensorMode::Monocular;
  config.detector.model = "none";
  SystemOptions options;
  options.deterministic = deterministic;
  auto system = std::make_unique<System>(config, options);
  for (size_t i = 0; i < sequence.frames.size(); ++i)
    system->processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  system->finish();
  return system;
}

TEST(SlamMonoStart, BonnCrowdStartsFromAWellDeterminedMotion) {
  const Sequence sequence = test::openSharedSequence("bonn/crowd");
  const std::unique_ptr<System> run = runMonocular(sequence);
  const System& system = *run;

  const SystemStats stats = system.stats();
  AteOptions ate_options;
  ate_options.alignment = Alignment::Sim3;
  const AteResult keyframe_ate = computeAte(system.keyframeTrajectory(), sequence.groundtruth, ate_options);
  const AteResult frame_ate = computeAte(system.frameTrajectory(), sequence.groundtruth, ate_options);
  std::cout << "initialised at frame " << stats.initialised_at_index << ", " << system.frameTrajectory().size()
            << " frames tracked, keyframe ATE " << keyframe_ate.rmse_m * 100 << " cm, frame ATE "
            << frame_ate.rmse_m * 100 << " cm\n";
  // Measured: initialised at frame 18, 283 frames tracked, keyframe ATE 1.92 cm,
  // frame ATE 3.77 cm (before: frame 9, 284, 3.25 cm, 3.94 cm).
  EXPECT_GE(system.frameTrajectory().size(), 270u);
  EXPECT_LT(keyframe_ate.rmse_m, 0.026);
  EXPECT_LT(frame_ate.rmse_m, 0.045);
}

void expectKittiRoadStartsWithinTheFirstSecond(bool deterministic) {
  // With config/kitti_00-02.yaml (window search on pyramid levels 0-1).
  const Sequence sequence = test::openSharedSequence("kitti/00");
  const std::unique_ptr<System> run = runMonocular(sequence, deterministic);
  const System& system = *run;

  AteOptions ate_options;
  ate_options.alignment = Alignment::Sim3;
  const AteResult keyframe_ate = computeAte(system.keyframeTrajectory(), sequence.groundtruth, ate_options);
  std::cout << "initialised at frame " << system.stats().initialised_at_index << ", "
            << system.frameTrajectory().size() << " of " << sequence.frames.size() << " frames tracked, keyframe ATE "
            << keyframe_ate.rmse_m << " m\n";
  // Measured: frame 2, 199 of 200, 0.802 m deterministic, 0.705 m threaded
  // with the road's 2.3 deg two-view parallax (1.15 deg: 0.938 / 0.897 m;
  // before the start's matches carried their levels' variances 0.726 / 0.795
  // m; docs/BENCHMARKS.md, "KITTI 00 across start frames"). Level 0 only:
  // frame 13, 188, 0.884 / 0.963 m. Issue 18: start
  // within the first second (10 frames), track at least 98 %.
  EXPECT_LT(system.stats().initialised_at_index, 10);
  EXPECT_GE(system.frameTrajectory().size(), 196u);
  EXPECT_LT(keyframe_ate.rmse_m, 1.0);
}

TEST(SlamMonoStart, KittiRoadStartsWithinTheFirstSecond) { expectKittiRoadStartsWithinTheFirstSecond(true); }

// The start is Tracking's alone, so it is the same threaded; so, on these
// 200 frames, are the frames tracked (every threaded run measured: 199).
TEST(SlamMonoStart, KittiRoadStartsWithinTheFirstSecondThreaded) { expectKittiRoadStartsWithinTheFirstSecond(false); }

}  // namespace
}  // namespace vslam
