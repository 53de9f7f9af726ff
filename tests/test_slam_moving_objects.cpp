// The motion check of --moving-classes boxes on hand-built frames: which
// keypoints are labelled, and when a box is judged parked, moving or left
// undecided, with and without depth.
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "synthetic_views.hpp"
#include "vslam/map/map_point.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/slam/moving_objects.hpp"

namespace vslam {
namespace {

constexpr int kPerson = 0, kCar = 2, kChair = 56;

class MovingObjectsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_.bf = 40;
    frame_.camera = &camera_;
    frame_.pyramid = &pyramid_;
    // The camera at the origin looking along +z, moved 10 cm to the right.
    frame_.T_cw.t = Vec3(-0.1, 0, 0);
  }

  // A keypoint where the point X (world) projects under the frame's pose,
  // shifted by `shift_px`, matched to a map point at X.
  void addMatchedKeypoint(const Vec3& X, double shift_px, double depth = -1) {
    const Vec3 p = frame_.T_cw * X;
    const cv::Point2f pixel(static_cast<float>(camera_.fx * p.x() / p.z() + camera_.cx + shift_px),
                            static_cast<float>(camera_.fy * p.y() / p.z() + camera_.cy));
    frame_.keypoints.emplace_back(pixel, 31.f, 0.f, 1.f, 0);
    frame_.points.push_back(pixel);
    if (depth > 0) {
      frame_.depth.push_back(static_cast<float>(depth));
      frame_.u_right.push_back(static_cast<float>(pixel.x - camera_.bf / depth));
    } else if (!frame_.depth.empty() || depth == 0) {
      frame_.depth.push_back(-1.f);
      frame_.u_right.push_back(0.f);
    }
    points_.push_back(std::make_unique<MapPoint>(static_cast<long>(points_.size()), X, nullptr, 0));
    frame_.map_points.push_back(points_.back().get());
  }

  static Detection box(int id, int class_id, float x, float y, float w, float h) {
    Detection detection;
    detection.id = id;
    detection.class_id = class_id;
    detection.box = cv::Rect2f(x, y, w, h);
    return detection;
  }

  PinholeCamera camera_ = test::vgaCamera();
  ScalePyramid pyramid_ = makeScalePyramid(1, 1.2);
  Frame frame_;
  std::vector<std::unique_ptr<MapPoint>> points_;
};

// With depth, keypoints of a person's box well behind the person (the wall
// seen around them) go back to the static scene; the person's own keypoints,
// and those without depth, keep the box's label. The person's depth is the
// median over the box's central half: 2.0 m here, so "behind" starts at
// 2.0 x 1.15 + 0.3 = 2.6 m.
TEST_F(MovingObjectsTest, KeypointsBehindTheObjectGoBackToTheStaticScene) {
  struct Keypoint {
    cv::Point2f pixel;
    float depth;
  };
  // Box x 100-300, y 100-400: its central half is x 150-250, y 175-325.
  const std::vector<Keypoint> keypoints = {
      {{200, 200}, 1.9f}, {{210, 250}, 2.0f}, {{190, 300}, 2.1f}, {{160, 180}, 2.0f}, {{240, 320}, 5.0f},  // core
      {{110, 110}, 2.59f},  // the person's edge, just in front of 2.6 m
      {{290, 390}, 2.61f},  // just behind: the wall
      {{120, 390}, 6.0f},   // the wall
      {{280, 120}, -1.f},   // no depth: stays the person's
      {{500, 200}, 6.0f}};  // outside the box
  for (const Keypoint& k : keypoints) {
    frame_.keypoints.emplace_back(k.pixel, 31.f);
    frame_.depth.push_back(k.depth);
  }
  const std::vector<Detection> detections = {box(0, kPerson, 100, 100, 200, 300)};
  labelMovableKeypoints(detections, {kPerson}, frame_);
  releaseBackgroundByDepth(detections, frame_);
  const std::vector<ObjectMotion> expected = {
      ObjectMotion::Unchecked,  ObjectMotion::Unchecked,  ObjectMotion::Unchecked, ObjectMotion::Unchecked,
      ObjectMotion::NotMovable, ObjectMotion::Unchecked,  ObjectMotion::NotMovable, ObjectMotion::NotMovable,
      ObjectMotion::Unchecked,  ObjectMotion::NotMovable};
  ASSERT_EQ(frame_.labels.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(frame_.labels[i].motion, expected[i]) << "keypoint " << i;
    const bool the_persons = expected[i] == ObjectMotion::Unchecked;
    EXPECT_EQ(frame_.labels[i].class_id, the_persons ? kPerson : -1) << "keypoint " << i;
  }

  // Fewer than 5 depths in the central half: the box is left as labelled.
  Frame few = frame_;
  few.labels.clear();
  for (size_t i = 0; i < 3; ++i) few.depth[i] = -1.f;
  labelMovableKeypoints(detections, {kPerson}, few);
  releaseBackgroundByDepth(detections, few);
  EXPECT_EQ(few.labels[7].motion, ObjectMotion::Unchecked);
  // A frame without depth is left alone too.
  Frame mono = few;
  mono.depth.clear();
  mono.labels.clear();
  labelMovableKeypoints(detections, {kPerson}, mono);
  releaseBackgroundByDepth(detections, mono);
  EXPECT_EQ(mono.labels[7].motion, ObjectMotion::Unchecked);
}

