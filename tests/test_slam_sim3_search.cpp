// The guided Sim(3) search of loop closing (searchBySim3, ORB-SLAM's
// SearchBySim3) on two hand-built keyframes related by a known similarity:
// the matches it adds are exactly the true pairs, and each decoy (outside the
// window, one-sided, an already matched keypoint, wrong level, far
// descriptor, no map point) is left out. And loop fusion's rule: where a
// loop point meets a keypoint that has a point already, the loop point stays.
#include <algorithm>
#include <array>
#include <cstdint>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "synthetic_views.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/slam/map_matching.hpp"

namespace vslam {
namespace {

using Descriptor = std::array<uint8_t, 32>;

// Bytes straight from mt19937 (its output is fixed by the standard; the
// distributions are not).
Descriptor randomDescriptor(std::mt19937& rng) {
  Descriptor d;
  for (uint8_t& byte : d) byte = static_cast<uint8_t>(rng() & 0xff);
  return d;
}

// `d` with its first `bits` bits flipped: Hamming distance exactly `bits`.
Descriptor flipBits(Descriptor d, int bits) {
  for (int b = 0; b < bits; ++b) d[b / 8] ^= static_cast<uint8_t>(1u << (b % 8));
  return d;
}

// One keyframe's features before it becomes a keyframe.
struct FeatureList {
  std::vector<Vec2> pixels;
  std::vector<Descriptor> descriptors;
  std::vector<int> octaves;
  int add(const Vec2& pixel, const Descriptor& descriptor, int octave = 0) {
    pixels.push_back(pixel);
    descriptors.push_back(descriptor);
    octaves.push_back(octave);
    return static_cast<int>(pixels.size()) - 1;
  }
};

class Sim3SearchTest : public ::testing::Test {
 protected:
  KeyFrame* makeKeyFrame(long id, const FeatureList& features, const SE3& T_cw) {
    Frame frame;
    frame.id = id;
    frame.index = static_cast<int>(id);
    frame.timestamp = static_cast<double>(id);
    frame.camera = &camera_;
    frame.pyramid = &pyramid_;
    frame.descriptors = cv::Mat::zeros(static_cast<int>(features.pixels.size()), 32, CV_8U);
    for (size_t i = 0; i < features.pixels.size(); ++i) {
      const Vec2& px = features.pixels[i];
      cv::KeyPoint kp(cv::Point2f(static_cast<float>(px.x()), static_cast<float>(px.y())), 31.f, 0.f, 1.f,
                      features.octaves[i]);
      frame.keypoints.push_back(kp);
      frame.points.push_back(kp.pt);
      frame.colours.emplace_back(0, 0, 0);
      std::copy(features.descriptors[i].begin(), features.descriptors[i].end(),
                frame.descriptors.ptr<uint8_t>(static_cast<int>(i)));
    }
    frame.T_cw = T_cw;
    frame.finalizeFeatures(cv::Rect2f(0, 0, 640, 480));
    return map_.createKeyFrame(frame);
  }

  // A map point seen only by keypoint `index` of `keyframe`, at `depth` along its ray.
  MapPoint* addPoint(KeyFrame* keyframe, int index, double depth) {
    const Vec2 px = keyframe->point(index);
    const Vec3 p_c((px.x() - camera_.cx) / camera_.fx * depth, (px.y() - camera_.cy) / camera_.fy * depth, depth);
    MapPoint* point = map_.createMapPoint(keyframe->pose().inverse() * p_c, keyframe);
    point->addObservation(keyframe, index);
    keyframe->setMapPoint(index, point);
    point->updateDescriptor();
    point->updateNormalAndDepth(pyramid_);
    return point;
  }

  Vec3 backProject(const Vec2& px, double depth) const {
    return Vec3((px.x() - camera_.cx) / camera_.fx * depth, (px.y() - camera_.cy) / camera_.fy * depth, depth);
  }

