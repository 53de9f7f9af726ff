// The monocular start on real data with a short, rotation-heavy baseline:
// Bonn RGB-D Dynamic `crowd` (../shared, 300 frames; people walk through an
// office while the camera turns). Its consecutive-frame attempts find F
// motions whose translation direction is known only to 5-8 deg; before the
// initializer refused them (issue 16), the map started at frame 9 on such a
// motion and ended 3.3 cm (deterministic) / 4.1-5.3 cm (threaded) off.
// Deterministic mode, so that the figures do not depend on timing.
#include <iostream>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

TEST(SlamMonoStart, BonnCrowdStartsFromAWellDeterminedMotion) {
  const Sequence sequence = test::openSharedSequence("bonn/crowd");
  Config config = sequence.config;
  config.sensor = SensorMode::Monocular;
  config.detector.model = "none";
  SystemOptions options;
  options.deterministic = true;
  System system(config, options);
  for (size_t i = 0; i < sequence.frames.size(); ++i)
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  system.finish();

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

}  // namespace
}  // namespace vslam
