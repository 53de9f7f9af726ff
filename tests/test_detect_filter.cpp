// The keypoint filter (the paper's Algorithm 1) rule by rule, with a fake box
// extractor on synthetic inputs, then once with the real OrbExtractor.
#include <algorithm>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "detect_test_support.hpp"
#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/detect/keypoint_filter.hpp"

namespace vslam {
namespace {

const cv::Size kImage(640, 480);

// Keypoints carry a tag in KeyPoint::class_id, and their descriptor's first
// byte repeats it, so the tests can check rows stay aligned with keypoints.
cv::KeyPoint tagged(float x, float y, int octave, int tag) {
  cv::KeyPoint keypoint(cv::Point2f(x, y), 31.f, -1.f, 0.f, octave, tag);
  return keypoint;
}

cv::Mat descriptorsOf(const std::vector<cv::KeyPoint>& keypoints) {
  cv::Mat descriptors(static_cast<int>(keypoints.size()), 32, CV_8U, cv::Scalar(0));
  for (size_t i = 0; i < keypoints.size(); ++i) descriptors.at<uchar>(static_cast<int>(i), 0) = static_cast<uchar>(keypoints[i].class_id);
  return descriptors;
}

Detection detection(int id, int class_id, cv::Rect2f box) {
  Detection d;
  d.id = id;
  d.class_id = class_id;
  d.class_name = "class" + std::to_string(class_id);
  d.confidence = 0.9f;
  d.box = box;
  return d;
}

// Records the boxes it is called with; returns the keypoints `source` gives for each.
struct FakeExtractor {
  std::vector<cv::Rect> calls;
  std::function<std::vector<cv::KeyPoint>(const cv::Rect&)> source = [](const cv::Rect& box) {
    // One keypoint at the box centre, tagged 200 + call-independent.
    return std::vector<cv::KeyPoint>{tagged(box.x + box.width / 2.f, box.y + box.height / 2.f, 0, 200)};
  };
  BoxExtractor bind() {
    return [this](const cv::Rect& box, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) {
      calls.push_back(box);
      keypoints = source(box);
      descriptors = descriptorsOf(keypoints);
    };
  }
};

void expectAligned(const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors,
                   const std::vector<KeypointLabel>& labels) {
  ASSERT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  ASSERT_EQ(labels.size(), keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i)
    EXPECT_EQ(descriptors.at<uchar>(static_cast<int>(i), 0), static_cast<uchar>(keypoints[i].class_id)) << i;
}

TEST(KeypointFilter, BoxesAreClippedToTheImage) {
  EXPECT_EQ(clipToImage({-30.f, 10.f, 130.f, 100.f}, kImage), cv::Rect(0, 10, 100, 100));
  EXPECT_EQ(clipToImage({600.f, 400.f, 100.f, 100.f}, kImage), cv::Rect(600, 400, 40, 80));
  EXPECT_EQ(clipToImage({10.4f, 20.6f, 99.8f, 100.f}, kImage), cv::Rect(10, 21, 100, 100));  // edges rounded
  EXPECT_TRUE(clipToImage({700.f, 10.f, 100.f, 100.f}, kImage).empty());

  FakeExtractor fake;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  std::vector<KeypointLabel> labels;
  const auto stats = applyKeypointFilter(kImage, {detection(0, 2, {-30.f, 10.f, 130.f, 100.f})}, 64, {}, fake.bind(),
                                         keypoints, descriptors, labels);
  ASSERT_EQ(fake.calls.size(), 1u);
  EXPECT_EQ(fake.calls[0], cv::Rect(0, 10, 100, 100));
  EXPECT_EQ(stats.boxes_used, 1);
  EXPECT_EQ(stats.keypoints_added, 1);
  EXPECT_EQ(keypoints.at(0).pt, cv::Point2f(50.f, 60.f));
}

TEST(KeypointFilter, BoxesUnder64PixelsWideOrHighAreSkipped) {
  FakeExtractor fake;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  std::vector<KeypointLabel> labels;
  const std::vector<Detection> detections = {
      detection(0, 1, {10.f, 10.f, 63.f, 100.f}),    // 63 wide: skipped
      detection(1, 1, {100.f, 10.f, 64.f, 100.f}),   // 64 wide: used
      detection(2, 1, {200.f, 10.f, 100.f, 63.f}),   // 63 high: skipped
      detection(3, 1, {350.f, 10.f, 100.f, 64.f}),   // 64 high: used
      detection(4, 1, {-20.f, 300.f, 80.f, 100.f}),  // 80 wide, but 60 inside the image: skipped
  };
  const auto stats = applyKeypointFilter(kImage, detections, 64, {}, fake.bind(), keypoints, descriptors, labels);
  EXPECT_EQ(stats.boxes_used, 2);
  EXPECT_EQ(stats.boxes_skipped_small, 3);
  ASSERT_EQ(fake.calls.size(), 2u);
  EXPECT_EQ(fake.calls[0], cv::Rect(100, 10, 64, 100));
  EXPECT_EQ(fake.calls[1], cv::Rect(350, 10, 100, 64));
  EXPECT_EQ(keypoints.size(), 2u);
}

TEST(KeypointFilter, BoxKeypointsAreAppendedAndExactDuplicatesDropped) {
  std::vector<cv::KeyPoint> keypoints = {tagged(50.f, 50.f, 0, 1), tagged(300.f, 300.f, 2, 2)};
  cv::Mat descriptors = descriptorsOf(keypoints);
  std::vector<KeypointLabel> labels;
  FakeExtractor fake;
  fake.source = [](const cv::Rect&) {
    return std::vector<cv::KeyPoint>{
        tagged(50.f, 50.f, 0, 10),   // same position and level as frame keypoint 1: dropped
        tagged(50.f, 50.f, 1, 11),   // same position, other level: kept
        tagged(50.5f, 50.f, 0, 12),  // half a pixel off: kept
        tagged(60.f, 70.f, 0, 13),   // new: kept
    };
  };
  // Two boxes over the same area: the second extraction repeats the first's keypoints.
  const std::vector<Detection> detections = {detection(0, 5, {0.f, 0.f, 100.f, 100.f}),
                                             detection(1, 6, {0.f, 0.f, 100.f, 100.f})};
  const auto stats = applyKeypointFilter(kImage, detections, 64, {}, fake.bind(), keypoints, descriptors, labels);
  EXPECT_EQ(stats.boxes_used, 2);
  EXPECT_EQ(stats.keypoints_added, 3);
  EXPECT_EQ(stats.duplicates_dropped, 1 + 4);
  ASSERT_EQ(keypoints.size(), 5u);
  std::vector<int> tags;
  for (const auto& keypoint : keypoints) tags.push_back(keypoint.class_id);
  EXPECT_EQ(tags, (std::vector<int>{1, 2, 11, 12, 13}));  // frame keypoints first, in order
  expectAligned(keypoints, descriptors, labels);
}

TEST(KeypointFilter, KeypointsCarryTheLabelOfTheirBox) {
  std::vector<cv::KeyPoint> keypoints = {
      tagged(20.f, 20.f, 0, 1),    // in the big box only
      tagged(120.f, 180.f, 0, 2),  // in the big and the small box: the small one wins
      tagged(400.f, 400.f, 0, 3),  // in no box
      tagged(520.f, 20.f, 0, 4),   // in a box too small to use: no label
      tagged(199.f, 199.f, 0, 5),  // on the small box's last pixel: inside
      tagged(200.f, 200.f, 0, 6),  // just past it: big box
  };
  cv::Mat descriptors = descriptorsOf(keypoints);
  std::vector<KeypointLabel> labels(keypoints.size());
  labels[2] = {7, 9};  // a label already there survives where no box covers the keypoint
  FakeExtractor fake;
  const std::vector<Detection> detections = {
      detection(0, 56, {0.f, 0.f, 300.f, 300.f}),     // chair
      detection(1, 39, {100.f, 100.f, 100.f, 100.f}),  // bottle on it
      detection(2, 73, {500.f, 0.f, 40.f, 40.f}),      // book, too small
  };
  const auto stats = applyKeypointFilter(kImage, detections, 64, {}, fake.bind(), keypoints, descriptors, labels);
  expectAligned(keypoints, descriptors, labels);
  auto labelOf = [&](int tag) {
    const auto it = std::find_if(keypoints.begin(), keypoints.end(), [&](const cv::KeyPoint& k) { return k.class_id == tag; });
    EXPECT_NE(it, keypoints.end()) << tag;
    return labels[it - keypoints.begin()];
  };
  EXPECT_EQ(labelOf(1).class_id, 56);
  EXPECT_EQ(labelOf(1).detection_id, 0);
  EXPECT_EQ(labelOf(2).class_id, 39);
  EXPECT_EQ(labelOf(2).detection_id, 1);
  EXPECT_EQ(labelOf(3).class_id, 7);
  EXPECT_EQ(labelOf(3).detection_id, 9);
  EXPECT_EQ(labelOf(4).class_id, -1);
  EXPECT_EQ(labelOf(5).class_id, 39);
  EXPECT_EQ(labelOf(6).class_id, 56);
  // The chair's and the bottle's centres coincide at (150, 150): added once,
  // labelled with the smaller bottle box, and the repeat dropped.
  EXPECT_EQ(stats.keypoints_added, 1);
  EXPECT_EQ(stats.duplicates_dropped, 1);
  ASSERT_EQ(keypoints.size(), 7u);
  EXPECT_EQ(keypoints[6].pt, cv::Point2f(150.f, 150.f));
  EXPECT_EQ(labels[6].class_id, 39);
  EXPECT_EQ(labels[6].detection_id, 1);
}

TEST(KeypointFilter, DynamicClassesRemoveKeypointsInsteadOfAdding) {
  const int person = 0;
  std::vector<cv::KeyPoint> keypoints = {tagged(20.f, 20.f, 0, 1), tagged(300.f, 300.f, 0, 2),
                                         tagged(35.f, 35.f, 3, 3)};
  cv::Mat descriptors = descriptorsOf(keypoints);
  std::vector<KeypointLabel> labels;
  FakeExtractor fake;
  fake.source = [](const cv::Rect&) {
    return std::vector<cv::KeyPoint>{tagged(30.f, 30.f, 0, 10), tagged(250.f, 250.f, 0, 11)};
  };
  const std::vector<Detection> detections = {
      detection(0, person, {0.f, 0.f, 40.f, 40.f}),   // small, but dynamic boxes remove whatever their size
      detection(1, 56, {0.f, 0.f, 400.f, 400.f}),     // a chair around it: extraction runs here
  };
  const auto stats = applyKeypointFilter(kImage, detections, 64, {person}, fake.bind(), keypoints, descriptors, labels);
  ASSERT_EQ(fake.calls.size(), 1u);  // never inside the person
  EXPECT_EQ(fake.calls[0], cv::Rect(0, 0, 400, 400));
  EXPECT_EQ(stats.keypoints_removed_dynamic, 2 + 1);  // frame keypoints 1 and 3, box keypoint 10
  EXPECT_EQ(stats.keypoints_added, 1);
  EXPECT_EQ(stats.boxes_skipped_small, 0);
  std::vector<int> tags;
  for (const auto& keypoint : keypoints) tags.push_back(keypoint.class_id);
  EXPECT_EQ(tags, (std::vector<int>{2, 11}));
  expectAligned(keypoints, descriptors, labels);
  for (const auto& label : labels) EXPECT_EQ(label.class_id, 56);
}

TEST(KeypointFilter, NoDetectionsLeavesTheFrameUntouched) {
  std::vector<cv::KeyPoint> keypoints = {tagged(20.f, 20.f, 0, 1), tagged(30.f, 20.f, 1, 2)};
  cv::Mat descriptors = descriptorsOf(keypoints);
  const cv::Mat before = descriptors.clone();
  std::vector<KeypointLabel> labels;
  FakeExtractor fake;
  const auto stats = applyKeypointFilter(kImage, {}, 64, {}, fake.bind(), keypoints, descriptors, labels);
  EXPECT_TRUE(fake.calls.empty());
  EXPECT_EQ(stats.keypoints_added, 0);
  EXPECT_EQ(keypoints.size(), 2u);
  EXPECT_EQ(cv::norm(descriptors, before, cv::NORM_L1), 0.0);
  ASSERT_EQ(labels.size(), 2u);
  EXPECT_EQ(labels[0].class_id, -1);
}

TEST(KeypointFilter, MismatchedInputsAreRejected) {
  std::vector<cv::KeyPoint> keypoints = {tagged(20.f, 20.f, 0, 1)};
  cv::Mat descriptors = descriptorsOf(keypoints);
  std::vector<KeypointLabel> labels(3);
  FakeExtractor fake;
  EXPECT_THROW(applyKeypointFilter(kImage, {}, 64, {}, fake.bind(), keypoints, descriptors, labels),
               std::invalid_argument);
}

TEST(KeypointFilter, RealOrbExtractorAddsKeypointsInsideTheBox) {
  test::DogFrame frame = test::dogFrame();
  ASSERT_FALSE(frame.image.empty());
  std::vector<cv::KeyPoint>& keypoints = frame.keypoints;  // the filter adds to the frame's own
  cv::Mat& descriptors = frame.descriptors;
  const size_t frame_count = keypoints.size();
  ASSERT_GT(frame_count, 100u);
  std::vector<KeypointLabel> labels;

  const cv::Rect2f bicycle(125.f, 128.f, 442.f, 292.f);
  const auto stats = applyKeypointFilter(frame.image.size(), {detection(0, 1, bicycle)}, 64, {},
                                         orbBoxExtractor(frame.extractor, frame.pyramid, 500), keypoints, descriptors,
                                         labels);
  EXPECT_EQ(stats.boxes_used, 1);
  EXPECT_GT(stats.keypoints_added, 50);
  EXPECT_EQ(keypoints.size(), frame_count + stats.keypoints_added);
  EXPECT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  EXPECT_EQ(descriptors.cols, 32);
  EXPECT_EQ(descriptors.type(), CV_8U);
  const cv::Rect box = clipToImage(bicycle, frame.image.size());
  for (size_t i = frame_count; i < keypoints.size(); ++i) {
    EXPECT_TRUE(box.contains(cv::Point(static_cast<int>(keypoints[i].pt.x), static_cast<int>(keypoints[i].pt.y))))
        << keypoints[i].pt;
    EXPECT_EQ(labels[i].class_id, 1);
    EXPECT_EQ(labels[i].detection_id, 0);
    EXPECT_GE(keypoints[i].octave, 0);
    EXPECT_LT(keypoints[i].octave, frame.extractor.levels());
  }
  // No exact duplicate survives.
  for (size_t i = frame_count; i < keypoints.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      ASSERT_FALSE(keypoints[i].pt == keypoints[j].pt && keypoints[i].octave == keypoints[j].octave) << i << " " << j;
}

TEST(KeypointFilter, FeaturesPerBoxComeFromTheConfig) {
  const auto path = test::scratchDir("filter_config") / "cam.yaml";
  std::ofstream(path) << "camera: {width: 640, height: 480, fx: 500, fy: 500, cx: 320, cy: 240}\n"
                         "orb: {n_features: 1200}\n"
                         "detector: {box_features: 150, min_box_px: 48}\n";
  Config config = loadConfig(path.string());
  EXPECT_EQ(config.detector.box_features, 150);
  EXPECT_EQ(config.detector.min_box_px, 48);
  EXPECT_EQ(featuresPerBox(config.detector, config.orb), 150);
  config.detector.box_features = 0;
  EXPECT_EQ(featuresPerBox(config.detector, config.orb), 1200);  // the paper: the frame's own count
}

}  // namespace
}  // namespace vslam
