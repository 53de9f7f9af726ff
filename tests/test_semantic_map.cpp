// The semantic part of the pipeline: object landmarks from labelled points
// (synthetic), the keypoint filter inside FrameBuilder on a real frame, and
// end-to-end runs of the System with the detector on fr1_xyz (deterministic).
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "system_test_support.hpp"
#include "test_support.hpp"
#include "vslam/detect/detector.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/map/object_map.hpp"
#include "vslam/slam/frame_builder.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

// `count` points of `class_id` spread uniformly in the box [lo, hi], ids from `first_id`.
void addCluster(std::vector<LabelledPoint>& points, int class_id, long first_id, int count, const Vec3& lo,
                const Vec3& hi, unsigned seed, std::vector<long> keyframes) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < count; ++i) {
    LabelledPoint point;
    point.id = first_id + i;
    for (int a = 0; a < 3; ++a) point.position[a] = lo[a] + unit(rng) * (hi[a] - lo[a]);
    point.class_id = class_id;
    point.confidence = 0.8;
    point.keyframe_ids = keyframes;
    points.push_back(point);
  }
}

const std::vector<std::string> kNames = {"person", "chair", "tvmonitor"};

TEST(ObjectMap, SeparatesClustersAndClasses) {
  std::vector<LabelledPoint> points;
  // Two chairs two metres apart, and a monitor touching the first chair: a
  // different class must not merge with it.
  addCluster(points, 1, 0, 200, Vec3(0, 0, 0), Vec3(0.5, 0.5, 0.5), 1, {0, 2});
  addCluster(points, 1, 1000, 120, Vec3(2.5, 0, 0), Vec3(3.0, 0.4, 0.3), 2, {3, 5});
  addCluster(points, 2, 2000, 80, Vec3(0.5, 0, 0), Vec3(0.9, 0.3, 0.1), 3, {2, 4});
  // Two stray chair points and unlabelled points far away: not objects.
  addCluster(points, 1, 3000, 2, Vec3(10, 10, 10), Vec3(10.01, 10.01, 10.01), 4, {7});
  addCluster(points, -1, 4000, 50, Vec3(0, 0, 0), Vec3(3, 3, 3), 5, {1});
  std::shuffle(points.begin(), points.end(), std::mt19937(9));  // input order must not matter

  ObjectMapParams params;
  const std::vector<ObjectLandmark> objects = buildObjectMap(points, 0.15, params, kNames);
  ASSERT_EQ(objects.size(), 3u);
  // Ordered by class, then smallest point id.
  EXPECT_EQ(objects[0].class_name, "chair");
  EXPECT_EQ(objects[0].point_ids.size(), 200u);
  EXPECT_EQ(objects[0].keyframe_ids, (std::vector<long>{0, 2}));
  EXPECT_EQ(objects[1].class_name, "chair");
  EXPECT_EQ(objects[1].point_ids.size(), 120u);
  EXPECT_EQ(objects[1].keyframe_ids, (std::vector<long>{3, 5}));
  EXPECT_EQ(objects[2].class_name, "tvmonitor");
  EXPECT_EQ(objects[2].class_id, 2);
  EXPECT_EQ(objects[2].point_ids.size(), 80u);
  EXPECT_NEAR(objects[2].confidence, 0.8, 1e-12);

  // 5-95 % boxes of uniform points: inside the true box, covering most of it.
  const Vec3 lo[3] = {Vec3(0, 0, 0), Vec3(2.5, 0, 0), Vec3(0.5, 0, 0)};
  const Vec3 hi[3] = {Vec3(0.5, 0.5, 0.5), Vec3(3.0, 0.4, 0.3), Vec3(0.9, 0.3, 0.1)};
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a) {
      const double extent = hi[k][a] - lo[k][a];
      EXPECT_GE(objects[k].box_min[a], lo[k][a]) << k << " " << a;
      EXPECT_LE(objects[k].box_min[a], lo[k][a] + 0.15 * extent) << k << " " << a;
      EXPECT_LE(objects[k].box_max[a], hi[k][a]) << k << " " << a;
      EXPECT_GE(objects[k].box_max[a], hi[k][a] - 0.15 * extent) << k << " " << a;
      EXPECT_NEAR(objects[k].centroid[a], 0.5 * (lo[k][a] + hi[k][a]), 0.1 * extent) << k << " " << a;
    }
}

