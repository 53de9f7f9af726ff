// Loop Closing's acceptance rule for the Sim(3) scale correction (exact values).
#include <gtest/gtest.h>

#include "vslam/slam/loop_closing.hpp"

namespace vslam {
namespace {

// Regression: a loop at Sim(3) scale 0.19 with the usual 40 matches was
// closed and warped a synthetic office map (47 cm ATE instead of 2 cm).
TEST(LoopScaleRule, ImplausibleScaleNeedsThreeTimesTheInliers) {
  EXPECT_TRUE(loopAccepted(1.0, 40));
  EXPECT_FALSE(loopAccepted(1.0, 39));
  EXPECT_TRUE(loopAccepted(0.5, 40));   // the plausible range is closed
  EXPECT_TRUE(loopAccepted(2.0, 40));
  EXPECT_FALSE(loopAccepted(0.19, 40));
  EXPECT_FALSE(loopAccepted(0.49, 119));
  EXPECT_TRUE(loopAccepted(0.49, 120));
  EXPECT_FALSE(loopAccepted(2.01, 100));
  EXPECT_TRUE(loopAccepted(3.0, 120));
  EXPECT_FALSE(loopAccepted(0.0, 1000));
  EXPECT_FALSE(loopAccepted(-1.0, 1000));
  LoopScaleRule strict;
  strict.min_inliers_implausible = 200;
  EXPECT_FALSE(loopAccepted(0.3, 150, strict));
}

}  // namespace
}  // namespace vslam
