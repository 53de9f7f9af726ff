#include <cmath>
#include <iostream>

#include <gtest/gtest.h>

#include "geometry_synthetic.hpp"
#include "vslam/geometry/two_view_initializer.hpp"

namespace vslam {
namespace {

constexpr double kDeg = M_PI / 180.0;

SE3 generalMotion() {
  // Mostly sideways, a little forward, 4 deg of rotation.
  return SE3(test::rotationDeg(4.0, Vec3(0.3, 1.0, 0.2)), Vec3(0.25, -0.04, 0.06));
}

struct StructureCheck {
  int inliers = 0;              // true (non-outlier) matches
  int inliers_triangulated = 0;
  int outliers_triangulated = 0;
  double max_relative_error = 0;  // |s X_est - X_true| / |X_true| over triangulated inliers
  double median_relative_error = 0;
};

// The structure comes out with a unit baseline: scale it by the true one.
StructureCheck checkStructure(const test::TwoViewScene& scene, const TwoViewResult& result) {
  StructureCheck check;
  std::vector<double> errors;
  const double scale = scene.T_cur_ref.t.norm();
  for (size_t i = 0; i < scene.points_ref.size(); ++i) {
    if (scene.is_outlier[i]) {
      check.outliers_triangulated += result.triangulated[i];
      continue;
    }
    ++check.inliers;
    if (!result.triangulated[i]) continue;
    ++check.inliers_triangulated;
    errors.push_back((scale * result.points_ref[i] - scene.points_ref[i]).norm() / scene.points_ref[i].norm());
  }
  if (!errors.empty()) {
    check.max_relative_error = *std::max_element(errors.begin(), errors.end());
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    check.median_relative_error = errors[errors.size() / 2];
  }
  return check;
}

TEST(GeometryInitializer, NonPlanarNoiseFreePicksFundamentalAndIsExact) {
  const auto scene = test::makeDepthScene(generalMotion(), 300, 0.0, 0.1, 1);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
  ASSERT_TRUE(result.success) << result.failure_reason;
  EXPECT_TRUE(result.failure_reason.empty());
  EXPECT_FALSE(result.used_homography);
  EXPECT_LT(result.score_ratio, 0.45);
  EXPECT_LT(test::rotationAngle(result.T_cur_ref.R, scene.T_cur_ref.R), 1e-6);
  EXPECT_NEAR(result.T_cur_ref.t.norm(), 1.0, 1e-12);
  EXPECT_LT(test::angleBetween(result.T_cur_ref.t, scene.T_cur_ref.t), 1e-6);

  const StructureCheck structure = checkStructure(scene, result);
  EXPECT_EQ(structure.inliers, 270);
  EXPECT_GE(structure.inliers_triangulated, 0.9 * structure.inliers);
  EXPECT_EQ(structure.outliers_triangulated, 0);
  EXPECT_LT(structure.max_relative_error, 1e-6);
  EXPECT_EQ(result.n_triangulated, structure.inliers_triangulated);
  // Every true match is an F inlier, every outlier is not.
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) EXPECT_NE(result.model_inliers[i], scene.is_outlier[i]) << i;
  EXPECT_GT(result.median_parallax_deg, 1.0);
}

TEST(GeometryInitializer, NonPlanarWithHalfPixelNoise) {
  const auto scene = test::makeDepthScene(generalMotion(), 300, 0.5, 0.1, 2);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
  ASSERT_TRUE(result.success) << result.failure_reason;
  EXPECT_FALSE(result.used_homography);
  EXPECT_LT(test::rotationAngle(result.T_cur_ref.R, scene.T_cur_ref.R), 0.1 * kDeg);
  EXPECT_LT(test::angleBetween(result.T_cur_ref.t, scene.T_cur_ref.t), 1.0 * kDeg);
  const StructureCheck structure = checkStructure(scene, result);
  EXPECT_GE(structure.inliers_triangulated, 0.9 * structure.inliers);
  EXPECT_EQ(structure.outliers_triangulated, 0);
  EXPECT_LT(structure.median_relative_error, 0.02);
}

TEST(GeometryInitializer, PlanarSceneNoiseFreePicksHomographyAndIsExact) {
  const SE3 motion(test::rotationDeg(3.0, Vec3(0.1, 1.0, -0.1)), Vec3(0.3, 0.05, 0.05));
  const auto scene = test::makePlanarScene(motion, Vec3(0.1, -0.3, 1.0).normalized(), 2.0, 300, 0.0, 0.1, 3);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
  ASSERT_TRUE(result.success) << result.failure_reason;
  EXPECT_TRUE(result.used_homography);
  EXPECT_GT(result.score_ratio, 0.45);
  EXPECT_LT(test::rotationAngle(result.T_cur_ref.R, scene.T_cur_ref.R), 1e-6);
  EXPECT_LT(test::angleBetween(result.T_cur_ref.t, scene.T_cur_ref.t), 1e-6);
  const StructureCheck structure = checkStructure(scene, result);
  EXPECT_GE(structure.inliers_triangulated, 0.9 * structure.inliers);
  EXPECT_EQ(structure.outliers_triangulated, 0);
  EXPECT_LT(structure.max_relative_error, 1e-6);
}

TEST(GeometryInitializer, PlanarSceneWithHalfPixelNoise) {
  const SE3 motion(test::rotationDeg(3.0, Vec3(0.1, 1.0, -0.1)), Vec3(0.3, 0.05, 0.05));
  const auto scene = test::makePlanarScene(motion, Vec3(0.1, -0.3, 1.0).normalized(), 2.0, 300, 0.5, 0.1, 4);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
  ASSERT_TRUE(result.success) << result.failure_reason;
  EXPECT_TRUE(result.used_homography);
  EXPECT_GT(result.score_ratio, 0.45);
  EXPECT_LT(test::rotationAngle(result.T_cur_ref.R, scene.T_cur_ref.R), 0.1 * kDeg);
  EXPECT_LT(test::angleBetween(result.T_cur_ref.t, scene.T_cur_ref.t), 1.0 * kDeg);
  const StructureCheck structure = checkStructure(scene, result);
  EXPECT_GE(structure.inliers_triangulated, 0.9 * structure.inliers);
  EXPECT_EQ(structure.outliers_triangulated, 0);
}

TEST(GeometryInitializer, CalibratedFScoringAndNoRefinementAlsoWork) {
  InitializerParams params;
  params.score_calibrated_f = true;
  params.refine_motion = false;
  const TwoViewInitializer initializer(test::syntheticK(), params, 0);
  const auto general = test::makeDepthScene(generalMotion(), 300, 0.0, 0.1, 1);
  const TwoViewResult f_result = initializer.initialize(general.px_ref, general.px_cur);
  ASSERT_TRUE(f_result.success) << f_result.failure_reason;
  EXPECT_FALSE(f_result.used_homography);
  EXPECT_LT(test::rotationAngle(f_result.T_cur_ref.R, general.T_cur_ref.R), 1e-6);
  EXPECT_LT(test::angleBetween(f_result.T_cur_ref.t, general.T_cur_ref.t), 1e-6);
  const SE3 motion(test::rotationDeg(3.0, Vec3(0.1, 1.0, -0.1)), Vec3(0.3, 0.05, 0.05));
  const auto plane = test::makePlanarScene(motion, Vec3(0.1, -0.3, 1.0).normalized(), 2.0, 300, 0.0, 0.1, 3);
  const TwoViewResult h_result = initializer.initialize(plane.px_ref, plane.px_cur);
  ASSERT_TRUE(h_result.success) << h_result.failure_reason;
  EXPECT_TRUE(h_result.used_homography);
  EXPECT_LT(test::rotationAngle(h_result.T_cur_ref.R, plane.T_cur_ref.R), 1e-6);
}

TEST(GeometryInitializer, PureRotationFailsForLackOfParallax) {
  const SE3 rotation_only(test::rotationDeg(5.0, Vec3(0.2, 1.0, 0.0)), Vec3::Zero());
  for (const double noise : {0.0, 0.5}) {
    const auto scene = test::makeDepthScene(rotation_only, 300, noise, 0.0, 5);
    const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
    const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
    EXPECT_FALSE(result.success) << "noise " << noise;
    EXPECT_NE(result.failure_reason.find("parallax"), std::string::npos)
        << "noise " << noise << ": " << result.failure_reason;
  }
}

TEST(GeometryInitializer, TooFewMatchesFails) {
  const auto scene = test::makeDepthScene(generalMotion(), 60, 0.0, 0.0, 6);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);  // min_matches 100
  const TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.failure_reason, "too few matches (60 < 100)");
}