TEST(ObjectMap, LinkDistanceDecidesWhatMerges) {
  std::vector<LabelledPoint> points;
  addCluster(points, 0, 0, 10, Vec3(0, 0, 0), Vec3(0.01, 0.01, 0.01), 1, {0});
  addCluster(points, 0, 100, 10, Vec3(1, 0, 0), Vec3(1.01, 0.01, 0.01), 2, {1});
  EXPECT_EQ(buildObjectMap(points, 0.5, ObjectMapParams(), kNames).size(), 2u);
  EXPECT_EQ(buildObjectMap(points, 1.5, ObjectMapParams(), kNames).size(), 1u);
  // Relative to the scene: the same map scaled by 10 with a 10x depth groups alike.
  for (LabelledPoint& point : points) point.position *= 10.0;
  ObjectMapParams params;
  EXPECT_EQ(buildObjectMap(points, linkDistanceFor(10.0, params), params, kNames).size(), 2u);
  EXPECT_TRUE(buildObjectMap(points, 0.0, params, kNames).empty());
}

// Two sparse parts of one chair, too far apart to link by distance (1 m at a
// 0.5 m link distance) but within the 2.5 m box link distance: one detection
// box of one keyframe seeing a point of each joins them; two different boxes,
// another class, or a point in the box but farther than 2.5 m, do not.
TEST(ObjectMap, ASharedDetectionBoxJoinsDistantParts) {
  std::vector<LabelledPoint> points;
  addCluster(points, 1, 0, 10, Vec3(0, 0, 0), Vec3(0.01, 0.01, 0.01), 1, {4});
  addCluster(points, 1, 100, 10, Vec3(1, 0, 0), Vec3(1.01, 0.01, 0.01), 2, {4});
  addCluster(points, 1, 300, 10, Vec3(4, 0, 0), Vec3(4.01, 0.01, 0.01), 4, {4});
  points.back().detections = {{4, 0}};  // far behind, in the same box
  ObjectMapParams params;
  ASSERT_EQ(params.box_link_factor, 5.0);
  ASSERT_EQ(buildObjectMap(points, 0.5, params, kNames).size(), 3u);

  points[3].detections = {{4, 0}};   // keyframe 4, detection 0
  points[15].detections = {{4, 1}};  // another box of keyframe 4
  EXPECT_EQ(buildObjectMap(points, 0.5, params, kNames).size(), 3u);
  points[15].detections.push_back({5, 0});  // detection 0 of another keyframe
  EXPECT_EQ(buildObjectMap(points, 0.5, params, kNames).size(), 3u);

  points[15].detections.push_back({4, 0});
  const std::vector<ObjectLandmark> joined = buildObjectMap(points, 0.5, params, kNames);
  ASSERT_EQ(joined.size(), 2u);
  EXPECT_EQ(joined[0].point_ids.size(), 20u);
  EXPECT_EQ(joined[1].point_ids.size(), 10u);
  params.box_link_factor = 1.0;  // box joins no looser than distance joins: apart again
  EXPECT_EQ(buildObjectMap(points, 0.5, params, kNames).size(), 3u);
  params.box_link_factor = 5.0;

  // Only points of one class join: a person point in the same box stays apart.
  addCluster(points, 0, 200, 10, Vec3(2, 0, 0), Vec3(2.01, 0.01, 0.01), 3, {4});
  points.back().detections = {{4, 0}};
  const std::vector<ObjectLandmark> by_class = buildObjectMap(points, 0.5, params, kNames);
  ASSERT_EQ(by_class.size(), 3u);
  EXPECT_EQ(by_class[0].class_name, "person");
  EXPECT_EQ(by_class[0].point_ids.size(), 10u);
  EXPECT_EQ(by_class[1].point_ids.size(), 20u);
}