  PinholeCamera camera_ = test::vgaCamera();
  ScalePyramid pyramid_ = makeScalePyramid(8, 1.2);
  Map map_;
};

TEST_F(Sim3SearchTest, AddsExactlyTheMutualMatchesOfTheSimilarity) {
  // S12 maps keyframe 2's camera coordinates into keyframe 1's: a drifted
  // scale (0.8), a 3-degree turn and a shift. Keyframe 1 sits at the world
  // origin; keyframe 2 has a pose of its own, so the world frames differ too.
  const Sim3 S12(0.8, Eigen::AngleAxisd(3.0 * M_PI / 180.0, Vec3(0, 1, 0).normalized()).toRotationMatrix(),
                 Vec3(0.1, -0.05, 0.02));
  const Sim3 S21 = S12.inverse();
  const SE3 T_2w(Eigen::AngleAxisd(10.0 * M_PI / 180.0, Vec3(0, 0, 1)).toRotationMatrix(), Vec3(0.3, 0.2, -0.1));
  // Where a point at pixel `px1`, `depth1` in keyframe 1 appears in keyframe 2, and its depth there.
  auto inKeyFrame2 = [&](const Vec2& px1, double depth1) {
    const Vec3 p_c2 = S21 * backProject(px1, depth1);
    return std::make_pair(camera_.project(p_c2), p_c2.z());
  };

  std::mt19937 rng(16);
  FeatureList f1, f2;
  struct Pair {
    int index1, index2;
    double depth1, depth2;
  };
  std::vector<Pair> with_points;  // both keypoints get a map point at these depths
  std::vector<std::pair<int, int>> expected;
  std::vector<std::pair<int, int>> prematched;

  // Four pairs RANSAC already accepted: kept as they are.
  for (int k = 0; k < 4; ++k) {
    const Vec2 px1(120.0 + 100 * k, 100);
    const auto [px2, depth2] = inKeyFrame2(px1, 5.0);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d), j = f2.add(px2, flipBits(d, 4));
    with_points.push_back({i, j, 5.0, depth2});
    prematched.emplace_back(i, j);
  }
  // Five true pairs to find, the descriptors 3 bits apart.
  for (int k = 0; k < 5; ++k) {
    const Vec2 px1(110.0 + 100 * k, 250);
    const double depth1 = 4.5 + 0.25 * k;
    const auto [px2, depth2] = inKeyFrame2(px1, depth1);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d), j = f2.add(px2, flipBits(d, 3));
    with_points.push_back({i, j, depth1, depth2});
    expected.emplace_back(i, j);
  }
  // Outside the window: the same descriptor 20 px to the right of where it should be.
  {
    const Vec2 px1(150, 400);
    const auto [px2, depth2] = inKeyFrame2(px1, 5.0);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d), j = f2.add(px2 + Vec2(20, 0), d);
    with_points.push_back({i, j, 5.0, depth2});
  }
  // One-sided: D lands next to E's keypoint in keyframe 2 and takes it (30
  // bits), but E's point picks its own keypoint in keyframe 1 (0 bits).
  {
    const Vec2 px_e(450, 400), px_d(454, 403);
    const auto [px2, depth2] = inKeyFrame2(px_e, 5.0);
    const Descriptor d_e = randomDescriptor(rng);
    const int e1 = f1.add(px_e, d_e), e2 = f2.add(px2, d_e);
    const int d1 = f1.add(px_d, flipBits(d_e, 30));
    with_points.push_back({e1, e2, 5.0, depth2});
    with_points.push_back({d1, -1, 5.0, 0});
    expected.emplace_back(e1, e2);
  }
  // An already matched keypoint of keyframe 2 with F's very descriptor, 2 px
  // from F's true keypoint (8 bits off): F must take the true one.
  {
    const Vec2 px_f(250, 400);
    const auto [px2, depth2] = inKeyFrame2(px_f, 5.0);
    const Descriptor d_f = randomDescriptor(rng);
    const int f_1 = f1.add(px_f, d_f), f_2 = f2.add(px2, flipBits(d_f, 8));
    const int taken = f2.add(px2 + Vec2(2, 0), d_f);
    const int partner = f1.add(Vec2(600, 50), randomDescriptor(rng));
    with_points.push_back({f_1, f_2, 5.0, depth2});
    with_points.push_back({partner, taken, 5.0, depth2});
    prematched.emplace_back(partner, taken);
    expected.emplace_back(f_1, f_2);
  }
  // The right place and descriptor at the wrong pyramid level (4).
  {
    const Vec2 px1(350, 400);
    const auto [px2, depth2] = inKeyFrame2(px1, 5.0);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d), j = f2.add(px2, d, 4);
    with_points.push_back({i, j, 5.0, depth2});
  }
  // The right place, a descriptor 110 bits away (over ORB-SLAM's TH_HIGH of 100).
  {
    const Vec2 px1(550, 400);
    const auto [px2, depth2] = inKeyFrame2(px1, 5.0);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d), j = f2.add(px2, flipBits(d, 110));
    with_points.push_back({i, j, 5.0, depth2});
  }
  // The right place and descriptor, but keyframe 2's keypoint has no map point.
  {
    const Vec2 px1(540, 120);
    const auto [px2, depth2] = inKeyFrame2(px1, 5.0);
    const Descriptor d = randomDescriptor(rng);
    const int i = f1.add(px1, d);
    f2.add(px2, d);
    with_points.push_back({i, -1, 5.0, 0});
  }
  for (const Vec2& px : f2.pixels) ASSERT_TRUE(camera_.inImage(px)) << px.transpose();

  KeyFrame* kf1 = makeKeyFrame(0, f1, SE3());
  KeyFrame* kf2 = makeKeyFrame(1, f2, T_2w);
  for (const Pair& p : with_points) {
    addPoint(kf1, p.index1, p.depth1);
    if (p.index2 >= 0) addPoint(kf2, p.index2, p.depth2);
  }

  std::vector<MapPoint*> matches12(kf1->size(), nullptr);
  for (const auto& [i, j] : prematched) matches12[i] = kf2->mapPoint(j);
  const std::vector<MapPoint*> before = matches12;

  EXPECT_EQ(searchBySim3(*kf1, *kf2, S12, matches12), static_cast<int>(expected.size()));
  std::vector<MapPoint*> wanted = before;
  for (const auto& [i, j] : expected) wanted[i] = kf2->mapPoint(j);
  for (size_t i = 0; i < kf1->size(); ++i)
    EXPECT_EQ(matches12[i], wanted[i]) << "keypoint " << i << " of keyframe 1";

  // The same keyframes under the identity similarity: nothing lines up.
  std::vector<MapPoint*> unguided = before;
  EXPECT_EQ(searchBySim3(*kf1, *kf2, Sim3(), unguided), 0);
  EXPECT_EQ(unguided, before);
}