TEST(GeometryInitializer, SameSeedSameResult) {
  const auto scene = test::makeDepthScene(generalMotion(), 300, 0.5, 0.1, 7);
  const TwoViewInitializer first(test::syntheticK(), InitializerParams{}, 42);
  const TwoViewInitializer second(test::syntheticK(), InitializerParams{}, 42);
  const TwoViewResult a = first.initialize(scene.px_ref, scene.px_cur);
  const TwoViewResult b = first.initialize(scene.px_ref, scene.px_cur);
  const TwoViewResult c = second.initialize(scene.px_ref, scene.px_cur);
  for (const TwoViewResult* other : {&b, &c}) {
    EXPECT_EQ(a.success, other->success);
    EXPECT_EQ(a.used_homography, other->used_homography);
    EXPECT_EQ(a.score_ratio, other->score_ratio);
    EXPECT_EQ(a.T_cur_ref.R, other->T_cur_ref.R);
    EXPECT_EQ(a.T_cur_ref.t, other->T_cur_ref.t);
    EXPECT_EQ(a.triangulated, other->triangulated);
    EXPECT_EQ(a.points_ref, other->points_ref);
    EXPECT_EQ(a.n_triangulated, other->n_triangulated);
    EXPECT_EQ(a.median_parallax_deg, other->median_parallax_deg);
  }
}

