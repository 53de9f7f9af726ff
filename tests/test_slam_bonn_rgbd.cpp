// RGB-D on Bonn RGB-D Dynamic `crowd` (../shared, 300 frames; people walk
// through an office): issue 15's RGB-D target, ATE <= 3 cm with moving
// objects handled. Without the detector, depth puts the walking people into
// the map at metric scale and the run ends 20-32 cm off; with the motion
// check of --moving-classes person, which judges each person by the keypoints
// at the person's depth, it stays within 2-3 cm.
// Threaded, with detection submitted ahead, as `vslam run` runs.
#include <iostream>
#include <memory>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "system_test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/eval/rpe.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

std::unique_ptr<System> runRgbd(const Sequence& sequence, const DetectorParams& detector) {
  Config config = sequence.config;
  config.sensor = SensorMode::RgbD;
  config.detector = detector;
  auto system = std::make_unique<System>(config, SystemOptions());
  test::feedFrames(*system, sequence, true);
  system->finish();
  return system;
}

AteResult metricAte(const std::vector<StampedPose>& trajectory, const Sequence& sequence) {
  AteOptions options;
  options.alignment = Alignment::SE3;
  return computeAte(trajectory, sequence.groundtruth, options);
}

TEST(SlamBonnRgbd, WalkingPeopleAreKeptOutOfTheMapByTheMotionCheck) {
  const Sequence sequence = test::openSharedSequence("bonn/crowd");
  ASSERT_EQ(sequence.frames.size(), 300u);

  DetectorParams off = sequence.config.detector;
  off.model = "none";
  const std::unique_ptr<System> plain = runRgbd(sequence, off);
  DetectorParams checked = sequence.config.detector;
  checked.moving_classes = {"person"};
  const std::unique_ptr<System> run = runRgbd(sequence, checked);

  const AteResult plain_frames = metricAte(plain->frameTrajectory(), sequence);
  const AteResult keyframes = metricAte(run->keyframeTrajectory(), sequence);
  const AteResult frames = metricAte(run->frameTrajectory(), sequence);
  const RpeResult drift = computeRpe(run->frameTrajectory(), sequence.groundtruth, RpeOptions());
  const SystemStats stats = run->stats();
  std::cout << "detector off: frame ATE " << plain_frames.rmse_m * 100 << " cm; motion-checked persons: "
            << stats.frames_tracked << " frames tracked, keyframe ATE " << keyframes.rmse_m * 100
            << " cm, frame ATE " << frames.rmse_m * 100 << " cm; person boxes moving " << stats.moving_boxes_moving
            << ", parked " << stats.moving_boxes_parked << "; RPE rotation " << drift.rot_rmse_deg << " deg/s\n";
  // Measured (threaded, 2 Dec 2026): detector off 20.2-31.3 cm (3 runs).
  // Checked, 9 runs: 300 frames tracked, keyframe ATE 1.79-3.13 cm, frame ATE
  // 1.69-2.06 cm, 211-225 person box-frames moving. Before the wall behind a
  // person was told from the person by depth (releaseBackgroundByDepth), 13
  // runs: 289-300 tracked, keyframe 2.41-7.72 cm, frame 1.94-8.79 cm, 88-136 moving.
  EXPECT_GT(plain_frames.rmse_m, 0.10);
  EXPECT_GE(stats.frames_tracked, 295);
  EXPECT_GT(stats.moving_boxes_moving, 170);
  EXPECT_LT(keyframes.rmse_m, 0.04);
  EXPECT_LT(frames.rmse_m, 0.03);
  // Scored against the markers' turn instead of the camera's (before
  // config/bonn.yaml's evaluation section), RPE read 10.3 deg/s.
  EXPECT_GT(drift.pairs, 200);
  EXPECT_LT(drift.rot_rmse_deg, 1.5);
}

}  // namespace
}  // namespace vslam
