#pragma once
// Ceres building blocks shared by pose-only optimisation and bundle adjustment:
// the pose parameter block, its manifolds, and reprojection residuals with
// analytic Jacobians.
//
// Pose parameter block: T_cw as 7 doubles, the Eigen quaternion coefficients
// (x, y, z, w) followed by the translation.
//
// Residuals. An observation is a pixel (u, v) and, for stereo / RGB-D, the
// right-image coordinate u_right = u - bf / depth (kNoRightCoordinate when
// there is none). The residual is the
// predicted minus the measured coordinates, whitened by sqrt(inv_sigma2), so
// its squared norm is the chi-square statistic with 2 (mono) or 3 (stereo)
// degrees of freedom.
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <ceres/manifold.h>
#include <ceres/sized_cost_function.h>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

// 95 % quantiles of the chi-square distribution (as ORB-SLAM uses them).
constexpr double kChi2Mono = 5.991;    // 2 degrees of freedom
constexpr double kChi2Stereo = 7.815;  // 3 degrees of freedom

// Below this depth (camera z, in map units) a point counts as behind the camera:
// its residual keeps growing with the distance behind (no cost cliff; see
// reprojectionResidual), and outlier classification rejects it.
constexpr double kMinPositiveDepth = 1e-6;

// An observation without a right-image coordinate (monocular). Every other
// value is one, negative ones included: a close point near the left border
// has u_R < 0, and must not silently turn monocular.
inline constexpr double kNoRightCoordinate = std::numeric_limits<double>::quiet_NaN();
inline bool hasRightCoordinate(double u_right) { return !std::isnan(u_right); }

// The 95 % chi-square bound of an observation: 2 dof, or 3 with a right coordinate.
inline double chi2Bound95(double u_right) { return hasRightCoordinate(u_right) ? kChi2Stereo : kChi2Mono; }

// RGB-D observations become stereo ones: the right-image coordinate a stereo
// rig with the same bf would have measured for a keypoint at `depth`.
inline double rightCoordinateFromDepth(double u, double depth, double bf) { return u - bf / depth; }

constexpr int kPoseParameterSize = 7;
using PoseParameters = std::array<double, kPoseParameterSize>;
PoseParameters poseToParameters(const SE3& T_cw);
SE3 poseFromParameters(const double* parameters);

