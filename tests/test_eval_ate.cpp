// ATE on cases whose answer is known exactly, and against the independent
// reference implementation of evaluate_ate (tools/evaluate_ate_reference.py).
#include <cmath>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/timestamp_association.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

StampedPose at(double t, const Vec3& position, const Mat3& R = Mat3::Identity()) {
  StampedPose pose;
  pose.timestamp = t;
  pose.T_wc = SE3(R, position);
  return pose;
}

// A curved, non-planar path so that every alignment is well defined.
std::vector<StampedPose> helix(int n) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i)
    poses.push_back(at(0.1 * i, Vec3(std::cos(0.2 * i), std::sin(0.2 * i), 0.05 * i),
                       Eigen::AngleAxisd(0.1 * i, Vec3::UnitZ()).toRotationMatrix()));
  return poses;
}

Sim3 someSim3(double scale) {
  return Sim3(scale, Eigen::AngleAxisd(0.7, Vec3(0.2, -1.0, 0.5).normalized()).toRotationMatrix(), Vec3(3, -2, 1));
}

TEST(Association, GreedyOverSortedDifferencesLikeAssociatePy) {
  // 1.00 is nearer to 1.01 than 1.03 is to 1.01... but 1.03-1.025 is the closest pair of all,
  // so it is taken first; 1.00 then gets 1.01, and 2.0 has nothing within 0.02.
  const std::vector<double> first = {1.00, 1.03, 2.0};
  const std::vector<double> second = {1.01, 1.025, 1.5};
  const auto pairs = associateTimestamps(first, second, 0.02);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0], std::make_pair(0, 0));
  EXPECT_EQ(pairs[1], std::make_pair(1, 1));
  // The bound is strict, as in associate.py: 0.02 apart does not pair.
  EXPECT_TRUE(associateTimestamps({1.0}, {1.25}, 0.25).empty());
  EXPECT_EQ(associateTimestamps({1.0}, {1.125}, 0.25).size(), 1u);
  // Each timestamp is used once: two estimates near one ground-truth pose.
  EXPECT_EQ(associateTimestamps({1.0, 1.004}, {1.003}, 0.02), (std::vector<std::pair<int, int>>{{1, 0}}));
}

TEST(Ate, KnownSim3AlignsBackAndRecoversTheScale) {
  const std::vector<StampedPose> groundtruth = helix(60);
  std::vector<StampedPose> estimate = groundtruth;
  const Sim3 S = someSim3(0.37);  // a monocular run's arbitrary frame and scale
  for (StampedPose& pose : estimate) pose.T_wc.t = S * pose.T_wc.t;
  AteOptions options;
  options.alignment = Alignment::Sim3;
  const AteResult ate = computeAte(estimate, groundtruth, options);
  EXPECT_EQ(ate.pairs, 60);
  EXPECT_LT(ate.rmse_m, 1e-9);
  EXPECT_LT(ate.max_m, 1e-9);
  EXPECT_NEAR(ate.scale, 1.0 / 0.37, 1e-9);
  const Sim3 inverse = S.inverse();
  EXPECT_LT((ate.alignment.R - inverse.R).norm(), 1e-9);
  EXPECT_LT((ate.alignment.t - inverse.t).norm(), 1e-9);

  // Without scale the same estimate cannot be aligned: the error is large.
  options.alignment = Alignment::SE3;
  const AteResult rigid = computeAte(estimate, groundtruth, options);
  EXPECT_DOUBLE_EQ(rigid.scale, 1.0);
  EXPECT_GT(rigid.rmse_m, 0.3);
}

TEST(Ate, KnownRigidMotionAlignsBackWithSe3) {
  const std::vector<StampedPose> groundtruth = helix(40);
  std::vector<StampedPose> estimate = groundtruth;
  const Sim3 S = someSim3(1.0);
  for (StampedPose& pose : estimate) pose.T_wc.t = S * pose.T_wc.t;
  const AteResult ate = computeAte(estimate, groundtruth, AteOptions());
  EXPECT_LT(ate.rmse_m, 1e-9);
  EXPECT_NEAR(ate.scale, 1.0, 1e-12);
}