TEST(GeometryInitializer, HomographyAndFundamentalBuildingBlocks) {
  const Mat3 K = test::syntheticK();
  const auto scene = test::makeDepthScene(generalMotion(), 20, 0.0, 0.0, 8);
  // F: the epipolar constraint holds for every match, and F has rank 2.
  const Mat3 F = computeFundamental(scene.px_ref, scene.px_cur);
  for (size_t i = 0; i < scene.px_ref.size(); ++i) {
    EXPECT_NEAR(scene.px_cur[i].homogeneous().dot(F * scene.px_ref[i].homogeneous()), 0.0, 1e-12);
  }
  EXPECT_NEAR(Eigen::JacobiSVD<Mat3>(F).singularValues()(2), 0.0, 1e-15);
  // The true motion is one of the four essential decompositions.
  const std::vector<SE3> motions = motionsFromEssential(K.transpose() * F * K);
  ASSERT_EQ(motions.size(), 4u);
  int matching = 0;
  for (const SE3& T : motions) {
    matching += test::rotationAngle(T.R, scene.T_cur_ref.R) < 1e-9 &&
                test::angleBetween(T.t, scene.T_cur_ref.t) < 1e-9;
  }
  EXPECT_EQ(matching, 1);
  // H of a plane transfers its points exactly (DLT on 4 and on many points).
  const Vec3 normal = Vec3(0, 0.2, 1).normalized();
  const auto plane = test::makePlanarScene(generalMotion(), normal, 3.0, 30, 0.0, 0.0, 9);
  for (const size_t count : {size_t{4}, size_t{30}}) {
    const std::vector<Vec2> ref(plane.px_ref.begin(), plane.px_ref.begin() + count);
    const std::vector<Vec2> cur(plane.px_cur.begin(), plane.px_cur.begin() + count);
    const Mat3 H = computeHomography(ref, cur);
    for (size_t i = 0; i < plane.px_ref.size(); ++i) {
      EXPECT_LT(((H * plane.px_ref[i].homogeneous()).hnormalized() - plane.px_cur[i]).norm(), 1e-9);
    }
    int found = 0;
    for (const SE3& T : motionsFromHomography(H, K)) {
      found += test::rotationAngle(T.R, plane.T_cur_ref.R) < 1e-9 &&
               test::angleBetween(T.t, plane.T_cur_ref.t) < 1e-9;
    }
    EXPECT_EQ(found, 1);
  }
}

// Translation mostly sideways and a little back, 1 deg of rotation: fr3_teddy's
// first frames, where consecutive frames are 1.3 cm apart.
SE3 teddyLikeMotion(double baseline_m) {
  return SE3(test::rotationDeg(1.0, Vec3(0.0, 1.0, 0.1)), baseline_m * Vec3(0.9, 0.25, -0.37).normalized());
}

TEST(GeometryInitializer, TranslationDirectionUncertaintyShrinksWithTheBaseline) {
  // Noise-free, so the figure is the geometry's alone: 1 px of noise per
  // match propagated to the direction, rotation marginalised.
  std::vector<double> std_deg;
  for (const double baseline : {0.06, 0.1, 0.2}) {
    const auto scene = test::makeDepthScene(teddyLikeMotion(baseline), 150, 0.0, 0.0, 1);
    const TwoViewResult result = TwoViewInitializer(test::syntheticK(), InitializerParams{}, 0)
                                     .initialize(scene.px_ref, scene.px_cur);
    ASSERT_TRUE(result.success) << baseline << ": " << result.failure_reason;
    std_deg.push_back(result.translation_direction_std_deg);
  }
  std::cout << "translation direction std at 6, 10, 20 cm: " << std_deg[0] << ", " << std_deg[1] << ", " << std_deg[2]
            << " deg\n";
  // Measured: 2.28, 1.43, 0.71 deg: about inversely proportional to the baseline.
  EXPECT_GT(std_deg[0], 1.5 * std_deg[1]);
  EXPECT_GT(std_deg[1], 1.7 * std_deg[2]);
  EXPECT_LT(std_deg[1], 2.3 * std_deg[2]);
}

