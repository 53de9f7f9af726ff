// RPE on synthetic trajectories with a known drift.
#include <cmath>

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
  RpeOptions bad;
  bad.delta = 0;
  EXPECT_THROW(computeRpe(poses, poses, bad), InputError);
}

}  // namespace
}  // namespace vslam