// Tangent space of a pose: delta = (omega, upsilon), and
//   Plus(T, delta) = (Exp(omega), upsilon) * T      (a left perturbation),
// so a camera-frame point moves by omega x p_c + upsilon to first order.
//
// The residuals below write the Jacobian with respect to this 6-vector into the
// first 6 columns of their 7-column "ambient" pose Jacobian (the 7th column is
// zero), and PlusJacobian is [I6; 0]. Ceres multiplies the two, so it sees the
// exact tangent Jacobian without a 7x6 product per residual. This is only
// correct with the residuals of this header: do not combine these manifolds
// with autodiff cost functions on the same block.
class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseParameterSize; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// A pose whose translation norm |t_cw| is held constant: the scale gauge of a
// monocular bundle adjustment (with another keyframe fixed). Tangent
// (omega, a, b): R <- Exp(omega) R, and t moves by (a, b) in the plane
// orthogonal to it, then is rescaled to its old norm. The norm must be > 0.
class PoseFixedTranslationNormManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseParameterSize; }
  int TangentSize() const override { return 5; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// What the optimisers need of the camera, without the strings of PinholeCamera.
struct ProjectionModel {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double bf = 0;  // fx * baseline; only used by stereo residuals

  ProjectionModel() = default;
  ProjectionModel(const PinholeCamera& camera, double bf_)
      : fx(camera.fx), fy(camera.fy), cx(camera.cx), cy(camera.cy), bf(bf_) {}
};

// Squared whitened error of one observation and whether the point is in front.
struct ReprojectionCheck {
  double chi2 = 0;
  bool depth_positive = false;
};
// u_right = kNoRightCoordinate means monocular.
ReprojectionCheck checkReprojection(const ProjectionModel& model, const SE3& T_cw, const Vec3& point_w,
                                    const Vec2& pixel, double u_right, double inv_sigma2);

// Whitened residual of a camera-frame point and its Jacobian with respect to
// the point. kResiduals = 2: (u, v); 3: (u, v, u_right).
template <int kResiduals>
void reprojectionResidual(const ProjectionModel& model, double sqrt_information,
                          const Eigen::Matrix<double, kResiduals, 1>& measured, const Vec3& p_c,
                          double* residuals, Eigen::Matrix<double, kResiduals, 3>* d_residual_d_pc) {
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> r(residuals);
  if (p_c.z() < kMinPositiveDepth) {
    // Behind (or at) the camera the projection is meaningless. A zero residual
    // there would be a cost cliff the optimiser could slide a point or pose
    // into. Instead every coordinate is off by two focal lengths (worse than
    // any point in front that projects into the image) plus as much again per
    // unit of "behindness" b = (z_min - z) / |p|, in (0, 2]: the cost keeps
    // rising as the point moves back, and the Jacobian points the way out.
    // It stays bounded, with Jacobians of the size of in-front ones, so one
    // such observation cannot swamp the others before outlier classification
    // rejects it.
    const double norm = std::max(p_c.norm(), kMinPositiveDepth);
    const double behind = (kMinPositiveDepth - p_c.z()) / norm;
    // d(behind)/d(p_c)
    const Vec3 d_behind = -Vec3::UnitZ() / norm - (kMinPositiveDepth - p_c.z()) * p_c / (norm * norm * norm);
    const double focal[3] = {model.fx, model.fy, model.fx};
    for (int i = 0; i < kResiduals; ++i) {
      r(i) = sqrt_information * focal[i] * (2.0 + behind);
      if (d_residual_d_pc) d_residual_d_pc->row(i) = sqrt_information * focal[i] * d_behind.transpose();
    }
    return;
  }
  const double inv_z = 1.0 / p_c.z();
  const double x_z = p_c.x() * inv_z;
  const double y_z = p_c.y() * inv_z;
  const double u = model.fx * x_z + model.cx;
  r(0) = sqrt_information * (u - measured(0));
  r(1) = sqrt_information * (model.fy * y_z + model.cy - measured(1));
  if constexpr (kResiduals == 3) r(2) = sqrt_information * (u - model.bf * inv_z - measured(2));
  if (d_residual_d_pc) {
    auto& J = *d_residual_d_pc;
    const double s_z = sqrt_information * inv_z;
    J(0, 0) = s_z * model.fx;
    J(0, 1) = 0;
    J(0, 2) = -s_z * model.fx * x_z;
    J(1, 0) = 0;
    J(1, 1) = s_z * model.fy;
    J(1, 2) = -s_z * model.fy * y_z;
    if constexpr (kResiduals == 3) {
      J(2, 0) = J(0, 0);
      J(2, 1) = 0;
      J(2, 2) = J(0, 2) + s_z * model.bf * inv_z;
    }
  }
}

// Builds the (u, v[, u_right]) measurement vector.
template <int kResiduals>
Eigen::Matrix<double, kResiduals, 1> measurementVector(const Vec2& pixel, double u_right) {
  Eigen::Matrix<double, kResiduals, 1> m;
  m(0) = pixel.x();
  m(1) = pixel.y();
  if constexpr (kResiduals == 3) m(2) = u_right;
  return m;
}

// d r / d pose-tangent = d r / d p_c * [-[p_c]x  I] (see PoseManifold).
template <int kResiduals>
Eigen::Matrix<double, kResiduals, 6> poseTangentJacobian(const Eigen::Matrix<double, kResiduals, 3>& d_residual_d_pc,
                                                         const Vec3& p_c) {
  Eigen::Matrix<double, kResiduals, 6> J;
  // d r / d omega = d r / d p_c * (-[p_c]x) = d r / d p_c * [p_c]x^T, i.e. the cross products below.
  for (int row = 0; row < kResiduals; ++row) {
    const Vec3 g = d_residual_d_pc.row(row).transpose();
    J.template block<1, 3>(row, 0) = p_c.cross(g).transpose();
    J.template block<1, 3>(row, 3) = g.transpose();
  }
  return J;
}

// The same into a row-major kResiduals x 7 ambient Jacobian, whose 7th column
// is zero (see PoseManifold).
template <int kResiduals>
void writePoseJacobian(const Eigen::Matrix<double, kResiduals, 3>& d_residual_d_pc, const Vec3& p_c,
                       double* jacobian) {
  Eigen::Map<Eigen::Matrix<double, kResiduals, kPoseParameterSize, Eigen::RowMajor>> J(jacobian);
  J.template leftCols<6>() = poseTangentJacobian<kResiduals>(d_residual_d_pc, p_c);
  J.col(6).setZero();
}

// Residual of a known point at camera-frame position p_c and its Jacobian with
// respect to the 6-d pose tangent: the term of pose-only optimisation, which is
// solved without Ceres (pose_optimizer.cpp).
template <int kResiduals>
void poseOnlyResidual(const ProjectionModel& model, double sqrt_information,
                      const Eigen::Matrix<double, kResiduals, 1>& measured, const Vec3& p_c,
                      Eigen::Matrix<double, kResiduals, 1>& residual, Eigen::Matrix<double, kResiduals, 6>& jacobian) {
  Eigen::Matrix<double, kResiduals, 3> d_r_d_pc;
  reprojectionResidual<kResiduals>(model, sqrt_information, measured, p_c, residual.data(), &d_r_d_pc);
  jacobian = poseTangentJacobian<kResiduals>(d_r_d_pc, p_c);
}

// Observation of a free point by a free pose: parameter blocks (pose 7, point 3).
// With `row_motion` (a rolling shutter, rolling_shutter.hpp) the pose is the
// middle row's and the pixel was seen after the camera moved by *row_motion:
// the point is projected from *row_motion * T_cw, held fixed. The motion is
// the caller's and must outlive the cost (bundleAdjust keeps one per
// observation for the solve); a pointer keeps Local Mapping's costs small.
template <int kResiduals>
class ReprojectionCost : public ceres::SizedCostFunction<kResiduals, kPoseParameterSize, 3> {
 public:
  ReprojectionCost(const ProjectionModel& model, const Vec2& pixel, double u_right, double inv_sigma2,
                   const SE3* row_motion = nullptr)
      : model_(model), measured_(measurementVector<kResiduals>(pixel, u_right)),
        sqrt_information_(std::sqrt(inv_sigma2)), row_motion_(row_motion) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Quat> q(parameters[0]);
    const Eigen::Map<const Vec3> t(parameters[0] + 4);
    const Eigen::Map<const Vec3> p_w(parameters[1]);
    const Mat3 R = q.toRotationMatrix();
    const Vec3 p_c = R * p_w + t;
    const Vec3 p_seen = row_motion_ ? Vec3(*row_motion_ * p_c) : p_c;
    if (!jacobians) {
      reprojectionResidual<kResiduals>(model_, sqrt_information_, measured_, p_seen, residuals, nullptr);
      return true;
    }
    Eigen::Matrix<double, kResiduals, 3> d_r_d_pc;
    reprojectionResidual<kResiduals>(model_, sqrt_information_, measured_, p_seen, residuals, &d_r_d_pc);
    if (row_motion_) d_r_d_pc = (d_r_d_pc * row_motion_->R).eval();
    if (jacobians[0]) writePoseJacobian<kResiduals>(d_r_d_pc, p_c, jacobians[0]);
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, kResiduals, 3, Eigen::RowMajor>> d_r_d_point(jacobians[1]);
      d_r_d_point = d_r_d_pc * R;
    }
    return true;
  }

 private:
  ProjectionModel model_;
  Eigen::Matrix<double, kResiduals, 1> measured_;
  double sqrt_information_;
  const SE3* row_motion_;
};

}  // namespace vslam