// A 0.5 m cube of 40 chair points seen along +z, and 3 stray points 2 m
// behind it seen in the same detection box (so linked into the object): the
// strays are rejected and the box stays inside the cube. Before outlier
// rejection its 95th percentile in z lay among the strays (2.25).
TEST(ObjectMap, StrayPointsDoNotStretchTheBox) {
  std::vector<LabelledPoint> points;
  addCluster(points, 1, 0, 40, Vec3(0, 0, 0), Vec3(0.5, 0.5, 0.5), 1, {0, 1});
  addCluster(points, 1, 100, 3, Vec3(0.24, 0.24, 2.45), Vec3(0.26, 0.26, 2.47), 2, {1});
  for (LabelledPoint& point : points) {
    point.detections = {{1, 0}};
    point.viewing_direction = Vec3(0, 0, 1);
  }
  const std::vector<ObjectLandmark> objects = buildObjectMap(points, 0.5, ObjectMapParams(), kNames);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].point_ids.size(), 40u);
  EXPECT_EQ(objects[0].point_ids.front(), 0);
  EXPECT_EQ(objects[0].point_ids.back(), 39);
  EXPECT_EQ(objects[0].rejected_point_ids, (std::vector<long>{100, 101, 102}));
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(objects[0].box_min[a], 0.0) << a;
    EXPECT_LE(objects[0].box_min[a], 0.1) << a;
    EXPECT_LE(objects[0].box_max[a], 0.5) << a;
    EXPECT_GE(objects[0].box_max[a], 0.4) << a;
    EXPECT_NEAR(objects[0].centroid[a], 0.25, 0.05) << a;
  }
  // Without viewing rays the distance check alone still rejects them.
  for (LabelledPoint& point : points) point.viewing_direction = Vec3::Zero();
  const std::vector<ObjectLandmark> without_rays = buildObjectMap(points, 0.5, ObjectMapParams(), kNames);
  ASSERT_EQ(without_rays.size(), 1u);
  EXPECT_EQ(without_rays[0].rejected_point_ids, (std::vector<long>{100, 101, 102}));
  EXPECT_LE(without_rays[0].box_max.z(), 0.5);

  // Four points and a stray linked to them: fewer than min_points (5) agree,
  // so no object.
  std::vector<LabelledPoint> few;
  addCluster(few, 1, 0, 4, Vec3(0, 0, 0), Vec3(0.01, 0.01, 0.01), 3, {0});
  addCluster(few, 1, 10, 1, Vec3(0, 0, 2), Vec3(0, 0, 2), 4, {0});
  for (LabelledPoint& point : few) point.detections = {{0, 0}};
  ASSERT_EQ(ObjectMapParams().min_points, 5);
  EXPECT_TRUE(buildObjectMap(few, 0.5, ObjectMapParams(), kNames).empty());
  few.back().position.z() = 0.005;  // the fifth agrees: an object
  EXPECT_EQ(buildObjectMap(few, 0.5, ObjectMapParams(), kNames).size(), 1u);
}