TEST(Ate, AlternatingOffsetGivesExactlyThatError) {
  // Every ground-truth position twice; the estimate is +d, -d along z around it.
  // The offsets have zero mean and no correlation with the path, so the best
  // alignment is the identity and every error is d.
  const double d = 0.05;
  const std::vector<StampedPose> path = helix(30);
  std::vector<StampedPose> groundtruth, estimate;
  for (size_t i = 0; i < path.size(); ++i) {
    for (int k = 0; k < 2; ++k) {
      const double t = 0.2 * i + 0.1 * k;
      groundtruth.push_back(at(t, path[i].T_wc.t));
      estimate.push_back(at(t + 0.005, path[i].T_wc.t + Vec3(0, 0, k == 0 ? d : -d)));
    }
  }
  const AteResult ate = computeAte(estimate, groundtruth, AteOptions());
  EXPECT_EQ(ate.pairs, 60);
  EXPECT_NEAR(ate.rmse_m, d, 1e-12);
  EXPECT_NEAR(ate.mean_m, d, 1e-12);
  EXPECT_NEAR(ate.median_m, d, 1e-12);
  EXPECT_NEAR(ate.min_m, d, 1e-12);
  EXPECT_NEAR(ate.max_m, d, 1e-12);
  EXPECT_NEAR(ate.std_m, 0.0, 1e-12);
}

TEST(Ate, HandComputedFourPoses) {
  // Ground truth at (1,0,0), (-1,0,0), (0,2,0), (0,-2,0). The estimate is pushed
  // out radially by 3 % and along z by +-0.04 m. Centroids stay at 0 and the
  // cross-covariance stays diagonal, so the SE(3) alignment is the identity and
  // the errors are |(0.03, 0, 0.04)| = 0.05 twice and |(0, 0.06, 0.04)| = 0.0721110255 twice.
  const double eps = 0.03, a = 0.04;
  const std::vector<StampedPose> groundtruth = {at(0, {1, 0, 0}), at(1, {-1, 0, 0}), at(2, {0, 2, 0}),
                                                at(3, {0, -2, 0})};
  const std::vector<StampedPose> estimate = {at(0, {1 + eps, 0, a}), at(1, {-1 - eps, 0, a}),
                                             at(2, {0, 2 + 2 * eps, -a}), at(3, {0, -2 - 2 * eps, -a})};
  const AteResult ate = computeAte(estimate, groundtruth, AteOptions());
  const double e1 = 0.05, e2 = std::sqrt(0.0052);
  EXPECT_EQ(ate.pairs, 4);
  EXPECT_NEAR(ate.rmse_m, std::sqrt(0.00385), 1e-12);  // sqrt((2 * 0.0025 + 2 * 0.0052) / 4)
  EXPECT_NEAR(ate.mean_m, (e1 + e2) / 2, 1e-12);
  EXPECT_NEAR(ate.median_m, (e1 + e2) / 2, 1e-12);
  EXPECT_NEAR(ate.std_m, (e2 - e1) / 2, 1e-12);
  EXPECT_NEAR(ate.min_m, e1, 1e-12);
  EXPECT_NEAR(ate.max_m, e2, 1e-12);
  EXPECT_LT((ate.alignment.R - Mat3::Identity()).norm(), 1e-12);
  EXPECT_EQ(toJson(ate).size(), 8u);
  EXPECT_DOUBLE_EQ(toJson(ate)["rmse_m"].get<double>(), ate.rmse_m);
  EXPECT_EQ(toJson(ate)["pairs"].get<int>(), 4);
}

TEST(Ate, IndexAssociationPairsLineWithLine) {
  std::vector<StampedPose> groundtruth = helix(10), estimate = helix(12);
  for (size_t i = 0; i < estimate.size(); ++i) estimate[i].timestamp = 100.0 + i;  // times play no part
  AteOptions options;
  options.association = Association::Index;
  const AteResult ate = computeAte(estimate, groundtruth, options);
  EXPECT_EQ(ate.pairs, 10);
  EXPECT_LT(ate.rmse_m, 1e-12);
  EXPECT_EQ(ate.pairs_idx[9], std::make_pair(9, 9));
}