TEST_F(MovingObjectsTest, LabelsKeypointsInBoxesOfMovableClassesOnly) {
  for (const cv::Point2f p : {cv::Point2f(50, 50), cv::Point2f(150, 150), cv::Point2f(199.5f, 100), cv::Point2f(200, 100),
                              cv::Point2f(420, 300)})
    frame_.keypoints.emplace_back(p, 31.f);
  const std::vector<Detection> detections = {box(0, kPerson, 100, 100, 100, 200),  // holds (150,150), (199.5,100)
                                             box(1, kChair, 0, 0, 640, 480),       // not movable: no label
                                             box(2, kCar, 400, 280, 50, 50),       // holds (420,300)
                                             box(3, kPerson, 410, 290, 20, 20)};    // smaller, also holds (420,300)
  labelMovableKeypoints(detections, {kPerson, kCar}, frame_);
  ASSERT_EQ(frame_.labels.size(), 5u);
  EXPECT_EQ(frame_.labels[0].motion, ObjectMotion::NotMovable);
  EXPECT_EQ(frame_.labels[1].motion, ObjectMotion::Unchecked);
  EXPECT_EQ(frame_.labels[1].detection_id, 0);
  EXPECT_EQ(frame_.labels[2].detection_id, 0);
  EXPECT_EQ(frame_.labels[3].motion, ObjectMotion::NotMovable);  // the box's right edge is outside
  EXPECT_EQ(frame_.labels[4].detection_id, 3);                    // the smaller of two boxes
  EXPECT_EQ(frame_.labels[4].class_id, kPerson);
  // Without movable classes nothing changes.
  Frame untouched;
  untouched.keypoints = frame_.keypoints;
  labelMovableKeypoints(detections, {}, untouched);
  EXPECT_TRUE(untouched.labels.empty());
}

