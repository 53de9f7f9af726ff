// Issue 15: boxes carried between detections by the motion of their
// keypoints, with an age and expiry; and the keypoint filter that reuses the
// frame's own FAST corners and adds only keypoints the frame did not have.
#include <algorithm>
#include <random>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include "detect_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/detect/box_carrier.hpp"
#include "vslam/detect/keypoint_filter.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

// A textured scene as keypoints: a 12 x 10 grid, 20 px apart, each with its
// own random descriptor (well apart in Hamming distance), at level 0.
FeatureSnapshot gridScene(int frame_index, cv::Point2f shift, float scale = 1.f) {
  std::mt19937 rng(7);
  FeatureSnapshot snapshot;
  snapshot.frame_index = frame_index;
  snapshot.descriptors = cv::Mat(120, 32, CV_8U);
  for (int row = 0; row < 10; ++row)
    for (int col = 0; col < 12; ++col) {
      const cv::Point2f p(100.f + 20.f * static_cast<float>(col), 100.f + 20.f * static_cast<float>(row));
      snapshot.keypoints.emplace_back(scale * p + shift, 31.f, 0.f, 0.f, 0);
    }
  for (int i = 0; i < snapshot.descriptors.rows; ++i)
    for (int b = 0; b < 32; ++b) snapshot.descriptors.at<uchar>(i, b) = static_cast<uchar>(rng());
  return snapshot;
}

Detection boxDetection(cv::Rect2f box) {
  Detection detection;
  detection.id = 0;
  detection.class_id = 62;
  detection.class_name = "tvmonitor";
  detection.confidence = 0.8f;
  detection.box = box;
  return detection;
}

TEST(BoxMotion, FitIsExactForAScaleAndATranslation) {
  const std::vector<cv::Point2f> before = {{10, 20}, {30, 20}, {10, 60}, {50, 40}, {26, 36}};
  std::vector<cv::Point2f> after;
  for (const cv::Point2f& p : before) after.push_back(1.25f * p + cv::Point2f(3.5f, -2.f));
  const std::optional<BoxMotion> motion = fitBoxMotion(before, after, 3);
  ASSERT_TRUE(motion);
  EXPECT_FLOAT_EQ(motion->scale, 1.25f);
  EXPECT_FLOAT_EQ(motion->translation.x, 3.5f);
  EXPECT_FLOAT_EQ(motion->translation.y, -2.f);
  EXPECT_EQ(motion->support, 5);
  const cv::Rect2f moved = moveBox(cv::Rect2f(8, 16, 40, 48), *motion);
  EXPECT_FLOAT_EQ(moved.x, 13.5f);
  EXPECT_FLOAT_EQ(moved.y, 18.f);
  EXPECT_FLOAT_EQ(moved.width, 50.f);
  EXPECT_FLOAT_EQ(moved.height, 60.f);
}

TEST(BoxMotion, AnOutlierDoesNotMoveTheMedian) {
  std::vector<cv::Point2f> before = {{0, 0}, {10, 0}, {0, 10}, {10, 10}, {5, 5}};
  std::vector<cv::Point2f> after;
  for (const cv::Point2f& p : before) after.push_back(p + cv::Point2f(4, -3));
  after[4] = {200, 300};  // a wrong match
  const std::optional<BoxMotion> motion = fitBoxMotion(before, after, 3);
  ASSERT_TRUE(motion);
  EXPECT_FLOAT_EQ(motion->scale, 1.f);
  EXPECT_FLOAT_EQ(motion->translation.x, 4.f);
  EXPECT_FLOAT_EQ(motion->translation.y, -3.f);
  EXPECT_FALSE(fitBoxMotion({{0, 0}, {1, 1}}, {{0, 0}, {1, 1}}, 3));  // too few
}