// A flat monitor face (0.5 x 0.3 m, 2 cm deep) seen along +z, and 4 points of
// the wall 30 cm behind it seen through its box: near the monitor's median by
// distance (the face is wider than that), but off in depth along their rays.
TEST(ObjectMap, PointsOffInDepthAlongTheirRaysAreRejected) {
  std::vector<LabelledPoint> points;
  addCluster(points, 2, 0, 60, Vec3(0, 0, 0), Vec3(0.5, 0.3, 0.02), 1, {0});
  addCluster(points, 2, 100, 4, Vec3(0.1, 0.1, 0.32), Vec3(0.4, 0.2, 0.32), 2, {0});
  for (LabelledPoint& point : points) {
    point.viewing_direction = Vec3(0, 0, 2);  // normalised inside
    point.detections = {{0, 0}};               // all seen in one box: linked
  }
  std::vector<ObjectLandmark> objects = buildObjectMap(points, 0.2, ObjectMapParams(), kNames);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].point_ids.size(), 60u);
  EXPECT_EQ(objects[0].rejected_point_ids, (std::vector<long>{100, 101, 102, 103}));
  EXPECT_LE(objects[0].box_max.z(), 0.02);
  // Seen from the side (rays along +x) the same points agree in depth: kept.
  for (LabelledPoint& point : points) point.viewing_direction = Vec3(1, 0, 0);
  objects = buildObjectMap(points, 0.2, ObjectMapParams(), kNames);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].point_ids.size(), 64u);
  EXPECT_TRUE(objects[0].rejected_point_ids.empty());
}

const std::vector<std::string> kScreenNames = {"person", "chair", "tvmonitor", "laptop"};

// A tvmonitor group and a laptop group overlapping in 3D become one object of
// the class with more points, recording the other; apart, or with no
// confusable classes configured, they stay two; a person never merges.
TEST(ObjectMap, OverlappingConfusableClassesMerge) {
  std::vector<LabelledPoint> points;
  addCluster(points, 2, 0, 80, Vec3(0, 0, 0), Vec3(0.5, 0.3, 0.05), 1, {0, 1});
  addCluster(points, 3, 100, 20, Vec3(0.1, 0.05, 0.0), Vec3(0.3, 0.25, 0.05), 2, {1, 2});
  addCluster(points, 0, 200, 30, Vec3(0.1, 0.05, 0.0), Vec3(0.3, 0.25, 0.05), 3, {3});
  ObjectMapParams params;
  std::vector<ObjectLandmark> objects = buildObjectMap(points, 0.15, params, kScreenNames);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[0].class_name, "person");
  EXPECT_EQ(objects[0].point_ids.size(), 30u);
  EXPECT_TRUE(objects[0].merged_classes.empty());
  EXPECT_EQ(objects[1].class_name, "tvmonitor");
  EXPECT_EQ(objects[1].class_id, 2);
  EXPECT_EQ(objects[1].point_ids.size(), 100u);
  EXPECT_EQ(objects[1].merged_classes, (std::vector<std::string>{"laptop"}));
  EXPECT_EQ(objects[1].keyframe_ids, (std::vector<long>{0, 1, 2}));

  // More laptop points than monitor points: the merged object is a laptop.
  addCluster(points, 3, 300, 90, Vec3(0, 0, 0), Vec3(0.5, 0.3, 0.05), 4, {5});
  objects = buildObjectMap(points, 0.15, params, kScreenNames);
  ASSERT_EQ(objects.size(), 2u);
  EXPECT_EQ(objects[1].class_name, "laptop");
  EXPECT_EQ(objects[1].point_ids.size(), 190u);
  EXPECT_EQ(objects[1].merged_classes, (std::vector<std::string>{"tvmonitor"}));
  points.resize(130);

  params.confusable_classes.clear();
  EXPECT_EQ(buildObjectMap(points, 0.15, params, kScreenNames).size(), 3u);
  params = ObjectMapParams();

  // The laptop 2 m to the side: two objects.
  for (LabelledPoint& point : points)
    if (point.class_id == 3) point.position.x() += 2.0;
  objects = buildObjectMap(points, 0.15, params, kScreenNames);
  ASSERT_EQ(objects.size(), 3u);
  EXPECT_EQ(objects[1].class_name, "tvmonitor");
  EXPECT_EQ(objects[1].point_ids.size(), 80u);
  EXPECT_EQ(objects[2].class_name, "laptop");
  EXPECT_EQ(objects[2].point_ids.size(), 20u);
  for (const ObjectLandmark& object : objects) EXPECT_TRUE(object.merged_classes.empty());
}

