#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "geometry_synthetic.hpp"
#include "vslam/geometry/pnp.hpp"

namespace vslam {
namespace {

struct PnpScene {
  SE3 T_cw;
  std::vector<Vec3> points_w;
  std::vector<Vec2> pixels;
  std::vector<bool> is_outlier;
};

// `n` points 2-6 m in front of the camera; a fraction of the pixels replaced by
// random ones at least 20 px from the true projection.
PnpScene makePnpScene(int n, double outlier_ratio, double noise_px, uint32_t seed) {
  const Mat3 K = test::syntheticK();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u_x(0, 640), u_y(0, 480), depth(2, 6);
  std::normal_distribution<double> noise(0, noise_px);
  PnpScene scene;
  scene.T_cw = SE3(test::rotationDeg(25, Vec3(0.3, -1, 0.4)), Vec3(0.4, -0.2, 1.1));
  const SE3 T_wc = scene.T_cw.inverse();
  for (int i = 0; i < n; ++i) {
    const Vec2 px(u_x(rng), u_y(rng));
    const Vec3 p_c = depth(rng) * (K.inverse() * px.homogeneous());
    scene.points_w.push_back(T_wc * p_c);
    scene.pixels.push_back(px + (noise_px > 0 ? Vec2(noise(rng), noise(rng)) : Vec2::Zero()));
    scene.is_outlier.push_back(false);
  }
  const int n_outliers = static_cast<int>(std::round(outlier_ratio * n));
  for (int k = 0; k < n_outliers; ++k) {
    const int i = k * n / n_outliers;
    Vec2 px;
    do {
      px = Vec2(u_x(rng), u_y(rng));
    } while ((px - scene.pixels[i]).norm() < 20);
    scene.pixels[i] = px;
    scene.is_outlier[i] = true;
  }
  return scene;
}

std::vector<int> trueInliers(const PnpScene& scene) {
  std::vector<int> inliers;
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) {
    if (!scene.is_outlier[i]) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

TEST(GeometryPnp, NoiseFreeWithOutliersIsExact) {
  const PnpScene scene = makePnpScene(200, 0.2, 0.0, 1);
  const PnpResult result = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 0);
  ASSERT_TRUE(result.success);
  EXPECT_LT(test::rotationAngle(result.T_cw.R, scene.T_cw.R), 1e-6);
  EXPECT_LT((result.T_cw.t - scene.T_cw.t).norm(), 1e-6);
  EXPECT_EQ(result.inliers, trueInliers(scene));  // every outlier flagged, every inlier kept
}

TEST(GeometryPnp, HalfPixelNoise) {
  const PnpScene scene = makePnpScene(200, 0.2, 0.5, 2);
  const PnpResult result = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 0);
  ASSERT_TRUE(result.success);
  EXPECT_LT(test::rotationAngle(result.T_cw.R, scene.T_cw.R), 0.1 * M_PI / 180);
  EXPECT_LT((result.T_cw.t - scene.T_cw.t).norm(), 0.01);
  // 0.5 px noise stays well inside 2.45 px: the inlier set is still exact.
  EXPECT_EQ(result.inliers, trueInliers(scene));
}

TEST(GeometryPnp, DeterministicForASeed) {
  const PnpScene scene = makePnpScene(150, 0.3, 0.5, 3);
  const PnpResult a = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 9);
  const PnpResult b = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 9);
  ASSERT_TRUE(a.success);
  EXPECT_EQ(a.T_cw.R, b.T_cw.R);
  EXPECT_EQ(a.T_cw.t, b.T_cw.t);
  EXPECT_EQ(a.inliers, b.inliers);
}

TEST(GeometryPnp, FailsBelowMinInliers) {
  const PnpScene scene = makePnpScene(40, 0.5, 0.0, 4);  // 20 true inliers
  const PnpResult result = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 0);
  EXPECT_FALSE(result.success);
  const PnpResult relaxed = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 20, 0);
  ASSERT_TRUE(relaxed.success);
  EXPECT_EQ(relaxed.inliers, trueInliers(scene));
  EXPECT_FALSE(solvePnpRansac({Vec3(0, 0, 1)}, {Vec2(1, 1)}, test::syntheticK()).success);
}

}  // namespace
// ORB-SLAM2's threshold grows with the keypoint's pyramid level: chi-square
// 5.991 sigma^2 with sigma = 1.2^level. A match 3 px off is an outlier for a
// level-0 keypoint (threshold 2.45 px) and an inlier at level 3 (4.23 px).
TEST(GeometryPnp, ThresholdScalesWithThePyramidLevel) {
  PnpScene scene = makePnpScene(100, 0.0, 0.0, 5);
  std::vector<double> sigma(scene.pixels.size(), 1.0);
  for (size_t i = 0; i < scene.pixels.size(); i += 10) {
    scene.pixels[i] += Vec2(3.0, 0.0);
    if (i % 20 == 0) sigma[i] = std::pow(1.2, 3);  // 5 of the 10 displaced keypoints are coarse
  }
  const PnpResult fixed = solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, std::sqrt(5.991), 30, 0);
  const PnpResult scaled =
      solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, std::sqrt(5.991), 30, 0, sigma);
  ASSERT_TRUE(fixed.success);
  ASSERT_TRUE(scaled.success);
  EXPECT_EQ(fixed.inliers.size(), 90u);
  EXPECT_EQ(scaled.inliers.size(), 95u);
  for (size_t i = 0; i < scene.pixels.size(); i += 10) {
    const bool kept = std::binary_search(scaled.inliers.begin(), scaled.inliers.end(), static_cast<int>(i));
    EXPECT_EQ(kept, i % 20 == 0) << "match " << i;
  }
  // A sigma per match or none.
  EXPECT_FALSE(solvePnpRansac(scene.points_w, scene.pixels, test::syntheticK(), 300, 2.45, 30, 0, {1.0, 1.0}).success);
}

}  // namespace vslam