TEST(BoxCarrier, BoxesFollowTheirKeypointsFrameByFrameAndAge) {
  BoxCarrier carrier(BoxCarrierParams{});
  carrier.advance(gridScene(0, {0, 0}));
  carrier.replace({boxDetection(cv::Rect2f(135, 135, 80, 60))}, gridScene(0, {0, 0}));
  ASSERT_EQ(carrier.boxes().size(), 1u);
  EXPECT_EQ(carrier.boxes()[0].age, 0);
  // The camera pans: everything moves 4 px right and 3 px up per frame.
  for (int frame = 1; frame <= 3; ++frame) {
    carrier.advance(gridScene(frame, cv::Point2f(4.f, -3.f) * static_cast<float>(frame)));
    ASSERT_EQ(carrier.boxes().size(), 1u) << "frame " << frame;
    const CarriedBox& box = carrier.boxes()[0];
    EXPECT_EQ(box.age, frame);
    EXPECT_FLOAT_EQ(box.detection.box.x, 135.f + 4.f * static_cast<float>(frame));
    EXPECT_FLOAT_EQ(box.detection.box.y, 135.f - 3.f * static_cast<float>(frame));
    EXPECT_FLOAT_EQ(box.detection.box.width, 80.f);
    EXPECT_FLOAT_EQ(box.detection.box.height, 60.f);
    EXPECT_EQ(box.detection.class_id, 62);
  }
}

TEST(BoxCarrier, ABoxGrowsWithItsKeypointsWhenTheCameraApproaches) {
  BoxCarrier carrier(BoxCarrierParams{});
  carrier.advance(gridScene(0, {0, 0}));
  carrier.replace({boxDetection(cv::Rect2f(150, 150, 100, 80))}, gridScene(0, {0, 0}));
  // p' = 1.1 p - 20: an expansion about (200, 200).
  carrier.advance(gridScene(1, {-20.f, -20.f}, 1.1f));
  ASSERT_EQ(carrier.boxes().size(), 1u);
  const cv::Rect2f& box = carrier.boxes()[0].detection.box;
  EXPECT_NEAR(box.x, 145.f, 1e-3);
  EXPECT_NEAR(box.y, 145.f, 1e-3);
  EXPECT_NEAR(box.width, 110.f, 1e-3);
  EXPECT_NEAR(box.height, 88.f, 1e-3);
}

TEST(BoxCarrier, LateDetectionsAreCarriedFromTheirOwnFrameToTheLastOne) {
  BoxCarrier carrier(BoxCarrierParams{});
  for (int frame = 0; frame <= 3; ++frame) carrier.advance(gridScene(frame, cv::Point2f(5.f, 2.f) * static_cast<float>(frame)));
  // The network saw frame 1; its result arrives while frame 3 is in hand.
  carrier.replace({boxDetection(cv::Rect2f(140, 140, 60, 60))}, gridScene(1, {5.f, 2.f}));
  ASSERT_EQ(carrier.boxes().size(), 1u);
  EXPECT_EQ(carrier.boxes()[0].age, 2);
  EXPECT_FLOAT_EQ(carrier.boxes()[0].detection.box.x, 150.f);
  EXPECT_FLOAT_EQ(carrier.boxes()[0].detection.box.y, 144.f);
}

TEST(BoxCarrier, AStaleBoxExpires) {
  BoxCarrierParams params;
  params.max_age = 2;
  BoxCarrier carrier(params);
  carrier.advance(gridScene(0, {0, 0}));
  carrier.replace({boxDetection(cv::Rect2f(135, 135, 80, 60))}, gridScene(0, {0, 0}));
  carrier.advance(gridScene(1, {1, 0}));
  carrier.advance(gridScene(2, {2, 0}));
  ASSERT_EQ(carrier.boxes().size(), 1u);
  EXPECT_EQ(carrier.boxes()[0].age, 2);
  carrier.advance(gridScene(3, {3, 0}));
  EXPECT_TRUE(carrier.boxes().empty());
  EXPECT_EQ(carrier.expired(), 1);
  // A detection already older than max_age when it arrives is not used at all.
  carrier.replace({boxDetection(cv::Rect2f(135, 135, 80, 60))}, gridScene(0, {0, 0}));
  EXPECT_TRUE(carrier.boxes().empty());
  EXPECT_EQ(carrier.expired(), 2);
  // Frames skipped (unreadable ones) count in the age too.
  carrier.replace({boxDetection(cv::Rect2f(135, 135, 80, 60))}, gridScene(3, {3, 0}));
  carrier.advance(gridScene(6, {6, 0}));
  EXPECT_TRUE(carrier.boxes().empty());
}

