#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "geometry_synthetic.hpp"
#include "vslam/core/camera.hpp"
#include "vslam/geometry/sim3_solver.hpp"
#include "vslam/optimize/pose_graph.hpp"

namespace vslam {
namespace {

// Points 2-6 m in front of camera 2, mapped into camera 1 by the true S12;
// a fraction of them gets a wrong partner: a random point in front of camera 1
// (observed where it projects), as a wrong loop match would.
Sim3Correspondences makeSim3Scene(const Sim3& S12, int n, double outlier_ratio, uint32_t seed,
                                  std::vector<bool>& is_outlier) {
  const Mat3 K = test::syntheticK();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u_x(0, 640), u_y(0, 480), depth(2, 6);
  Sim3Correspondences m;
  is_outlier.assign(n, false);
  while (static_cast<int>(m.points_1.size()) < n) {
    const Vec3 p2 = depth(rng) * (K.inverse() * Vec2(u_x(rng), u_y(rng)).homogeneous());
    const Vec3 p1 = S12 * p2;
    if (p1.z() <= 0.1 || !test::inImage(test::projectPx(K, p1))) continue;
    m.points_1.push_back(p1);
    m.points_2.push_back(p2);
    m.pixels_1.push_back(test::projectPx(K, p1));
    m.pixels_2.push_back(test::projectPx(K, p2));
  }
  const int n_outliers = static_cast<int>(std::round(outlier_ratio * n));
  for (int k = 0; k < n_outliers; ++k) {
    const int i = k * n / n_outliers;
    Vec3 wrong;
    do {
      wrong = depth(rng) * S12.s * (K.inverse() * Vec2(u_x(rng), u_y(rng)).homogeneous());
    } while ((test::projectPx(K, wrong) - m.pixels_1[i]).norm() < 20);
    m.points_1[i] = wrong;
    m.pixels_1[i] = test::projectPx(K, wrong);
    is_outlier[i] = true;
  }
  return m;
}

Sim3 trueSim3(double scale) {
  return Sim3(scale, test::rotationDeg(12, Vec3(0.2, 1, -0.3)), Vec3(0.3, -0.1, 0.5));
}

TEST(GeometrySim3, ClosedFormIsExactOnThreePointsAndMore) {
  const Sim3 S = trueSim3(1.7);
  std::vector<bool> is_outlier;
  const Sim3Correspondences m = makeSim3Scene(S, 10, 0.0, 1, is_outlier);
  for (const size_t count : {size_t{3}, size_t{10}}) {
    const Sim3 estimated = computeSim3({m.points_1.begin(), m.points_1.begin() + count},
                                       {m.points_2.begin(), m.points_2.begin() + count}, false);
    EXPECT_NEAR(estimated.s, 1.7, 1e-9);
    EXPECT_LT(test::rotationAngle(estimated.R, S.R), 1e-9);
    EXPECT_LT((estimated.t - S.t).norm(), 1e-9);
  }
}

TEST(GeometrySim3, RansacRecoversScaleRotationTranslationAndFlagsOutliers) {
  const Sim3 S = trueSim3(1.7);
  std::vector<bool> is_outlier;
  const Sim3Correspondences m = makeSim3Scene(S, 100, 0.3, 2, is_outlier);
  const Sim3Result result = solveSim3Ransac(m, test::syntheticK(), test::syntheticK(), Sim3SolverParams{}, 0);
  ASSERT_TRUE(result.success);
  EXPECT_NEAR(result.S12.s, 1.7, 1e-9);
  EXPECT_LT(test::rotationAngle(result.S12.R, S.R), 1e-9);
  EXPECT_LT((result.S12.t - S.t).norm(), 1e-9);
  EXPECT_EQ(result.n_inliers, 70);
  for (size_t i = 0; i < is_outlier.size(); ++i) EXPECT_NE(result.inliers[i], is_outlier[i]) << i;
}

TEST(GeometrySim3, FixedScaleStaysAtOne) {
  // Rigid truth (RGB-D / stereo): recovered exactly with s = 1.
  const Sim3 rigid = trueSim3(1.0);
  std::vector<bool> is_outlier;
  const Sim3Correspondences m = makeSim3Scene(rigid, 100, 0.2, 3, is_outlier);
  Sim3SolverParams params;
  params.fix_scale = true;
  const Sim3Result result = solveSim3Ransac(m, test::syntheticK(), test::syntheticK(), params, 0);
  ASSERT_TRUE(result.success);
  EXPECT_EQ(result.S12.s, 1.0);
  EXPECT_LT(test::rotationAngle(result.S12.R, rigid.R), 1e-9);
  EXPECT_LT((result.S12.t - rigid.t).norm(), 1e-9);
  EXPECT_EQ(result.n_inliers, 80);
  // A scaled truth cannot be explained by a rigid motion: s stays 1 and few
  // matches agree with any hypothesis.
  const Sim3Correspondences scaled = makeSim3Scene(trueSim3(1.7), 100, 0.0, 4, is_outlier);
  const Sim3Result rigid_on_scaled = solveSim3Ransac(scaled, test::syntheticK(), test::syntheticK(), params, 0);
  EXPECT_EQ(rigid_on_scaled.S12.s, 1.0);
  EXPECT_FALSE(rigid_on_scaled.success);
}

TEST(GeometrySim3, ReprojectionRefinementBeatsTheThreeDimensionalFitUnderDepthNoise) {
  // Exact pixels, map-point depths off by up to 5 % (as triangulated depths
  // are): the RANSAC's 3D fit absorbs the depth errors; optimizeSim3, which
  // loop closing runs after it, minimises pixel errors and does not care.
  const Sim3 S = trueSim3(1.7);
  std::vector<bool> is_outlier;
  Sim3Correspondences m = makeSim3Scene(S, 100, 0.2, 6, is_outlier);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> depth_error(0.95, 1.05);
  for (size_t i = 0; i < m.points_1.size(); ++i) {
    m.points_1[i] *= depth_error(rng);
    m.points_2[i] *= depth_error(rng);
  }
  const Sim3Result fit_3d = solveSim3Ransac(m, test::syntheticK(), test::syntheticK(), Sim3SolverParams{}, 0);
  ASSERT_TRUE(fit_3d.success);

  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = test::syntheticK()(0, 0);
  camera.fy = test::syntheticK()(1, 1);
  camera.cx = test::syntheticK()(0, 2);
  camera.cy = test::syntheticK()(1, 2);
  std::vector<Sim3Match> matches(m.points_1.size());
  for (size_t i = 0; i < matches.size(); ++i)
    matches[i] = {m.points_1[i], m.points_2[i], m.pixels_1[i], m.pixels_2[i], 1.0, 1.0};
  Sim3 refined = fit_3d.S12;
  const Sim3OptimizationResult result = optimizeSim3(camera, matches, refined);

  const double rotation_3d = test::rotationAngle(fit_3d.S12.R, S.R);
  const double rotation_refined = test::rotationAngle(refined.R, S.R);
  std::cout << "rotation error: 3D fit " << rotation_3d * 180 / M_PI << " deg, refined "
            << rotation_refined * 180 / M_PI << " deg; scale " << fit_3d.S12.s << " / " << refined.s << "; inliers "
            << fit_3d.n_inliers << " / " << result.n_inliers << "\n";
  EXPECT_LT(rotation_refined, 0.5 * rotation_3d);
  EXPECT_LT(rotation_refined, 0.1 * M_PI / 180);
  EXPECT_NEAR(refined.s, 1.7, 0.02 * 1.7);
  EXPECT_LT(fit_3d.n_inliers, 80);       // the 3D fit loses true matches ...
  EXPECT_EQ(result.n_inliers, 80);       // ... the refinement gets every one back
  for (size_t i = 0; i < is_outlier.size(); ++i) EXPECT_EQ(result.inlier[i], !is_outlier[i]) << i;
}

TEST(GeometrySim3, DeterministicForASeed) {
  std::vector<bool> is_outlier;
  const Sim3Correspondences m = makeSim3Scene(trueSim3(0.6), 80, 0.4, 5, is_outlier);
  const Sim3Result a = solveSim3Ransac(m, test::syntheticK(), test::syntheticK(), Sim3SolverParams{}, 3);
  const Sim3Result b = solveSim3Ransac(m, test::syntheticK(), test::syntheticK(), Sim3SolverParams{}, 3);
  ASSERT_TRUE(a.success);
  EXPECT_EQ(a.S12.s, b.S12.s);
  EXPECT_EQ(a.S12.R, b.S12.R);
  EXPECT_EQ(a.S12.t, b.S12.t);
  EXPECT_EQ(a.inliers, b.inliers);
}

}  // namespace
}  // namespace vslam
