// After a worker thread fails, `vslam run` still writes what was computed
// (docs/RELIABILITY.md): the System must then finish without hanging and still
// hand out its trajectories and map. This is the run's "failed" path, driven
// by a fault injected into Local Mapping.
#include <atomic>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

TEST(SlamFailure, AfterAWorkerFailsTheComputedTrajectoryAndMapAreStillThere) {
  const Sequence sequence = test::openSharedSequence("tum/fr1_xyz");
  Config config = sequence.config;
  config.detector.model = "none";
  SystemOptions options;
  options.after_keyframe_mapped = [](long id) {
    if (id == 3) throw std::runtime_error("injected failure at keyframe 3");
  };
  System system(config, options);
  std::string error;
  size_t frames_given = 0;
  try {
    for (; frames_given < 300; ++frames_given)
      system.processFrame(sequence.frames[frames_given].index, sequence.frames[frames_given].timestamp,
                          sequence.loadColor(frames_given));
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  ASSERT_NE(error.find("injected failure at keyframe 3"), std::string::npos) << error;
  ASSERT_LT(frames_given, 300u);  // the failure stopped the frame loop

  // As runSlam does after a failure: finish without a final BA; the failure is reported again.
  FinishOptions finish;
  finish.final_ba = false;
  EXPECT_THROW(system.finish(finish), std::runtime_error);
  const std::vector<StampedPose> trajectory = system.frameTrajectory();
  EXPECT_GT(trajectory.size(), 2u);
  EXPECT_LE(trajectory.size(), frames_given + 1);
  EXPECT_GE(system.keyframeTrajectory().size(), 3u);
  EXPECT_GT(system.mapPoints().size(), 100u);
  EXPECT_TRUE(system.keyframeTrajectoryBeforeFinalBa().empty());  // no final BA ran
}

}  // namespace
}  // namespace vslam