TEST(BoxCarrier, ABoxWithoutMatchesIsDroppedNotLeftBehind) {
  BoxCarrier carrier(BoxCarrierParams{});
  carrier.advance(gridScene(0, {0, 0}));
  carrier.replace({boxDetection(cv::Rect2f(135, 135, 80, 60)), boxDetection(cv::Rect2f(500, 400, 80, 60))},
                  gridScene(0, {0, 0}));
  EXPECT_EQ(carrier.boxes().size(), 2u);  // the frame's own detections need no matches
  carrier.advance(gridScene(1, {2, 2}));  // the second box holds no keypoint
  ASSERT_EQ(carrier.boxes().size(), 1u);
  EXPECT_FLOAT_EQ(carrier.boxes()[0].detection.box.x, 137.f);
  EXPECT_EQ(carrier.unmoved(), 1);
  // The keypoints jump farther than the search window: nothing is matched.
  carrier.advance(gridScene(2, {300, 2}));
  EXPECT_TRUE(carrier.boxes().empty());
  EXPECT_EQ(carrier.detections().size(), 0u);
}

// The cheaper filter on a real photo: no added keypoint is one the frame has,
// every one is a corner the frame's FAST found, and its descriptor is what
// ORB computes for it.
TEST(ReuseFilter, AddsOnlyCornersTheFrameDroppedWithTheirOwnDescriptors) {
  test::DogFrame frame = test::dogFrame();
  ASSERT_FALSE(frame.image.empty());
  // Keeping the corners changes nothing about the frame's own extraction.
  std::vector<cv::KeyPoint> plain_keypoints;
  cv::Mat plain_descriptors;
  frame.extractor.extract(frame.pyramid, plain_keypoints, plain_descriptors);
  ASSERT_EQ(plain_keypoints.size(), frame.keypoints.size());
  EXPECT_EQ(cv::norm(plain_descriptors, frame.descriptors, cv::NORM_L1), 0.0);

  using Key = std::tuple<float, float, int>;
  std::set<Key> frame_set, dropped_corners;
  for (const cv::KeyPoint& kp : frame.keypoints) frame_set.insert({kp.pt.x, kp.pt.y, kp.octave});
  int in_frame = 0;
  for (int l = 0; l < static_cast<int>(frame.corners.levels.size()); ++l)
    for (const OrbCorner& corner : frame.corners.levels[l]) {
      if (corner.in_frame) {
        ++in_frame;
        EXPECT_TRUE(frame_set.count({corner.level0.x, corner.level0.y, l}));
      } else {
        dropped_corners.insert({corner.level0.x, corner.level0.y, l});
      }
    }
  EXPECT_EQ(in_frame, static_cast<int>(frame.keypoints.size()));

  const cv::Rect box(120, 200, 300, 220);
  std::vector<cv::KeyPoint> added;
  cv::Mat added_descriptors;
  int reused = 0;
  const OrbCorners frame_corners = frame.corners;  // the frame's as extracted, for the filter below
  frame.extractor.extractFromCorners(frame.pyramid, frame.corners, box, 250, added, added_descriptors, &reused);
  ASSERT_FALSE(added.empty());
  EXPECT_EQ(added_descriptors.rows, static_cast<int>(added.size()));
  EXPECT_GT(reused, 0);
  EXPECT_LE(static_cast<int>(added.size()) + reused, 250);
  // The paper's filter on the same box, for the descriptors of common keypoints.
  std::vector<cv::KeyPoint> paper;
  cv::Mat paper_descriptors;
  frame.extractor.extract(frame.pyramid, paper, paper_descriptors, box, 250);
  std::map<Key, int> paper_rows;
  for (int i = 0; i < static_cast<int>(paper.size()); ++i) paper_rows[{paper[i].pt.x, paper[i].pt.y, paper[i].octave}] = i;
  int compared = 0;
  for (int i = 0; i < static_cast<int>(added.size()); ++i) {
    const Key key{added[i].pt.x, added[i].pt.y, added[i].octave};
    EXPECT_FALSE(frame_set.count(key)) << "a duplicate of the frame's own keypoint at " << added[i].pt;
    EXPECT_TRUE(dropped_corners.count(key)) << "not one of the frame's FAST corners: " << added[i].pt;
    EXPECT_TRUE(box.contains(cv::Point(static_cast<int>(added[i].pt.x), static_cast<int>(added[i].pt.y))));
    const auto row = paper_rows.find(key);
    if (row == paper_rows.end()) continue;
    ++compared;
    EXPECT_EQ(cv::norm(added_descriptors.row(i), paper_descriptors.row(row->second), cv::NORM_HAMMING), 0.0);
    EXPECT_FLOAT_EQ(added[i].angle, paper[row->second].angle);
  }
  EXPECT_GT(compared, 0);

  // Through the filter: nothing is dropped as a duplicate, since nothing is one.
  std::vector<KeypointLabel> labels;
  Detection dog;
  dog.id = 0;
  dog.class_id = 16;
  dog.box = cv::Rect2f(box);
  int filter_reused = 0;
  std::vector<cv::KeyPoint> keypoints = frame.keypoints;
  cv::Mat descriptors = frame.descriptors.clone();
  OrbCorners filter_corners = frame_corners;
  const KeypointFilterStats stats = applyKeypointFilter(
      frame.image.size(), {dog}, 64, {},
      cornerBoxExtractor(frame.extractor, frame.pyramid, filter_corners, 250, &filter_reused), keypoints, descriptors,
      labels);
  EXPECT_EQ(stats.duplicates_dropped, 0);
  EXPECT_EQ(stats.keypoints_added, static_cast<int>(added.size()));
  EXPECT_EQ(filter_reused, reused);
  EXPECT_EQ(keypoints.size(), frame.keypoints.size() + added.size());
  // The same box again adds nothing: its winners are all the frame's now.
  std::vector<cv::KeyPoint> again;
  cv::Mat again_descriptors;
  int again_reused = 0;
  frame.extractor.extractFromCorners(frame.pyramid, frame.corners, box, 250, again, again_descriptors, &again_reused);
  EXPECT_TRUE(again.empty());
  EXPECT_EQ(again_reused, reused + static_cast<int>(added.size()));
}

