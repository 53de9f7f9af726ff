#pragma once
// Geometric value types shared by every module.
//
// Conventions (used everywhere, so nobody has to guess):
//  - `SE3` is a rigid transform stored as rotation + translation. A pose named
//    `T_a_b` maps points expressed in frame b into frame a: p_a = T_a_b * p_b.
//    Camera poses in the map are stored as T_cw (world -> camera); trajectories
//    on disk are T_wc (camera -> world), as the TUM and KITTI formats define.
//  - `Sim3` adds a scale: p_a = s * R * p_b + t.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vslam {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Quat = Eigen::Quaterniond;

struct SE3 {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  SE3() = default;
  SE3(const Mat3& rotation, const Vec3& translation) : R(rotation), t(translation) {}
  SE3(const Quat& q, const Vec3& translation) : R(q.normalized().toRotationMatrix()), t(translation) {}

  static SE3 identity() { return SE3(); }
  static SE3 fromMatrix(const Mat4& m) { return SE3(m.topLeftCorner<3, 3>(), m.topRightCorner<3, 1>()); }

  Vec3 operator*(const Vec3& p) const { return R * p + t; }
  SE3 operator*(const SE3& o) const { return SE3(R * o.R, R * o.t + t); }
  SE3 inverse() const { return SE3(R.transpose(), -R.transpose() * t); }
  Quat quaternion() const { return Quat(R); }
  Mat4 matrix() const {
    Mat4 m = Mat4::Identity();
    m.topLeftCorner<3, 3>() = R;
    m.topRightCorner<3, 1>() = t;
    return m;
  }
};

struct Sim3 {
  double s = 1.0;
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();

  Sim3() = default;
  Sim3(double scale, const Mat3& rotation, const Vec3& translation) : s(scale), R(rotation), t(translation) {}
  explicit Sim3(const SE3& rigid) : s(1.0), R(rigid.R), t(rigid.t) {}

  Vec3 operator*(const Vec3& p) const { return s * (R * p) + t; }
  Sim3 operator*(const Sim3& o) const { return Sim3(s * o.s, R * o.R, s * (R * o.t) + t); }
  Sim3 inverse() const {
    const Mat3 Rt = R.transpose();
    return Sim3(1.0 / s, Rt, -(Rt * t) / s);
  }
};

// A timestamped camera-to-world pose, one line of a trajectory file.
struct StampedPose {
  double timestamp = 0.0;
  SE3 T_wc;
};

}  // namespace vslam