TEST(ObjectMap, BoxesOverlap) {
  const Vec3 zero(0, 0, 0), one(1, 1, 1);
  EXPECT_TRUE(boxesOverlap(zero, one, Vec3(0.5, 0, 0), Vec3(1.5, 1, 1), 0.0, 0.5));
  EXPECT_FALSE(boxesOverlap(zero, one, Vec3(0.5, 0, 0), Vec3(1.5, 1, 1), 0.0, 0.51));
  EXPECT_FALSE(boxesOverlap(zero, one, Vec3(2, 0, 0), Vec3(3, 1, 1), 0.0, 0.01));
  // A flat box has no volume; the margin gives it one.
  const Vec3 flat(1, 1, 0);
  EXPECT_FALSE(boxesOverlap(zero, flat, zero, flat, 0.0, 0.3));
  EXPECT_TRUE(boxesOverlap(zero, flat, zero, flat, 0.1, 0.3));
  // A small box inside a large one shares all of the smaller.
  EXPECT_TRUE(boxesOverlap(zero, Vec3(10, 10, 10), Vec3(4, 4, 4), Vec3(5, 5, 5), 0.0, 1.0));
}

TEST(ObjectMap, Percentile) {
  EXPECT_DOUBLE_EQ(percentile({3, 1, 2}, 0.5), 2.0);
  EXPECT_DOUBLE_EQ(percentile({0, 10}, 0.25), 2.5);
  EXPECT_DOUBLE_EQ(percentile({}, 0.5), 0.0);
}

Sequence fr1Xyz() {
  SequenceOptions options;
  options.data_root = test::sharedData().string();
  return openSequence("tum/fr1_xyz", options);
}

std::vector<std::string> cocoNames() {
  return readClassNames((test::sharedModels() / "yolo-fastest-1.1" / "coco.names").string());
}

// A real fr1_xyz frame with a hand-placed box over the keyboard (the
// detector's box there, rounded): Algorithm 1 adds labelled keypoints inside
// it, and the dynamic variant removes every keypoint inside it instead.
TEST(FrameBuilderFilter, AddsLabelledKeypointsOrRemovesDynamicOnes) {
  const Sequence sequence = fr1Xyz();
  const cv::Mat image = sequence.loadColor(0);
  Config config = sequence.config;
  config.detector.box_filter = "paper";
  Detection keyboard;
  keyboard.id = 0;
  keyboard.class_id = 66;
  keyboard.class_name = "keyboard";
  keyboard.confidence = 0.99f;
  keyboard.box = cv::Rect2f(326, 331, 270, 139);
  const std::vector<Detection> detections = {keyboard};
  const cv::Rect box = cv::Rect(326, 331, 270, 139) & cv::Rect(0, 0, image.cols, image.rows);

  const FrameBuilder plain(config, config.camera);
  const Frame before = plain.build(0, 0, 0.0, image);
  FrameFilterResult filter;
  const Frame after = plain.build(0, 0, 0.0, image, cv::Mat(), -1, &detections, &filter);
  EXPECT_EQ(filter.stats.boxes_used, 1);
  EXPECT_GT(filter.stats.keypoints_added, 50);
  EXPECT_EQ(after.size(), before.size() + filter.stats.keypoints_added);
  ASSERT_EQ(after.labels.size(), after.size());
  ASSERT_EQ(after.points.size(), after.size());
  for (size_t i = 0; i < after.size(); ++i) {
    const bool in_box = box.contains(cv::Point(static_cast<int>(after.keypoints[i].pt.x), static_cast<int>(after.keypoints[i].pt.y)));
    EXPECT_EQ(after.labels[i].class_id, in_box ? 66 : -1) << i;
  }
  for (size_t i = before.size(); i < after.size(); ++i) EXPECT_EQ(after.labels[i].detection_id, 0);

  const FrameBuilder dynamic(config, config.camera, {66});
  FrameFilterResult removed;
  const Frame without = dynamic.build(0, 0, 0.0, image, cv::Mat(), -1, &detections, &removed);
  EXPECT_EQ(removed.stats.keypoints_added, 0);
  EXPECT_GT(removed.stats.keypoints_removed_dynamic, 20);
  EXPECT_EQ(without.size(), before.size() - removed.stats.keypoints_removed_dynamic);
  for (const cv::KeyPoint& keypoint : without.keypoints)
    EXPECT_FALSE(box.contains(cv::Point(static_cast<int>(keypoint.pt.x), static_cast<int>(keypoint.pt.y))));
}