// Loop fusion (ORB-SLAM2's SearchAndFuse) keeps the loop side's point even
// where the current side's point is seen more; Local Mapping's fusion keeps
// the one seen more.
TEST_F(Sim3SearchTest, LoopFusionKeepsTheLoopSidesPoint) {
  for (const FuseKeeps keeps : {FuseKeeps::Projected, FuseKeeps::MoreObserved}) {
    map_.clear();
    std::mt19937 rng(7);
    const Descriptor d = randomDescriptor(rng);
    const Vec2 px(320, 240);
    FeatureList one;
    one.add(px, d);
    // The loop side: one keyframe. The current side: two keyframes seeing the
    // same spot, 1 cm to the side (the drift the loop correction left).
    KeyFrame* loop_kf = makeKeyFrame(0, one, SE3());
    KeyFrame* current_kf = makeKeyFrame(1, one, SE3(Mat3::Identity(), Vec3(0.01, 0, 0)));
    KeyFrame* current_neighbour = makeKeyFrame(2, one, SE3(Mat3::Identity(), Vec3(0.01, 0, 0)));
    MapPoint* loop_point = addPoint(loop_kf, 0, 3.0);
    MapPoint* own_point = addPoint(current_kf, 0, 3.0);
    own_point->addObservation(current_neighbour, 0);
    current_neighbour->setMapPoint(0, own_point);
    ASSERT_GT(own_point->observationCount(), loop_point->observationCount());

    ASSERT_EQ(fuse(current_kf, {loop_point}, 4.0, keeps), 1);
    MapPoint* survivor = keeps == FuseKeeps::Projected ? loop_point : own_point;
    MapPoint* retired = keeps == FuseKeeps::Projected ? own_point : loop_point;
    EXPECT_TRUE(retired->isBad());
    EXPECT_FALSE(survivor->isBad());
    EXPECT_EQ(current_kf->mapPoint(0), survivor);
    EXPECT_EQ(current_neighbour->mapPoint(0), survivor);
    EXPECT_EQ(loop_kf->mapPoint(0), survivor);
    EXPECT_EQ(survivor->observationCount(), 3);
  }
}

}  // namespace
}  // namespace vslam
