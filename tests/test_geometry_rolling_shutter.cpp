// Rolling shutter (vslam/geometry/rolling_shutter.hpp): exact values on
// constructed motions, and a frame rendered row by row whose middle-row pose
// the corrected pose solve recovers and the uncorrected one does not.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "geometry_synthetic.hpp"
#include "optimize_synthetic.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/optimize/pose_optimizer.hpp"

namespace vslam {
namespace {

SE3 exampleMotion() { return SE3(test::rotationDeg(2.0, Vec3(0.2, 1, -0.3)), Vec3(0.01, -0.004, 0.006)); }

TEST(GeometryRollingShutter, RowTimeRunsFromMinusHalfToPlusHalfTheReadout) {
  EXPECT_DOUBLE_EQ(rowTime(0, 480, 0.03), -0.015);
  EXPECT_DOUBLE_EQ(rowTime(240, 480, 0.03), 0.0);
  EXPECT_DOUBLE_EQ(rowTime(480, 480, 0.03), 0.015);
  EXPECT_DOUBLE_EQ(rowTime(120, 480, 0.0), 0.0);  // global shutter
}

TEST(GeometryRollingShutter, VelocityBetweenTwoPosesIsTheirMotionPerSecond) {
  const SE3 before(test::rotationDeg(30, Vec3(1, 0.5, 0)), Vec3(0.3, -1, 2));
  const SE3 D = exampleMotion();
  const CameraVelocity velocity = velocityBetween(before, D * before, 0.05);
  const Eigen::AngleAxisd rotation(D.R);
  EXPECT_NEAR((velocity.angular - rotation.angle() / 0.05 * rotation.axis()).norm(), 0, 1e-12);
  EXPECT_NEAR((velocity.linear - D.t / 0.05).norm(), 0, 1e-12);
  // Over its own interval the motion is D again.
  const SE3 motion = motionOverRowTime(velocity, 0.05);
  EXPECT_NEAR((motion.R - D.R).norm() + (motion.t - D.t).norm(), 0, 1e-12);
  // Standing still: no velocity.
  const CameraVelocity still = velocityBetween(before, before, 0.05);
  EXPECT_NEAR(still.angular.norm() + still.linear.norm(), 0, 1e-12);
}

TEST(GeometryRollingShutter, APointSeenAtTheVelocitysOwnIntervalIsWhereTheLaterPoseSeesIt) {
  const SE3 T_cw(test::rotationDeg(-20, Vec3(0, 1, 0.2)), Vec3(-0.5, 0.1, 1.5));
  const SE3 later = exampleMotion() * T_cw;
  const CameraVelocity velocity = velocityBetween(T_cw, later, 0.04);
  const Vec3 point_w(0.7, -0.3, 3.1);
  // Over exactly the interval it was measured on, the motion is reproduced exactly.
  EXPECT_NEAR((T_cw * pointSeenAtRowTime(T_cw, point_w, velocity, 0.04) - later * point_w).norm(), 0, 1e-12);
  // At row time 0 (the middle row) nothing moves.
  EXPECT_NEAR((pointSeenAtRowTime(T_cw, point_w, velocity, 0.0) - point_w).norm(), 0, 1e-15);
}

// A frame exposed row by row while the camera moves at a constant velocity:
// each point is seen at the row it lands on (found by iterating row -> pose ->
// row). Posed with each point corrected for its row's time, the frame comes
// out at its middle row's pose; posed as if every row were seen at once, it
// does not.
TEST(GeometryRollingShutter, PosingARowByRowFrameRecoversItsMiddleRowPose) {
  const PinholeCamera camera = test::syntheticCamera();
  const double readout_s = 0.03;
  const SE3 T_mid(test::rotationDeg(10, Vec3(0.1, 1, 0)), Vec3(0.2, -0.1, 0.5));
  // 0.5 m/s sideways and 30 deg/s about the vertical axis: a handheld sweep.
  CameraVelocity velocity;
  velocity.linear = Vec3(0.5, 0.1, 0.0);
  velocity.angular = Vec3(0, 30 * M_PI / 180, 0);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u_x(20, 620), u_y(20, 460), depth(1.5, 4.0);
  std::vector<Vec3> points_w;
  std::vector<Observation2D> observations;
  for (int i = 0; i < 300; ++i) {
    // A point on the middle-row pose's ray through a random pixel.
    const Vec3 point_w = T_mid.inverse() * (camera.unproject(Vec2(u_x(rng), u_y(rng))) * depth(rng));
    Vec2 pixel = camera.project(T_mid * point_w);
    for (int k = 0; k < 10; ++k)
      pixel = camera.project(T_mid * pointSeenAtRowTime(T_mid, point_w, velocity, rowTime(pixel.y(), 480, readout_s)));
    observations.push_back({static_cast<int>(points_w.size()), pixel, 1.0, kNoRightCoordinate});
    points_w.push_back(point_w);
  }
  // Start both solves a little off.
  const SE3 start = SE3(test::rotationDeg(0.5, Vec3(1, 0, 0)), Vec3(0.01, 0, 0)) * T_mid;

  std::vector<Vec3> corrected = points_w;
  for (const Observation2D& observation : observations)
    corrected[observation.point] = pointSeenAtRowTime(start, points_w[observation.point], velocity,
                                                      rowTime(observation.pixel.y(), 480, readout_s));
  // The correction is computed at the starting pose, so it is exact only
  // there; one more pass from the first answer removes the rest.
  PoseOptimizationResult result = optimizePose(camera, 0, start, corrected, observations);
  for (const Observation2D& observation : observations)
    corrected[observation.point] = pointSeenAtRowTime(result.T_cw, points_w[observation.point], velocity,
                                                      rowTime(observation.pixel.y(), 480, readout_s));
  result = optimizePose(camera, 0, result.T_cw, corrected, observations);
  EXPECT_EQ(result.n_inliers, 300);
  EXPECT_LT((result.T_cw.inverse().t - T_mid.inverse().t).norm(), 1e-4);  // metres
  EXPECT_LT(test::rotationAngle(result.T_cw.R, T_mid.R), 1e-5);           // radians

  const PoseOptimizationResult global_shutter = optimizePose(camera, 0, start, points_w, observations);
  EXPECT_GT((global_shutter.T_cw.inverse().t - T_mid.inverse().t).norm(), 1e-3);
}

}  // namespace
}  // namespace vslam