// --box-filter label: no keypoint is added, so the frame is the detector-off
// frame keypoint for keypoint, and those inside the box carry its class.
TEST(FrameBuilderFilter, LabelFilterKeepsTheDetectorOffKeypointsAndLabelsThoseInTheBox) {
  const Sequence sequence = fr1Xyz();
  const cv::Mat image = sequence.loadColor(0);
  Config config = sequence.config;
  config.detector.box_filter = "label";
  Detection keyboard;
  keyboard.id = 0;
  keyboard.class_id = 66;
  keyboard.class_name = "keyboard";
  keyboard.confidence = 0.99f;
  keyboard.box = cv::Rect2f(326, 331, 270, 139);
  const std::vector<Detection> detections = {keyboard};
  const cv::Rect box = cv::Rect(326, 331, 270, 139) & cv::Rect(0, 0, image.cols, image.rows);

  const FrameBuilder builder(config, config.camera);
  const Frame plain = builder.build(0, 0, 0.0, image);
  FrameFilterResult filter;
  const Frame labelled = builder.build(0, 0, 0.0, image, cv::Mat(), -1, &detections, &filter);
  EXPECT_EQ(filter.stats.boxes_used, 1);
  EXPECT_EQ(filter.stats.keypoints_added, 0);
  ASSERT_EQ(labelled.size(), plain.size());
  EXPECT_EQ(cv::norm(labelled.descriptors, plain.descriptors, cv::NORM_HAMMING), 0);
  ASSERT_EQ(labelled.labels.size(), labelled.size());
  int in_box_count = 0;
  for (size_t i = 0; i < labelled.size(); ++i) {
    EXPECT_EQ(labelled.keypoints[i].pt, plain.keypoints[i].pt) << i;
    const bool in_box =
        box.contains(cv::Point(static_cast<int>(labelled.keypoints[i].pt.x), static_cast<int>(labelled.keypoints[i].pt.y)));
    EXPECT_EQ(labelled.labels[i].class_id, in_box ? 66 : -1) << i;
    in_box_count += in_box;
  }
  EXPECT_GT(in_box_count, 20);
}

struct SemanticRun {
  std::vector<StampedPose> frames;
  std::vector<ExportedMapPoint> points;
  std::vector<ObjectLandmark> objects;
  DetectionSummary detection;
};

// Deterministic run over the first `count` frames, submitting each next frame
// to detection ahead as `vslam run` does.
SemanticRun runFirstFrames(const Sequence& sequence, const DetectorParams& detector, size_t count) {
  Config config = sequence.config;
  config.detector = detector;
  SystemOptions options;
  options.deterministic = true;
  System system(config, options);
  test::feedFrames(system, sequence, false, count);
  system.finish();
  return {system.frameTrajectory(), system.mapPoints(), system.objectMap(), system.detectionSummary()};
}

int countClass(const std::vector<ExportedMapPoint>& points, int class_id) {
  return static_cast<int>(std::count_if(points.begin(), points.end(), [&](const auto& p) { return p.class_id == class_id; }));
}

