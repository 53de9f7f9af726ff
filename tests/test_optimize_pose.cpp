#include <random>

#include <gtest/gtest.h>

#include "optimize_synthetic.hpp"
#include "vslam/optimize/pose_optimizer.hpp"

namespace vslam {
namespace {

struct PoseScene {
  PinholeCamera camera = test::syntheticCamera();
  double bf = 0;
  SE3 T_cw_true;
  SE3 T_cw_initial;
  std::vector<Vec3> points_w;
  std::vector<Observation2D> observations;
  std::vector<bool> is_outlier;
};

// `count` noise-free observations seen from a known pose; the initial guess is
// 5 cm and 3 degrees away. With bf > 0, every other observation is stereo.
PoseScene makeScene(int count, double bf, unsigned seed) {
  std::mt19937 rng(seed);
  PoseScene scene;
  scene.bf = bf;
  scene.T_cw_true = SE3(test::rotationAbout(Vec3(0.2, 1, 0.1), 0.4), Vec3(0.3, -0.2, 1.0));
  scene.T_cw_initial = test::perturbPose(scene.T_cw_true, 0.05, test::degrees(3), rng);
  std::uniform_int_distribution<int> level(0, 7);
  for (int i = 0; i < count; ++i) {
    const Vec3 p_w = test::pointSeenBy(scene.camera, scene.T_cw_true, 1.0, 10.0, rng);
    const Vec3 p_c = scene.T_cw_true * p_w;
    Observation2D obs;
    obs.point = i;
    obs.pixel = scene.camera.project(p_c);
    obs.inv_sigma2 = 1.0 / std::pow(1.2, 2 * level(rng));
    if (bf > 0 && i % 2 == 1) obs.u_right = obs.pixel.x() - bf / p_c.z();
    scene.points_w.push_back(p_w);
    scene.observations.push_back(obs);
    scene.is_outlier.push_back(false);
  }
  return scene;
}

// Moves every fifth observation by 15..60 pixels (scaled by the level's sigma),
// far beyond the chi2 threshold.
void injectOutliers(PoseScene& scene, unsigned seed, bool right_coordinate_only = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> magnitude(15.0, 60.0);
  for (size_t i = 0; i < scene.observations.size(); i += 5) {
    Observation2D& obs = scene.observations[i];
    const double sigma = 1.0 / std::sqrt(obs.inv_sigma2);
    if (right_coordinate_only) {
      if (!hasRightCoordinate(obs.u_right)) continue;
      obs.u_right += magnitude(rng) * sigma;
    } else {
      const Vec3 direction = test::randomUnitVector(rng);
      obs.pixel += magnitude(rng) * sigma * Vec2(direction.x(), direction.y()).normalized();
    }
    scene.is_outlier[i] = true;
  }
}

void expectPoseNear(const SE3& actual, const SE3& expected, double tolerance) {
  EXPECT_LT((actual.t - expected.t).norm(), tolerance);
  EXPECT_LT(test::rotationDifference(actual.R, expected.R), tolerance);
}

int countInliers(const std::vector<bool>& is_outlier) {
  int n = 0;
  for (bool outlier : is_outlier) n += outlier ? 0 : 1;
  return n;
}

TEST(OptimizePose, RecoversTruePoseFromNoiseFreeObservations) {
  const PoseScene scene = makeScene(300, 0.0, 1);
  ASSERT_GT((scene.T_cw_initial.t - scene.T_cw_true.t).norm(), 0.049);
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
  EXPECT_EQ(result.n_inliers, 300);
  for (bool inlier : result.inlier) EXPECT_TRUE(inlier);
}

TEST(OptimizePose, FlagsInjectedOutliersExactly) {
  PoseScene scene = makeScene(300, 0.0, 2);
  injectOutliers(scene, 3);
  ASSERT_EQ(countInliers(scene.is_outlier), 240);
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
  EXPECT_EQ(result.n_inliers, 240);
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) EXPECT_EQ(result.inlier[i], !scene.is_outlier[i]) << i;
}

TEST(OptimizePose, StereoObservationsWithOutliers) {
  PoseScene scene = makeScene(300, 50.0, 4);
  injectOutliers(scene, 5);
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
  EXPECT_EQ(result.n_inliers, 240);
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) EXPECT_EQ(result.inlier[i], !scene.is_outlier[i]) << i;
}

TEST(OptimizePose, WrongDisparityAloneMakesAnOutlier) {
  PoseScene scene = makeScene(300, 50.0, 6);
  injectOutliers(scene, 7, /*right_coordinate_only=*/true);
  const int expected_inliers = countInliers(scene.is_outlier);
  ASSERT_EQ(expected_inliers, 270);  // only the stereo ones among every fifth were moved
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
  EXPECT_EQ(result.n_inliers, expected_inliers);
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) EXPECT_EQ(result.inlier[i], !scene.is_outlier[i]) << i;
}

TEST(OptimizePose, PointsBehindTheCameraAreOutliersNotCrashes) {
  PoseScene scene = makeScene(100, 0.0, 8);
  // Mirror ten points through the camera centre: they are now behind it, and
  // their (unchanged) pixels cannot be explained.
  const Vec3 centre = scene.T_cw_true.inverse().t;
  for (int i = 0; i < 10; ++i) {
    scene.points_w[i] = centre - (scene.points_w[i] - centre);
    scene.is_outlier[i] = true;
  }
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
  EXPECT_EQ(result.n_inliers, 90);
  for (size_t i = 0; i < scene.is_outlier.size(); ++i) EXPECT_EQ(result.inlier[i], !scene.is_outlier[i]) << i;
}

TEST(OptimizePose, DroppedObservationComesBackWhenItsErrorFalls) {
  PoseScene scene = makeScene(300, 0.0, 11);
  std::mt19937 rng(12);
  scene.T_cw_initial = test::perturbPose(scene.T_cw_true, 0.3, test::degrees(10), rng);
  PoseOptimizationOptions options;
  options.iterations_per_round = 1;  // one step per round: the early rounds end far from the minimum
  options.rounds = 1;
  const PoseOptimizationResult after_one_round =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations, options);
  // All observations are correct, yet the first round rejects many of them...
  ASSERT_LT(after_one_round.n_inliers, 290);
  ASSERT_GE(after_one_round.n_inliers, 10);
  // ...and later rounds take every one of them back.
  options.rounds = 10;
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations, options);
  EXPECT_EQ(result.n_inliers, 300);
  expectPoseNear(result.T_cw, scene.T_cw_true, 1e-6);
}

TEST(OptimizePose, TooFewObservationsLeaveThePoseUnchanged) {
  const PoseScene scene = makeScene(2, 0.0, 9);
  const PoseOptimizationResult result =
      optimizePose(scene.camera, scene.bf, scene.T_cw_initial, scene.points_w, scene.observations);
  EXPECT_LT((result.T_cw.t - scene.T_cw_initial.t).norm(), 1e-15);
  EXPECT_LT((result.T_cw.R - scene.T_cw_initial.R).norm(), 1e-15);
  EXPECT_EQ(result.inlier.size(), 2u);
}

TEST(OptimizePose, RejectsObservationOfMissingPoint) {
  PoseScene scene = makeScene(5, 0.0, 10);
  scene.observations[3].point = 5;
  EXPECT_THROW(optimizePose(scene.camera, 0.0, scene.T_cw_initial, scene.points_w, scene.observations),
               std::invalid_argument);
}

}  // namespace
}  // namespace vslam
