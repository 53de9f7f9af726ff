#include "vslam/optimize/reprojection.hpp"

#include <limits>

#include <Eigen/Geometry>

namespace vslam {
namespace {

Quat quaternionExp(const Vec3& omega) {
  const double angle = omega.norm();
  if (angle < 1e-12) return Quat(1.0, 0.5 * omega.x(), 0.5 * omega.y(), 0.5 * omega.z()).normalized();
  return Quat(Eigen::AngleAxisd(angle, omega / angle));
}

Vec3 quaternionLog(const Quat& q) {
  const Eigen::AngleAxisd angle_axis(q);
  return angle_axis.angle() * angle_axis.axis();
}

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Two orthonormal vectors spanning the plane orthogonal to t (t != 0). A pure
// function of t, so Plus and PlusJacobian agree.
Eigen::Matrix<double, 3, 2> orthogonalBasis(const Vec3& t) {
  const Vec3 n = t.normalized();
  int least_aligned_axis = 0;
  n.cwiseAbs().minCoeff(&least_aligned_axis);
  const Vec3 b1 = n.cross(Vec3::Unit(least_aligned_axis)).normalized();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = b1;
  basis.col(1) = n.cross(b1);
  return basis;
}

struct PoseView {
  Eigen::Map<const Quat> q;
  Eigen::Map<const Vec3> t;
  explicit PoseView(const double* x) : q(x), t(x + 4) {}
};

void writePose(const Quat& q, const Vec3& t, double* x) {
  const Quat unit = q.normalized();
  x[0] = unit.x();
  x[1] = unit.y();
  x[2] = unit.z();
  x[3] = unit.w();
  x[4] = t.x();
  x[5] = t.y();
  x[6] = t.z();
}

}  // namespace

PoseParameters poseToParameters(const SE3& T_cw) {
  PoseParameters p;
  writePose(Quat(T_cw.R), T_cw.t, p.data());
  return p;
}

SE3 poseFromParameters(const double* parameters) {
  const PoseView pose(parameters);
  return SE3(pose.q.normalized().toRotationMatrix(), Vec3(pose.t));
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const PoseView pose(x);
  const Quat dq = quaternionExp(Vec3(delta[0], delta[1], delta[2]));
  writePose(dq * pose.q, dq * pose.t + Vec3(delta[3], delta[4], delta[5]), x_plus_delta);
  return true;
}

bool PoseManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  // See the header: the residuals already differentiate with respect to the tangent.
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const PoseView pose_y(y), pose_x(x);
  const Quat dq = pose_y.q * pose_x.q.conjugate();
  const Vec3 omega = quaternionLog(dq);
  const Vec3 upsilon = pose_y.t - dq * pose_x.t;
  for (int i = 0; i < 3; ++i) {
    y_minus_x[i] = omega[i];
    y_minus_x[i + 3] = upsilon[i];
  }
  return true;
}

bool PoseManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

bool PoseFixedTranslationNormManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const PoseView pose(x);
  const Quat dq = quaternionExp(Vec3(delta[0], delta[1], delta[2]));
  Vec3 t = pose.t;
  const double norm = t.norm();
  if (norm > 0) t = norm * (t + orthogonalBasis(t) * Eigen::Vector2d(delta[3], delta[4])).normalized();
  writePose(dq * pose.q, t, x_plus_delta);
  return true;
}

bool PoseFixedTranslationNormManifold::PlusJacobian(const double* x, double* jacobian) const {
  // In the 6-d pose tangent of PoseManifold this retraction moves p_c by
  // omega x (p_c - t) + B (a, b), i.e. omega' = omega, upsilon = [t]x omega + B (a, b).
  const PoseView pose(x);
  Eigen::Map<Eigen::Matrix<double, 7, 5, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<3, 3>(0, 0).setIdentity();
  J.block<3, 3>(3, 0) = skew(pose.t);
  if (pose.t.norm() > 0) J.block<3, 2>(3, 3) = orthogonalBasis(pose.t);
  return true;
}

bool PoseFixedTranslationNormManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const PoseView pose_y(y), pose_x(x);
  const Vec3 omega = quaternionLog(pose_y.q * pose_x.q.conjugate());
  Eigen::Vector2d ab = Eigen::Vector2d::Zero();
  const double along = pose_x.t.dot(pose_y.t);
  if (pose_x.t.norm() > 0) {
    if (along <= 0) return false;  // more than 90 degrees apart: not reachable by Plus
    ab = orthogonalBasis(pose_x.t).transpose() * (pose_y.t * pose_x.t.squaredNorm() / along);
  }
  for (int i = 0; i < 3; ++i) y_minus_x[i] = omega[i];
  y_minus_x[3] = ab[0];
  y_minus_x[4] = ab[1];
  return true;
}

bool PoseFixedTranslationNormManifold::MinusJacobian(const double* x, double* jacobian) const {
  const PoseView pose(x);
  Eigen::Map<Eigen::Matrix<double, 5, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<3, 3>(0, 0).setIdentity();
  if (pose.t.norm() > 0) {
    const Eigen::Matrix<double, 3, 2> basis = orthogonalBasis(pose.t);
    J.block<2, 3>(3, 0) = -basis.transpose() * skew(pose.t);
    J.block<2, 3>(3, 3) = basis.transpose();
  }
  return true;
}

ReprojectionCheck checkReprojection(const ProjectionModel& model, const SE3& T_cw, const Vec3& point_w,
                                    const Vec2& pixel, double u_right, double inv_sigma2) {
  const Vec3 p_c = T_cw * point_w;
  ReprojectionCheck check;
  check.depth_positive = p_c.z() >= kMinPositiveDepth;
  if (!check.depth_positive) {
    check.chi2 = std::numeric_limits<double>::infinity();
    return check;
  }
  const double sqrt_information = std::sqrt(inv_sigma2);
  if (!hasRightCoordinate(u_right)) {
    Eigen::Vector2d r;
    reprojectionResidual<2>(model, sqrt_information, measurementVector<2>(pixel, u_right), p_c, r.data(), nullptr);
    check.chi2 = r.squaredNorm();
  } else {
    Eigen::Vector3d r;
    reprojectionResidual<3>(model, sqrt_information, measurementVector<3>(pixel, u_right), p_c, r.data(), nullptr);
    check.chi2 = r.squaredNorm();
  }
  return check;
}

}  // namespace vslam