// The paper's behaviour (--detect-every 1 --box-filter paper): every frame
// detected, ORB run again inside each box and appended.
TEST(SemanticSlam, PaperFilterAddsKeypointsAndLabelsTheMap) {
  const Sequence sequence = fr1Xyz();
  const std::vector<std::string> names = cocoNames();
  const int keyboard = static_cast<int>(std::find(names.begin(), names.end(), "keyboard") - names.begin());
  DetectorParams detector = sequence.config.detector;
  ASSERT_EQ(detector.model, "yolo-fastest-1.1-xl");
  detector.detect_every = *parseDetectEvery("1");
  detector.box_filter = "paper";
  const SemanticRun run = runFirstFrames(sequence, detector, 60);

  ASSERT_TRUE(run.detection.enabled);
  EXPECT_EQ(run.detection.frames, 60);
  EXPECT_EQ(run.detection.input_size, 320);
  EXPECT_GT(run.detection.median_ms, 0.0);
  // The keyboard, monitor and chair boxes on fr1_xyz are all over 64 px.
  EXPECT_GE(run.detection.boxes_used_per_frame, 2.0);
  EXPECT_GT(run.detection.keypoints_added_per_frame, 100.0);
  EXPECT_GE(run.frames.size(), 50u);

  // The keyboard fills the lower right of every frame: many map points on it,
  // and an object landmark of that class.
  EXPECT_GT(countClass(run.points, keyboard), 30);
  const auto keyboard_object = std::find_if(run.objects.begin(), run.objects.end(),
                                            [](const ObjectLandmark& o) { return o.class_name == "keyboard"; });
  ASSERT_NE(keyboard_object, run.objects.end());
  EXPECT_GE(keyboard_object->point_ids.size(), 30u);
  EXPECT_GE(keyboard_object->keyframe_ids.size(), 2u);
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(keyboard_object->box_min[a], keyboard_object->centroid[a]);
    EXPECT_GE(keyboard_object->box_max[a], keyboard_object->centroid[a]);
  }
  for (const ObjectLandmark& object : run.objects) {
    EXPECT_GT(object.confidence, 0.5);
    EXPECT_LE(object.confidence, 1.0);
  }
}

// The default detector (--detect-every auto --box-filter label; deterministic
// runs detect each keyframe) adds no keypoint, so tracking is the detector-off
// run's to the digit, while the map's points and objects still carry classes.
TEST(SemanticSlam, DefaultDetectorTracksAsDetectorOffAndLabelsTheMap) {
  const Sequence sequence = fr1Xyz();
  const std::vector<std::string> names = cocoNames();
  const int keyboard = static_cast<int>(std::find(names.begin(), names.end(), "keyboard") - names.begin());
  DetectorParams off = sequence.config.detector;
  off.model = "none";
  const SemanticRun plain = runFirstFrames(sequence, off, 60);
  const SemanticRun run = runFirstFrames(sequence, sequence.config.detector, 60);

  ASSERT_TRUE(run.detection.enabled);
  EXPECT_EQ(run.detection.detect_every, "auto");
  EXPECT_EQ(run.detection.box_filter, "label");
  EXPECT_EQ(run.detection.keypoints_added_total, 0);
  EXPECT_GE(run.detection.network_frames, 2);
  EXPECT_LT(run.detection.network_frames, 60);
  ASSERT_EQ(run.frames.size(), plain.frames.size());
  for (size_t i = 0; i < run.frames.size(); ++i) {
    EXPECT_EQ(run.frames[i].timestamp, plain.frames[i].timestamp) << i;
    EXPECT_EQ(run.frames[i].T_wc.matrix(), plain.frames[i].T_wc.matrix()) << i;
  }
  EXPECT_GT(countClass(run.points, keyboard), 30);
  EXPECT_TRUE(std::any_of(run.objects.begin(), run.objects.end(),
                          [](const ObjectLandmark& o) { return o.class_name == "keyboard"; }));
}