// Two overlapping boxes: a new corner that wins in both is described once,
// so the filter drops nothing as a duplicate (it dropped 25 a frame on
// fr1_xyz before corners were marked as taken between boxes).
TEST(ReuseFilter, OverlappingBoxesDoNotAddTheSameCornerTwice) {
  test::DogFrame frame = test::dogFrame();
  ASSERT_FALSE(frame.image.empty());
  std::vector<cv::KeyPoint>& keypoints = frame.keypoints;  // the filter adds to the frame's own
  const size_t frame_count = keypoints.size();
  std::vector<Detection> boxes(2);
  boxes[0].id = 0, boxes[0].class_id = 16, boxes[0].box = cv::Rect2f(120, 200, 300, 220);
  boxes[1].id = 1, boxes[1].class_id = 1, boxes[1].box = cv::Rect2f(200, 150, 300, 220);
  std::vector<KeypointLabel> labels;
  int reused = 0;
  const KeypointFilterStats stats =
      applyKeypointFilter(frame.image.size(), boxes, 64, {},
                          cornerBoxExtractor(frame.extractor, frame.pyramid, frame.corners, 250, &reused), keypoints,
                          frame.descriptors, labels);
  EXPECT_EQ(stats.boxes_used, 2);
  EXPECT_GT(stats.keypoints_added, 0);
  EXPECT_EQ(stats.duplicates_dropped, 0);
  EXPECT_EQ(keypoints.size(), frame_count + static_cast<size_t>(stats.keypoints_added));
  using Key = std::tuple<float, float, int>;
  std::set<Key> unique;
  for (const cv::KeyPoint& kp : keypoints) unique.insert({kp.pt.x, kp.pt.y, kp.octave});
  EXPECT_EQ(unique.size(), keypoints.size());
}

}  // namespace
}  // namespace vslam