TEST_F(MovingObjectsTest, JudgesEachBoxByItsMatchesUnderThePose) {
  // Box 0: 6 points where the pose puts them (parked). Box 1: 6 points 5 px
  // off (moving: chi2 25 > 5.991 at level 0). Box 2: 4 points 5 px off (too
  // few to judge). Box 3: 3 of 6 off, exactly the parked share. Box 4: 4 of 6 off.
  struct Box {
    int id;
    int n;
    int off;
  };
  const std::vector<Box> boxes = {{0, 6, 0}, {1, 6, 6}, {2, 4, 4}, {3, 6, 3}, {4, 6, 4}};
  for (const Box& b : boxes)
    for (int k = 0; k < b.n; ++k) {
      addMatchedKeypoint(Vec3(0.2 * k - 0.5, 0.1 * b.id - 0.2, 3.0), k < b.off ? 5.0 : 0.0);
      frame_.labels.push_back({kPerson, b.id, ObjectMotion::Unchecked});
    }
  // One unmatched keypoint in box 0 and one static keypoint, both left as they are but relabelled with their box.
  frame_.keypoints.emplace_back(cv::Point2f(10, 10), 31.f);
  frame_.points.emplace_back(10.f, 10.f);
  frame_.map_points.push_back(nullptr);
  frame_.labels.push_back({kPerson, 0, ObjectMotion::Unchecked});
  addMatchedKeypoint(Vec3(1, 1, 4), 9.0);
  frame_.labels.push_back({});

  std::vector<bool> consistent;
  const std::vector<ObjectMotionVerdict> verdicts = checkObjectMotion(frame_, &consistent);
  ASSERT_EQ(verdicts.size(), 5u);
  const ObjectMotion expected[] = {ObjectMotion::Parked, ObjectMotion::Moving, ObjectMotion::Unchecked,
                                   ObjectMotion::Parked, ObjectMotion::Moving};
  const int expected_consistent[] = {6, 0, 0, 3, 2};
  for (int b = 0; b < 5; ++b) {
    EXPECT_EQ(verdicts[b].detection_id, b);
    EXPECT_EQ(verdicts[b].matched, boxes[b].n) << b;
    EXPECT_EQ(verdicts[b].consistent, expected_consistent[b]) << b;
    EXPECT_EQ(verdicts[b].motion, expected[b]) << b;
  }
  size_t i = 0;
  for (const Box& b : boxes)
    for (int k = 0; k < b.n; ++k, ++i) {
      EXPECT_EQ(frame_.labels[i].motion, expected[b.id]) << i;
      EXPECT_EQ(consistent[i], k >= b.off) << i;
    }
  EXPECT_EQ(frame_.labels[i].motion, ObjectMotion::Parked);  // the unmatched keypoint follows its box
  EXPECT_EQ(frame_.labels[i + 1].motion, ObjectMotion::NotMovable);
  EXPECT_FALSE(consistent[i + 1]);  // static keypoints are not judged
}

TEST_F(MovingObjectsTest, DepthTellsAnObjectMovingAlongTheRay) {
  // A person walking straight at the camera: the pixels stay put, the depth
  // shrinks by 20 cm. Without depth the box looks parked; with it, moving.
  for (int k = 0; k < 6; ++k) {
    const Vec3 X(0.1 * k - 0.3, 0.05 * k, 3.0);
    const double depth_now = (frame_.T_cw * X).z() - 0.2;
    addMatchedKeypoint(X, 0.0, depth_now);
    frame_.labels.push_back({kPerson, 0, ObjectMotion::Unchecked});
  }
  Frame without_depth = frame_;
  without_depth.depth.clear();
  without_depth.u_right.clear();
  EXPECT_EQ(checkObjectMotion(without_depth).front().motion, ObjectMotion::Parked);
  // bf / z: 40 / 3.0 = 13.33 px against 40 / 2.8 = 14.29 px, 0.95 px apart on u_R: chi2 0.91 < 7.815...
  // ...too little at 3 m; at 1 m the same 20 cm is 10 px.
  EXPECT_EQ(checkObjectMotion(frame_).front().motion, ObjectMotion::Parked);
  Frame close = frame_;
  for (size_t i = 0; i < close.size(); ++i) {
    const Vec3 X = close.map_points[i]->position();
    points_.push_back(std::make_unique<MapPoint>(100 + static_cast<long>(i), Vec3(X.x() / 3.0, X.y() / 3.0, 1.0), nullptr, 0));
    close.map_points[i] = points_.back().get();
    const Vec3 p = close.T_cw * close.map_points[i]->position();
    const cv::Point2f pixel(static_cast<float>(camera_.fx * p.x() / p.z() + camera_.cx),
                            static_cast<float>(camera_.fy * p.y() / p.z() + camera_.cy));
    close.keypoints[i].pt = pixel;
    close.points[i] = pixel;
    close.depth[i] = static_cast<float>(p.z() - 0.2);
    close.u_right[i] = static_cast<float>(pixel.x - camera_.bf / close.depth[i]);
    close.labels[i].motion = ObjectMotion::Unchecked;
  }
  EXPECT_EQ(checkObjectMotion(close).front().motion, ObjectMotion::Moving);
}

}  // namespace
}  // namespace vslam