// The first 400 frames of fr1_xyz, deterministic (about 25 s on 2 cores). The
// monitor must come out as one tvmonitor under 1.2 m in every axis, whatever
// the detector called it in single keyframes: with the random BRIEF pattern the
// detector's "laptop" from frame 300 or so made a second screen object without
// merging, and stray points stretched the plain monitor box to 1.23 m. With
// standard ORB descriptors (issue 16) no laptop-labelled object forms and the
// plain box is 0.99 m wide, so that contrast is no longer on this data; the
// merging and the rejection are held by ObjectMap.OverlappingConfusableClassesMerge
// and ObjectMap.StrayPointsDoNotStretchTheBox. Sizes are metric through the
// Sim(3) scale of the trajectory against the ground truth.
TEST(SemanticSlam, ObjectsOfFr1XyzLookLikeTheObjects) {
  const Sequence sequence = fr1Xyz();
  const SemanticRun run = runFirstFrames(sequence, sequence.config.detector, 400);
  AteOptions ate;
  ate.alignment = Alignment::Sim3;
  const double scale = computeAte(run.frames, sequence.groundtruth, ate).scale;
  ASSERT_GT(scale, 0.5);

  int screens = 0;
  for (const ObjectLandmark& object : run.objects) {
    if (object.class_name == "tvmonitor" || object.class_name == "laptop") {
      ++screens;
      EXPECT_EQ(object.class_name, "tvmonitor");
      for (const std::string& merged : object.merged_classes) EXPECT_EQ(merged, "laptop");
    }
    // Desk-scale classes. The chair is left out: it stands 2.6 m from the
    // camera, where monocular depth scatters its points over more than a
    // metre without any of them being a stray (docs/SEMANTIC_MAP.md).
    if (object.class_name == "tvmonitor" || object.class_name == "keyboard" || object.class_name == "book")
      for (int a = 0; a < 3; ++a)
        EXPECT_LE(scale * (object.box_max[a] - object.box_min[a]), 1.2) << object.class_name << " axis " << a;
    EXPECT_LE(object.rejected_point_ids.size(), object.point_ids.size() / 5) << object.class_name;
  }
  EXPECT_EQ(screens, 1);
}

TEST(SemanticSlam, DynamicClassRemovesItsKeypoints) {
  const Sequence sequence = fr1Xyz();
  const std::vector<std::string> names = cocoNames();
  const int keyboard = static_cast<int>(std::find(names.begin(), names.end(), "keyboard") - names.begin());
  DetectorParams detector = sequence.config.detector;
  detector.dynamic_classes = {"keyboard"};
  const SemanticRun run = runFirstFrames(sequence, detector, 30);
  EXPECT_GT(run.detection.keypoints_removed_per_frame, 20.0);
  EXPECT_EQ(countClass(run.points, keyboard), 0);
  for (const ObjectLandmark& object : run.objects) EXPECT_NE(object.class_name, "keyboard");
}

TEST(SemanticSlam, DetectorNoneLabelsNothingAndRepeats) {
  const Sequence sequence = fr1Xyz();
  DetectorParams detector;
  detector.model = "none";
  const SemanticRun first = runFirstFrames(sequence, detector, 40);
  const SemanticRun second = runFirstFrames(sequence, detector, 40);
  EXPECT_FALSE(first.detection.enabled);
  EXPECT_TRUE(first.objects.empty());
  ASSERT_FALSE(first.points.empty());
  for (const ExportedMapPoint& point : first.points) EXPECT_EQ(point.class_id, -1);
  ASSERT_EQ(first.frames.size(), second.frames.size());
  for (size_t i = 0; i < first.frames.size(); ++i) {
    EXPECT_EQ(first.frames[i].T_wc.t, second.frames[i].T_wc.t) << i;
    EXPECT_EQ(first.frames[i].T_wc.R, second.frames[i].T_wc.R) << i;
  }
}

}  // namespace
}  // namespace vslam
