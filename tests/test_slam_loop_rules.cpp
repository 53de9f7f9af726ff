// Loop Closing's rules, on hand-made inputs (exact values): the acceptance of
// the Sim(3) scale correction and ORB-SLAM2's covisibility consistency.
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

// ORB-SLAM2 accepts a loop candidate after 3 consistent detections following
// the first one: 4 consecutive keyframes. The count used to start at 1, so 3
// consecutive keyframes were enough.
TEST(LoopConsistency, ACandidateNeedsFourConsecutiveKeyFrames) {
  std::vector<ConsistentGroup> groups;
  const std::vector<std::set<long>> place = {{10, 11, 12}};
  EXPECT_TRUE(updateConsistentGroups(groups, place, 3).empty());  // first detection: consistency 0
  EXPECT_EQ(groups.at(0).consistency, 0);
  EXPECT_TRUE(updateConsistentGroups(groups, {{12, 13}}, 3).empty());  // overlaps by keyframe 12: 1
  EXPECT_EQ(groups.at(0).consistency, 1);
  EXPECT_TRUE(updateConsistentGroups(groups, {{13, 14}}, 3).empty());  // 2
  const std::vector<size_t> accepted = updateConsistentGroups(groups, {{20, 21}, {14, 15}}, 3);
  ASSERT_EQ(accepted.size(), 1u);  // the fourth keyframe: the overlapping candidate, index 1
  EXPECT_EQ(accepted[0], 1u);
  EXPECT_EQ(groups.at(0).consistency, 0);  // a new place starts again
  EXPECT_EQ(groups.at(1).consistency, 3);
}

TEST(LoopConsistency, AKeyFrameWithoutCandidatesBreaksTheChain) {
  std::vector<ConsistentGroup> groups;
  updateConsistentGroups(groups, {{1, 2}}, 3);
  updateConsistentGroups(groups, {{2, 3}}, 3);
  updateConsistentGroups(groups, {}, 3);
  EXPECT_TRUE(groups.empty());
  updateConsistentGroups(groups, {{3, 4}}, 3);
  EXPECT_EQ(groups.at(0).consistency, 0);
}

// The highest consistency among the overlapping previous groups carries on.
TEST(LoopConsistency, TheMostConsistentOverlappingGroupCarriesOn) {
  std::vector<ConsistentGroup> groups = {{{1, 2}, 2}, {{5, 6}, 0}};
  const std::vector<size_t> accepted = updateConsistentGroups(groups, {{2, 5}}, 3);
  ASSERT_EQ(accepted.size(), 1u);
  EXPECT_EQ(groups.at(0).consistency, 3);
}

TEST(LoopEssentialGraph, NewLoopLinksEnterOnlyAboveTheCovisibilityWeight) {
  EXPECT_TRUE(loopLinkEntersEssentialGraph(100, false));
  EXPECT_FALSE(loopLinkEntersEssentialGraph(99, false));
  EXPECT_FALSE(loopLinkEntersEssentialGraph(0, false));
  EXPECT_TRUE(loopLinkEntersEssentialGraph(15, true));  // the current-matched link always does
  EXPECT_TRUE(loopLinkEntersEssentialGraph(0, true));
  EXPECT_FALSE(loopLinkEntersEssentialGraph(49, false, 50));
}

}  // namespace
}  // namespace vslam
