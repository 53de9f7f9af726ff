#include "vslam/geometry/rolling_shutter.hpp"

#include <Eigen/Geometry>

namespace vslam {

CameraVelocity velocityBetween(const SE3& T_cw_before, const SE3& T_cw_after, double dt) {
  // The motion in the camera's coordinates: p_after = D p_before.
  const SE3 D = T_cw_after * T_cw_before.inverse();
  const Eigen::AngleAxisd rotation(D.R);
  CameraVelocity velocity;
  velocity.angular = rotation.angle() / dt * rotation.axis();
  velocity.linear = D.t / dt;
  return velocity;
}

SE3 motionOverRowTime(const CameraVelocity& velocity, double row_time) {
  const Vec3 rotation = row_time * velocity.angular;
  const double angle = rotation.norm();
  const Mat3 R = angle > 0 ? Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix() : Mat3::Identity();
  return SE3(R, row_time * velocity.linear);
}

Vec3 pointSeenAtRowTime(const SE3& T_cw, const Vec3& point_w, const CameraVelocity& velocity, double row_time) {
  return T_cw.inverse() * (motionOverRowTime(velocity, row_time) * (T_cw * point_w));
}

}  // namespace vslam