TEST(Ate, TooFewPairsIsAnError) {
  const std::vector<StampedPose> groundtruth = helix(10);
  std::vector<StampedPose> estimate = helix(10);
  for (StampedPose& pose : estimate) pose.timestamp += 50.0;
  try {
    computeAte(estimate, groundtruth, AteOptions());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("only 0 of 10 estimated poses pair"), std::string::npos) << e.what();
  }
}

// A run that tracked nothing: the reason is the empty estimate, not pairing.
TEST(Ate, EmptyEstimateSaysItHoldsNoPoses) {
  try {
    computeAte({}, helix(10), AteOptions());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "the estimate holds no poses; at least 3 are needed to align");
  }
}

TEST(Ate, MotionlessEstimateIsAnErrorNotNaN) {
  const std::vector<StampedPose> groundtruth = helix(10);
  std::vector<StampedPose> estimate = helix(10);
  for (StampedPose& pose : estimate) pose.T_wc.t = Vec3(1, 2, 3);
  AteOptions options;
  options.alignment = Alignment::Sim3;
  try {
    computeAte(estimate, groundtruth, options);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("all the same point"), std::string::npos) << e.what();
  }
}

// The perturbed copy of tools/make_perturbed_trajectory.py, computed here with the same formula.
std::vector<StampedPose> perturbedFr1Xyz(const std::vector<StampedPose>& groundtruth) {
  const Mat3 R = Eigen::AngleAxisd(30.0 * M_PI / 180.0, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Vec3 t0(0.4, -1.2, 2.0);
  std::vector<StampedPose> estimate;
  for (size_t i = 0, k = 0; i < groundtruth.size(); i += 3, ++k) {
    const Vec3 noise = 0.01 * Vec3(std::sin(12.9898 * k), std::sin(78.233 * k + 1), std::sin(37.719 * k + 2));
    estimate.push_back(at(groundtruth[i].timestamp + 0.004, 0.5 * (R * (groundtruth[i].T_wc.t + noise)) + t0,
                          R * groundtruth[i].T_wc.R));
  }
  return estimate;
}

TEST(Ate, AgreesWithTheEvaluateAteReferenceOnFr1Xyz) {
  const std::string gt_path = (test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string();
  const std::vector<StampedPose> groundtruth = readTumTrajectory(gt_path);
  const std::string est_path = (test::scratchDir("ate_reference") / "perturbed.txt").string();
  writeTumTrajectory(est_path, perturbedFr1Xyz(groundtruth));  // through the file, as the script does
  const std::vector<StampedPose> estimate = readTumTrajectory(est_path);

  // Figures of: python3 tools/evaluate_ate_reference.py GT EST [--scale] (docs/EVALUATION.md).
  AteOptions options;
  options.alignment = Alignment::Sim3;
  const AteResult sim3 = computeAte(estimate, groundtruth, options);
  EXPECT_EQ(sim3.pairs, 1000);
  EXPECT_NEAR(sim3.rmse_m, 0.012180351210754182, 1e-7);
  EXPECT_NEAR(sim3.mean_m, 0.011840448675868497, 1e-7);
  EXPECT_NEAR(sim3.median_m, 0.012079635276190211, 1e-7);
  EXPECT_NEAR(sim3.std_m, 0.0028573993020655788, 1e-7);
  EXPECT_NEAR(sim3.min_m, 0.001616816357141406, 1e-7);
  EXPECT_NEAR(sim3.max_m, 0.018378034433426803, 1e-7);
  EXPECT_NEAR(sim3.scale, 1.996925663473192, 1e-7);

  options.alignment = Alignment::SE3;
  const AteResult se3 = computeAte(estimate, groundtruth, options);
  EXPECT_EQ(se3.pairs, 1000);
  EXPECT_NEAR(se3.rmse_m, 0.09332425815327433, 1e-7);
  EXPECT_NEAR(se3.mean_m, 0.08322454595914205, 1e-7);
  EXPECT_NEAR(se3.median_m, 0.07889024758943661, 1e-7);
  EXPECT_NEAR(se3.std_m, 0.04222667533388871, 1e-7);
  EXPECT_NEAR(se3.min_m, 0.003988023068545485, 1e-7);
  EXPECT_NEAR(se3.max_m, 0.18375900522039118, 1e-7);
  EXPECT_DOUBLE_EQ(se3.scale, 1.0);
}

}  // namespace
}  // namespace vslam
