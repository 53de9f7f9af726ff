// RPE on synthetic trajectories with a known drift.
#include <cmath>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "vslam/core/error.hpp"
#include "vslam/eval/rpe.hpp"

namespace vslam {
namespace {

StampedPose at(double t, const Vec3& position, const Mat3& R = Mat3::Identity()) {
  StampedPose pose;
  pose.timestamp = t;
  pose.T_wc = SE3(R, position);
  return pose;
}

TEST(Rpe, TranslationDriftPerSecond) {
  // 10 Hz for 10 s; ground truth moves 1 m/s along x, the estimate 1.1 m/s:
  // over every 1 s interval the estimate is 0.1 m off.
  std::vector<StampedPose> groundtruth, estimate;
  for (int i = 0; i <= 100; ++i) {
    const double t = 0.1 * i;
    groundtruth.push_back(at(t, Vec3(t, 0, 0)));
    estimate.push_back(at(t + 0.003, Vec3(1.1 * t, 0, 0)));
  }
  const RpeResult rpe = computeRpe(estimate, groundtruth, RpeOptions());
  EXPECT_EQ(rpe.pairs, 91);  // starts at 0.0 ... 9.0 s
  EXPECT_NEAR(rpe.trans_rmse, 0.1, 1e-9);
  EXPECT_NEAR(rpe.trans_mean, 0.1, 1e-9);
  EXPECT_NEAR(rpe.rot_rmse_deg, 0.0, 1e-9);
  EXPECT_EQ(rpe.trans_units, "m/s");
  EXPECT_EQ(rpe.rot_units, "deg/s");

  // Over 2 s the error is 0.2 m, i.e. still 0.1 m/s.
  RpeOptions two_seconds;
  two_seconds.delta = 2.0;
  const RpeResult rpe2 = computeRpe(estimate, groundtruth, two_seconds);
  EXPECT_EQ(rpe2.pairs, 81);
  EXPECT_NEAR(rpe2.trans_mean, 0.1, 1e-9);

  // The Sim(3) scale of a monocular run is applied: 1/1.1 removes the drift.
  RpeOptions scaled;
  scaled.scale = 1.0 / 1.1;
  EXPECT_NEAR(computeRpe(estimate, groundtruth, scaled).trans_rmse, 0.0, 1e-9);
}

TEST(Rpe, RotationDriftPerSecond) {
  // A camera turning in place: the estimate turns 2 deg/s faster about z.
  std::vector<StampedPose> groundtruth, estimate;
  for (int i = 0; i <= 50; ++i) {
    const double t = 0.1 * i;
    groundtruth.push_back(at(t, Vec3(1, 2, 3), Eigen::AngleAxisd(0.1 * t, Vec3::UnitZ()).toRotationMatrix()));
    estimate.push_back(
        at(t, Vec3(1, 2, 3), Eigen::AngleAxisd(0.1 * t + 2.0 * t * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix()));
  }
  const RpeResult rpe = computeRpe(estimate, groundtruth, RpeOptions());
  EXPECT_EQ(rpe.pairs, 41);
  EXPECT_NEAR(rpe.rot_rmse_deg, 2.0, 1e-9);
  EXPECT_NEAR(rpe.rot_mean_deg, 2.0, 1e-9);
  EXPECT_NEAR(rpe.trans_rmse, 0.0, 1e-12);
}

TEST(Rpe, KittiPercentPerHundredMetres) {
  // 1 m per frame along z for 300 m; the estimate is 2 % too long: 2 m per 100 m.
  std::vector<StampedPose> groundtruth, estimate;
  for (int i = 0; i <= 300; ++i) {
    groundtruth.push_back(at(i, Vec3(0, 0, i)));
    estimate.push_back(at(i, Vec3(0, 0, 1.02 * i)));
  }
  RpeOptions options;
  options.association = Association::Index;
  options.delta = 100.0;
  const RpeResult rpe = computeRpe(estimate, groundtruth, options);
  EXPECT_EQ(rpe.pairs, 201);  // first frames 0 ... 200
  EXPECT_NEAR(rpe.trans_rmse, 2.0, 1e-9);
  EXPECT_NEAR(rpe.trans_mean, 2.0, 1e-9);
  EXPECT_NEAR(rpe.rot_mean_deg, 0.0, 1e-12);
  EXPECT_EQ(rpe.units, "%, deg/100m");
}

TEST(Rpe, NoPairsWhenTheTrajectoryIsShorterThanTheInterval) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) poses.push_back(at(0.1 * i, Vec3(i, 0, 0)));
  const RpeResult rpe = computeRpe(poses, poses, RpeOptions());
  EXPECT_EQ(rpe.pairs, 0);
  // No pairs, no figures: null, never a perfect 0.
  const nlohmann::json json = toJson(rpe);
  EXPECT_TRUE(json["trans_rmse"].is_null()) << json;
  EXPECT_TRUE(json["rot_rmse_deg"].is_null()) << json;
  EXPECT_EQ(json["pairs"], 0);
  RpeOptions bad;
  bad.delta = 0;
  EXPECT_THROW(computeRpe(poses, poses, bad), InputError);
}

// Real KITTI times.txt steps by 0.1036224 s: t_i + 1 s falls 0.036 s from the
// nearest frame (10 steps on), beyond the 0.02 s that pairs estimate and ground
// truth. Before the interval tolerance followed the frame step, this found 0
// pairs (and the run's report said trans_rmse 0).
TEST(Rpe, KittiTimestampsPairTheNearestFrameToOneSecond) {
  std::vector<StampedPose> groundtruth, estimate;
  for (int k = 0; k < 50; ++k) {
    const double t = k * 0.1036224;
    groundtruth.push_back(at(t, Vec3(0, 0, 10 * t)));  // 10 m/s forward
    estimate.push_back(at(t, Vec3(0, 0, 11 * t)));     // 10 % too fast
  }
  const RpeResult rpe = computeRpe(estimate, groundtruth, RpeOptions());
  EXPECT_NEAR(rpe.interval_tolerance, 0.6 * 0.1036224, 1e-12);
  ASSERT_EQ(rpe.pairs, 40);  // i = 0 ... 39, each with j = i + 10 (1.036 s on); from i = 40 the nearest is 0.067 s off
  for (int k = 0; k < 40; ++k) EXPECT_EQ(rpe.pairs_idx[k], std::make_pair(k, k + 10));
  // Over 1.036224 s the estimate runs 1.036224 m too far: per 1 s interval, 1.036224 m/s.
  EXPECT_NEAR(rpe.trans_rmse, 1.036224, 1e-9);
  EXPECT_NEAR(rpe.trans_mean, 1.036224, 1e-9);
}

// TUM's frames come at irregular times, with dropped frames: each interval
// takes the frame nearest to t_i + delta, and none further than the tolerance.
TEST(Rpe, TumIrregularTimestampsPairTheNearestFrame) {
  const std::vector<double> times = {0.000, 0.033, 0.068, 0.099, 0.134, 0.166, 0.201,
                                     0.232, 0.300, 0.334, 0.366, 0.399, 0.433};  // 0.266 dropped
  std::vector<StampedPose> groundtruth, estimate;
  for (double t : times) {
    groundtruth.push_back(at(t, Vec3(t, 0, 0)));
    estimate.push_back(at(t, Vec3(1.5 * t, 0, 0)));
  }
  RpeOptions options;
  options.delta = 0.2;
  const RpeResult rpe = computeRpe(estimate, groundtruth, options);
  // Median step 0.034 s: the tolerance stays 0.02 s (0.6 x 0.034 = 0.0204).
  EXPECT_NEAR(rpe.interval_tolerance, 0.0204, 1e-12);
  // From 0.068 s the target 0.268 s lies 0.032 s from 0.300 s, and from 0.300 s nothing is near 0.5 s.
  const std::vector<std::pair<int, int>> expected = {{0, 6}, {1, 7}, {3, 8}, {4, 9}, {5, 10}, {6, 11}, {7, 12}};
  EXPECT_EQ(rpe.pairs_idx, expected);
  EXPECT_EQ(rpe.pairs, 7);
  // The error of each interval is 0.5 (t_j - t_i) m, divided by 0.2 s; the intervals sum to 1.4 s.
  EXPECT_NEAR(rpe.trans_mean, 2.5 * 1.4 / 7, 1e-12);
  const double squares = 3 * 0.201 * 0.201 + 0.199 * 0.199 + 2 * 0.2 * 0.2 + 0.198 * 0.198;
  EXPECT_NEAR(rpe.trans_rmse, 2.5 * std::sqrt(squares / 7), 1e-12);
}

}  // namespace
}  // namespace vslam
