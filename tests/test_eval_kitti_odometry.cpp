// The KITTI odometry metric on hand-built roads with a known drift, and on a
// copy of KITTI 00's ground truth checked against an independent transcription
// of the devkit (tools/kitti_odometry_reference.py).
#include <cmath>
#include <optional>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/eval/kitti_odometry_metric.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

constexpr double kDegPerRad = 180.0 / M_PI;

// A straight road along the camera's z axis, one frame a metre: 1001 frames, 1000 m.
std::vector<SE3> straightRoad() {
  std::vector<SE3> road;
  for (int i = 0; i <= 1000; ++i) road.emplace_back(Mat3::Identity(), Vec3(0, 0, i));
  return road;
}

std::vector<std::optional<SE3>> everyFrame(const std::vector<SE3>& poses) {
  return std::vector<std::optional<SE3>>(poses.begin(), poses.end());
}

std::vector<SE3> kitti00GroundTruth() {
  std::vector<SE3> poses;
  for (const StampedPose& pose : readKittiTrajectory((test::sharedData() / "kitti" / "poses" / "00.txt").string()))
    poses.push_back(pose.T_wc);
  return poses;
}

TEST(KittiOdometryMetric, ConstantScaleErrorOnAStraightRoad) {
  // The estimate drives 1.02 m for every metre. A subsequence of L metres ends
  // at the first frame strictly beyond L, i.e. L + 1 m on, so its error is
  // 0.02 (L + 1) m, divided by the nominal L: 2.02 % for L = 100 m.
  const std::vector<SE3> road = straightRoad();
  std::vector<SE3> estimate;
  for (const SE3& pose : road) estimate.emplace_back(pose.R, 1.02 * pose.t);

  KittiOdometryOptions hundred;
  hundred.lengths_m = {100};
  const KittiOdometryResult short_only = computeKittiOdometryError(road, everyFrame(estimate), hundred);
  ASSERT_TRUE(short_only.available);
  EXPECT_FALSE(short_only.standard_lengths);
  EXPECT_EQ(short_only.subsequences, 90);  // starts 0, 10, ..., 890 (the last frame is 1000)
  EXPECT_NEAR(short_only.translation_error_pct, 2.02, 1e-10);
  EXPECT_NEAR(short_only.rotation_error_deg_per_100m, 0.0, 1e-12);

  const KittiOdometryResult result = computeKittiOdometryError(road, everyFrame(estimate));
  ASSERT_TRUE(result.available);
  EXPECT_TRUE(result.standard_lengths);
  EXPECT_DOUBLE_EQ(result.groundtruth_length_m, 1000.0);
  // Length L has a subsequence from every 10th frame up to 999 - L: 90, 80, ..., 20 of them.
  const int counts[8] = {90, 80, 70, 60, 50, 40, 30, 20};
  double expected_sum = 0;
  ASSERT_EQ(result.per_length.size(), 8u);
  for (int k = 0; k < 8; ++k) {
    const double length = 100.0 * (k + 1);
    expected_sum += counts[k] * 2.0 * (length + 1) / length;
    EXPECT_EQ(result.per_length[k].subsequences, counts[k]);
    EXPECT_NEAR(result.per_length[k].translation_error_pct, 2.0 * (length + 1) / length, 1e-10);
  }
  EXPECT_EQ(result.subsequences, 440);
  EXPECT_EQ(result.subsequences_without_estimate, 0);
  EXPECT_NEAR(result.translation_error_pct, expected_sum / 440, 1e-10);
  EXPECT_NEAR(result.translation_error_pct, 2.0087175324675326, 1e-10);  // the same sum, worked out
}

TEST(KittiOdometryMetric, ConstantRotationDriftPerMetre) {
  // Positions exact, orientation drifting by 0.1 deg per metre about the
  // direction of travel (z): E is that rotation alone, 0.1 (L + 1) deg over a
  // subsequence, i.e. 10 (L + 1) / L deg/100m, and no translation.
  const std::vector<SE3> road = straightRoad();
  const double drift = 0.1 / kDegPerRad;  // rad per metre
  std::vector<SE3> rolling, yawing;
  for (const SE3& pose : road) {
    rolling.emplace_back(Eigen::AngleAxisd(drift * pose.t.z(), Vec3::UnitZ()).toRotationMatrix(), pose.t);
    yawing.emplace_back(Eigen::AngleAxisd(drift * pose.t.z(), Vec3::UnitY()).toRotationMatrix(), pose.t);
  }
  KittiOdometryOptions hundred;
  hundred.lengths_m = {100};
  const KittiOdometryResult roll = computeKittiOdometryError(road, everyFrame(rolling), hundred);
  EXPECT_NEAR(roll.rotation_error_deg_per_100m, 10.1, 1e-9);
  EXPECT_NEAR(roll.translation_error_pct, 0.0, 1e-9);

  const KittiOdometryResult all_lengths = computeKittiOdometryError(road, everyFrame(rolling));
  const int counts[8] = {90, 80, 70, 60, 50, 40, 30, 20};
  double expected_sum = 0;
  for (int k = 0; k < 8; ++k) {
    const double length = 100.0 * (k + 1);
    expected_sum += counts[k] * 10.0 * (length + 1) / length;
    EXPECT_NEAR(all_lengths.per_length[k].rotation_error_deg_per_100m, 10.0 * (length + 1) / length, 1e-9);
  }
  EXPECT_NEAR(all_lengths.rotation_error_deg_per_100m, expected_sum / 440, 1e-9);

  // A heading (yaw) drift has the same rotational error; its translational
  // error, from the positions seen in a turned frame, is not checked here.
  const KittiOdometryResult yaw = computeKittiOdometryError(road, everyFrame(yawing), hundred);
  EXPECT_NEAR(yaw.rotation_error_deg_per_100m, 10.1, 1e-9);
}

