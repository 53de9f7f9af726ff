// The motion check of --moving-classes on a static object that fills the
// view: fr3_teddy (../shared, 200 frames), whose teddy bear the detector calls
// `person` and `bear`, both COCO movable classes. The pose from the few static
// points around the bear is poor, and in the first frames after a start no
// point is old enough to vouch for a parked object, so the bear is judged
// moving. Before the check kept a frame's last matches, it retired the bear's
// points and lost the track: 42 of 200 frames tracked in mono, 145 in RGB-D
// (threaded, 3 runs each). Threaded, with detection submitted ahead, as
// `vslam run` runs.
#include <iostream>
#include <memory>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "system_test_support.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

SystemStats runTeddy(SensorMode sensor) {
  const Sequence sequence = test::openSharedSequence("tum/fr3_teddy");
  Config config = sequence.config;
  config.sensor = sensor;
  config.detector.moving_classes = {"coco-movable"};
  System system(config, SystemOptions());
  test::feedFrames(system, sequence, sensor == SensorMode::RgbD);
  system.finish();
  const SystemStats stats = system.stats();
  std::cout << (sensor == SensorMode::RgbD ? "RGB-D" : "mono") << ": " << stats.frames_tracked
            << " frames tracked, " << stats.map_resets << " resets; box-frames moving " << stats.moving_boxes_moving
            << ", parked " << stats.moving_boxes_parked << ", undecided " << stats.moving_boxes_undecided << "\n";
  return stats;
}

// Measured with the check's safeguard (one threaded run each): mono 199 of
// 200 frames, RGB-D 200 of 200, no reset.
TEST(SlamMotionCheck, ABearFillingTheViewNeverCostsTheTrackMonocular) {
  const SystemStats stats = runTeddy(SensorMode::Monocular);
  EXPECT_GE(stats.frames_tracked, 195);
  EXPECT_EQ(stats.map_resets, 0);
}

TEST(SlamMotionCheck, ABearFillingTheViewNeverCostsTheTrackRgbd) {
  const SystemStats stats = runTeddy(SensorMode::RgbD);
  EXPECT_GE(stats.frames_tracked, 195);
  EXPECT_EQ(stats.map_resets, 0);
}

}  // namespace
}  // namespace vslam
