#include <random>

#include <gtest/gtest.h>

#include "geometry_synthetic.hpp"
#include "vslam/geometry/triangulation.hpp"

namespace vslam {
namespace {

TEST(GeometryTriangulation, DltRecoversRandomPointsExactly) {
  const Mat3 K = test::syntheticK();
  const SE3 T_c1w(test::rotationDeg(10, Vec3(0.2, 1, 0.1)), Vec3(0.1, -0.2, 0.3));
  const SE3 T_c2w(test::rotationDeg(-7, Vec3(1, 0.3, -0.2)), Vec3(-0.3, 0.05, 0.25));
  const Mat34 P1 = projectionMatrix(K, T_c1w);
  const Mat34 P2 = projectionMatrix(K, T_c2w);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(1.0, 6.0);
  for (int i = 0; i < 200; ++i) {
    const Vec3 X_w(xy(rng), xy(rng), z(rng));
    ASSERT_GT((T_c1w * X_w).z(), 0);
    ASSERT_GT((T_c2w * X_w).z(), 0);
    Vec3 X;
    // Pixels with K[R|t] ...
    ASSERT_TRUE(triangulateDlt(P1, P2, test::projectPx(K, T_c1w * X_w), test::projectPx(K, T_c2w * X_w), X));
    EXPECT_LT((X - X_w).norm(), 1e-9) << i;
    // ... and normalised coordinates with [R|t].
    const Mat34 N1 = projectionMatrix(Mat3::Identity(), T_c1w);
    const Mat34 N2 = projectionMatrix(Mat3::Identity(), T_c2w);
    ASSERT_TRUE(triangulateDlt(N1, N2, (T_c1w * X_w).hnormalized(), (T_c2w * X_w).hnormalized(), X));
    EXPECT_LT((X - X_w).norm(), 1e-9) << i;
  }
}

TEST(GeometryTriangulation, DltRejectsParallelRays) {
  // Same rotation, same pixel in both views: the rays are parallel and meet
  // only at infinity, which is not a finite point.
  const Mat3 K = test::syntheticK();
  const Mat34 P1 = projectionMatrix(K, SE3::identity());
  const Mat34 P2 = projectionMatrix(K, SE3(Mat3::Identity(), Vec3(-0.3, 0.1, 0.05)));
  Vec3 X;
  EXPECT_FALSE(triangulateDlt(P1, P2, Vec2(100, 100), Vec2(100, 100), X));
  EXPECT_FALSE(triangulateDlt(P1, P2, Vec2(320, 240), Vec2(320, 240), X));
}

TEST(GeometryTriangulation, ParallaxOfASymmetricPair) {
  // Centres at +-tan(15 deg) on x, point at z = 1 on the axis: rays meet at 30 deg.
  const double half = std::tan(15.0 * M_PI / 180.0);
  EXPECT_NEAR(parallaxDeg(Vec3(0, 0, 1), Vec3(-half, 0, 0), Vec3(half, 0, 0)), 30.0, 1e-12);
  EXPECT_NEAR(parallaxCos(Vec3(0, 0, 1), Vec3(-half, 0, 0), Vec3(half, 0, 0)), std::cos(30.0 * M_PI / 180.0), 1e-15);
  EXPECT_DOUBLE_EQ(parallaxDeg(Vec3(0, 0, 1), Vec3(0, 0, 0), Vec3(0, 0, 0)), 0.0);
}

TEST(GeometryTriangulation, GoodTriangulationChecksDepthReprojectionAndParallax) {
  const Mat3 K = test::syntheticK();
  const SE3 T_c1w = SE3::identity();
  const SE3 T_c2w(Mat3::Identity(), Vec3(-0.2, 0, 0));  // second centre at x = +0.2
  const Vec3 X(0.1, 0.05, 2.0);                          // parallax ~5.7 deg
  const Vec2 px1 = test::projectPx(K, T_c1w * X);
  const Vec2 px2 = test::projectPx(K, T_c2w * X);
  const double cos_1deg = std::cos(M_PI / 180.0);
  EXPECT_TRUE(isGoodTriangulation(X, T_c1w, T_c2w, K, px1, px2, 1.0, 1.0, cos_1deg));
  // Reprojection: sqrt(5.991) = 2.45 px is the bound at sigma 1 px; sigma^2 = 4 widens it.
  EXPECT_TRUE(isGoodTriangulation(X, T_c1w, T_c2w, K, px1 + Vec2(2.4, 0), px2, 1.0, 1.0, cos_1deg));
  EXPECT_FALSE(isGoodTriangulation(X, T_c1w, T_c2w, K, px1 + Vec2(2.5, 0), px2, 1.0, 1.0, cos_1deg));
  EXPECT_FALSE(isGoodTriangulation(X, T_c1w, T_c2w, K, px1, px2 + Vec2(0, 2.5), 1.0, 1.0, cos_1deg));
  EXPECT_TRUE(isGoodTriangulation(X, T_c1w, T_c2w, K, px1, px2 + Vec2(0, 2.5), 1.0, 4.0, cos_1deg));
  // Behind the cameras.
  const Vec3 behind(0.1, 0.05, -2.0);
  EXPECT_FALSE(isGoodTriangulation(behind, T_c1w, T_c2w, K, px1, px2, 1e9, 1e9, cos_1deg));
  // Too little parallax: a point 100 m away sees the 0.2 m baseline under ~0.11 deg.
  const Vec3 far(1.0, 0.5, 100.0);
  EXPECT_FALSE(isGoodTriangulation(far, T_c1w, T_c2w, K, test::projectPx(K, T_c1w * far),
                                   test::projectPx(K, T_c2w * far), 1.0, 1.0, cos_1deg));
  EXPECT_TRUE(isGoodTriangulation(far, T_c1w, T_c2w, K, test::projectPx(K, T_c1w * far),
                                  test::projectPx(K, T_c2w * far), 1.0, 1.0, std::cos(0.1 * M_PI / 180.0)));
}

}  // namespace
}  // namespace vslam