TEST(KittiOdometryMetric, Kitti00GroundTruthWithAScaleDrift) {
  // Every position 1 % further from the start: E's translation is 1 % of the
  // chord between the subsequence's ends. 200 frames, 144.9 m: five 100 m
  // subsequences (from frames 0, 10, 20, 30, 40). Reference:
  // tools/kitti_odometry_reference.py poses/00.txt <this copy>: 0.792460935239 %.
  const std::vector<SE3> groundtruth = kitti00GroundTruth();
  ASSERT_EQ(groundtruth.size(), 200u);
  std::vector<SE3> drifted;
  for (const SE3& pose : groundtruth) drifted.emplace_back(pose.R, 1.01 * pose.t);
  const KittiOdometryResult result = computeKittiOdometryError(groundtruth, everyFrame(drifted));
  ASSERT_TRUE(result.available);
  EXPECT_EQ(result.subsequences, 5);
  EXPECT_NEAR(result.groundtruth_length_m, 144.878560, 1e-6);
  EXPECT_NEAR(result.translation_error_pct, 0.792460935239, 1e-9);
  EXPECT_NEAR(result.rotation_error_deg_per_100m, 0.0, 1e-4);  // the 7-digit rotations are not quite orthogonal
  ASSERT_EQ(result.per_length.size(), 1u);
  EXPECT_EQ(result.per_length[0].length_m, 100.0);

  // A monocular-like copy: moved and shrunk by a similarity; with the Sim(3)
  // scale given back, nothing is left.
  const Sim3 similarity(0.3, Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix(), Vec3(4, -5, 6));
  std::vector<SE3> moved;
  for (const SE3& pose : groundtruth) moved.emplace_back(similarity.R * pose.R, similarity * pose.t);
  KittiOdometryOptions rescaled;
  rescaled.scale = 1.0 / 0.3;
  const KittiOdometryResult aligned = computeKittiOdometryError(groundtruth, everyFrame(moved), rescaled);
  EXPECT_NEAR(aligned.translation_error_pct, 0.0, 1e-9);
  EXPECT_NEAR(aligned.rotation_error_deg_per_100m, 0.0, 1e-4);
}

TEST(KittiOdometryMetric, LostFramesAreNeitherScoredNorHidden) {
  const std::vector<SE3> groundtruth = kitti00GroundTruth();
  std::vector<std::optional<SE3>> estimate = everyFrame(groundtruth);
  estimate[0].reset();    // the first subsequence (0 -> 137) starts on a lost frame
  estimate[160].reset();  // the third (20 -> 160) ends on one
  estimate[5].reset();    // inside subsequences only: no effect
  const KittiOdometryResult result = computeKittiOdometryError(groundtruth, estimate);
  ASSERT_TRUE(result.available);
  EXPECT_EQ(result.subsequences, 3);
  EXPECT_EQ(result.subsequences_without_estimate, 2);

  std::vector<std::optional<SE3>> nothing(groundtruth.size());
  const KittiOdometryResult lost = computeKittiOdometryError(groundtruth, nothing);
  EXPECT_FALSE(lost.available);
  EXPECT_EQ(lost.unavailable_reason, "none of the 5 subsequences has an estimate at both its first and last frame");
}

TEST(KittiOdometryMetric, TooShortARoadIsNullWithAReasonNeverZero) {
  std::vector<SE3> groundtruth = kitti00GroundTruth();
  groundtruth.resize(50);  // 45.7 m
  const KittiOdometryResult result = computeKittiOdometryError(groundtruth, everyFrame(groundtruth));
  EXPECT_FALSE(result.available);
  EXPECT_EQ(result.subsequences, 0);
  EXPECT_EQ(result.unavailable_reason,
            "the ground truth covers 45.7 m over 50 frames; no subsequence of 100.0 m (the shortest length) fits");
  const nlohmann::json json = toJson(result);
  EXPECT_TRUE(json["translation_error_pct"].is_null());
  EXPECT_TRUE(json["rotation_error_deg_per_100m"].is_null());
  EXPECT_EQ(json["reason"], result.unavailable_reason);
  EXPECT_EQ(json["available"], false);

  // Shorter, non-standard lengths are scored when asked for, and say so.
  KittiOdometryOptions short_lengths;
  short_lengths.lengths_m = {20, 40};
  const KittiOdometryResult shorter = computeKittiOdometryError(groundtruth, everyFrame(groundtruth), short_lengths);
  EXPECT_TRUE(shorter.available);
  EXPECT_FALSE(shorter.standard_lengths);
  EXPECT_EQ(toJson(shorter)["standard_lengths"], false);
}

TEST(KittiOdometryMetric, MismatchedSizesAreRefused) {
  const std::vector<SE3> road = straightRoad();
  EXPECT_THROW(computeKittiOdometryError(road, std::vector<std::optional<SE3>>(3)), std::invalid_argument);
}

}  // namespace
}  // namespace vslam