TEST(GeometryInitializer, TranslationDirectionUncertaintyIsTheRightSizeUnderNoise) {
  // Over 20 scenes with 1 px of noise in both images the direction's RMS
  // error must be of the first-order figure's size. Measured: RMS 3.6 deg
  // against a mean figure of 1.6 deg (the figure is per residual at 1 px; the
  // Sampson distance of a match noisy in both images spreads about sqrt(2)
  // times wider, and RANSAC adds its own share). A figure off by the pixel
  // scaling (e.g. a missing sigma) would be out by 10x or more.
  double sum_squared_error = 0, sum_std = 0;
  int n = 0;
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    const SE3 motion = teddyLikeMotion(0.1);
    const auto scene = test::makeDepthScene(motion, 150, 1.0, 0.0, seed);
    const TwoViewResult result = TwoViewInitializer(test::syntheticK(), InitializerParams{}, 0)
                                     .initialize(scene.px_ref, scene.px_cur);
    if (!result.success) continue;
    const double error_deg = test::angleBetween(result.T_cur_ref.t, motion.t) / kDeg;
    sum_squared_error += error_deg * error_deg;
    sum_std += result.translation_direction_std_deg;
    ++n;
  }
  ASSERT_GE(n, 18);
  const double rms_error = std::sqrt(sum_squared_error / n), mean_std = sum_std / n;
  std::cout << n << " scenes: RMS direction error " << rms_error << " deg, mean first-order figure " << mean_std
            << " deg\n";
  EXPECT_GT(rms_error, 1.0 * mean_std);
  EXPECT_LT(rms_error, 3.0 * mean_std);
}

TEST(GeometryInitializer, FundamentalWithAnUncertainTranslationDirectionIsRefused) {
  const auto scene = test::makeDepthScene(teddyLikeMotion(0.06), 150, 1.0, 0.0, 1);
  InitializerParams params;
  const TwoViewResult accepted = TwoViewInitializer(test::syntheticK(), params, 0).initialize(scene.px_ref, scene.px_cur);
  ASSERT_TRUE(accepted.success) << accepted.failure_reason;
  ASSERT_FALSE(accepted.used_homography);
  ASSERT_LT(accepted.translation_direction_std_deg, params.max_translation_direction_std_deg);

  // The same scene with the bound just under its figure.
  params.max_translation_direction_std_deg = 0.9 * accepted.translation_direction_std_deg;
  const TwoViewResult refused = TwoViewInitializer(test::syntheticK(), params, 0).initialize(scene.px_ref, scene.px_cur);
  EXPECT_FALSE(refused.success);
  EXPECT_NE(refused.failure_reason.find("translation direction from F uncertain"), std::string::npos)
      << refused.failure_reason;
  EXPECT_DOUBLE_EQ(refused.translation_direction_std_deg, accepted.translation_direction_std_deg);
}

TEST(GeometryInitializer, HomographyIsNotHeldToTheTranslationDirectionBound) {
  // A plane does not fix the epipolar geometry, so the figure is large or
  // infinite there; H has its own ambiguity test (the runner-up's share).
  const SE3 motion(test::rotationDeg(3.0, Vec3(0.1, 1.0, 0.0)), Vec3(0.2, 0.02, 0.03));
  const auto plane = test::makePlanarScene(motion, Vec3(0.1, -0.2, 1.0).normalized(), 2.0, 300, 0.0, 0.0, 3);
  InitializerParams params;
  params.max_translation_direction_std_deg = 1e-6;
  const TwoViewResult result = TwoViewInitializer(test::syntheticK(), params, 0).initialize(plane.px_ref, plane.px_cur);
  ASSERT_TRUE(result.success) << result.failure_reason;
  EXPECT_TRUE(result.used_homography);
}

TEST(GeometryInitializer, MedianDepth) {
  const std::vector<Vec3> points{{0, 0, 3}, {0, 0, 1}, {0, 0, 2}, {0, 0, 10}, {0, 0, 5}};
  EXPECT_DOUBLE_EQ(medianDepth(points), 3.0);
  EXPECT_DOUBLE_EQ(medianDepth(points, {true, true, true, false, false}), 2.0);
  EXPECT_DOUBLE_EQ(medianDepth({}), 0.0);
}

}  // namespace
}  // namespace vslam
