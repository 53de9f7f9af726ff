// Pose-only optimisation in plain Eigen rather than Ceres: six unknowns and a
// few hundred residuals make a 6x6 normal system per iteration, and Ceres's
// per-solve setup cost three to five times the solve (bench_optimize
// BM_PoseOnly, 300 observations: 0.67-1.06 ms with Ceres, 0.20-0.22 ms here;
// docs/OPTIMIZATION.md). Tracking solves it
// at least twice a frame. The iteration is Ceres's trust-region
// Levenberg-Marquardt with its default options, step for step, so Tracking's
// poses stay what Ceres gave them, to rounding (test
// OptimizePose.ReproducesCeresStepForStep, which keeps the Ceres version as
// the reference).
#include "vslam/optimize/pose_optimizer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

namespace vslam {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// Huber's rho of a squared whitened error s, with threshold a^2 = chi2 (Ceres's
// HuberLoss convention), and its derivative d rho / d s: the IRLS weight.
double huberRho(double s, double chi2) { return s <= chi2 ? s : 2.0 * std::sqrt(chi2 * s) - chi2; }
double huberWeight(double s, double chi2) { return s <= chi2 ? 1.0 : std::sqrt(chi2 / s); }

// The 95 % chi-square bound of an observation: the outlier test, and Huber's threshold.
double chi2Bound(const Observation2D& obs, const PoseOptimizationOptions& options) {
  return hasRightCoordinate(obs.u_right) ? options.chi2_stereo : options.chi2_mono;
}

// The pose problem of one round: the active observations, with or without the robust loss.
class PoseProblem {
 public:
  PoseProblem(const ProjectionModel& model, const std::vector<Vec3>& points_w,
              const std::vector<Observation2D>& observations, const PoseOptimizationOptions& options)
      : model_(model), points_w_(points_w), observations_(observations), options_(options) {}

  // 1/2 sum of rho(chi2), as Ceres defines the cost.
  double cost(const SE3& T_cw, const std::vector<bool>& active, bool robust) const {
    double total = 0;
    for (size_t i = 0; i < observations_.size(); ++i) {
      if (!active[i]) continue;
      const Observation2D& obs = observations_[i];
      const Vec3 p_c = T_cw * points_w_[obs.point];
      const double s = hasRightCoordinate(obs.u_right) ? squaredError<3>(obs, p_c) : squaredError<2>(obs, p_c);
      total += robust ? huberRho(s, chi2Bound(obs, options_)) : s;
    }
    return 0.5 * total;
  }

  // Gauss-Newton normal equations H = J^T W J, g = J^T W r at T_cw (IRLS weights
  // under the robust loss: Ceres's corrector drops its second-order term where
  // rho'' <= 0, which for Huber is everywhere, and keeps the sqrt(rho') scaling).
  void normalEquations(const SE3& T_cw, const std::vector<bool>& active, bool robust, Mat6& H, Vec6& g) const {
    H.setZero();
    g.setZero();
    for (size_t i = 0; i < observations_.size(); ++i) {
      if (!active[i]) continue;
      const Observation2D& obs = observations_[i];
      const Vec3 p_c = T_cw * points_w_[obs.point];
      if (hasRightCoordinate(obs.u_right))
        accumulate<3>(i, p_c, robust, H, g);
      else
        accumulate<2>(i, p_c, robust, H, g);
    }
  }

 private:
  // The whitened squared reprojection error of one observation.
  template <int kResiduals>
  double squaredError(const Observation2D& obs, const Vec3& p_c) const {
    Eigen::Matrix<double, kResiduals, 1> r;
    reprojectionResidual<kResiduals>(model_, std::sqrt(obs.inv_sigma2),
                                     measurementVector<kResiduals>(obs.pixel, obs.u_right), p_c, r.data(), nullptr);
    return r.squaredNorm();
  }

  template <int kResiduals>
  void accumulate(size_t i, const Vec3& p_c, bool robust, Mat6& H, Vec6& g) const {
    const Observation2D& obs = observations_[i];
    Eigen::Matrix<double, kResiduals, 1> r;
    Eigen::Matrix<double, kResiduals, 6> J;
    poseOnlyResidual<kResiduals>(model_, std::sqrt(obs.inv_sigma2), measurementVector<kResiduals>(obs.pixel, obs.u_right),
                                 p_c, r, J);
    const double weight = robust ? huberWeight(r.squaredNorm(), chi2Bound(obs, options_)) : 1.0;
    H.noalias() += weight * J.transpose() * J;
    g.noalias() += weight * J.transpose() * r;
  }

  const ProjectionModel& model_;
  const std::vector<Vec3>& points_w_;
  const std::vector<Observation2D>& observations_;
  const PoseOptimizationOptions& options_;
};

// Levenberg-Marquardt on the 6-d pose tangent, step for step as Ceres's
// trust-region minimiser with its defaults runs it (so that Tracking's poses
// do not move): Jacobi scaling fixed at the first evaluation, damping
// clamp(diag(J'J), 1e-6, 1e32) / radius in the scaled space, radius from 1e4,
// a step kept when it achieves 1e-3 of the model's decrease; it stops, without
// taking the step, when the step changes the parameters by 1e-8 of their norm
// (checked only after a first kept step, as Ceres does) or the cost by 1e-6 of
// itself, and when the gradient's projected max norm is 1e-10 or the radius
// falls under 1e-32. Returns whether it converged within `max_iterations`.
bool levenbergMarquardt(const PoseProblem& problem, const std::vector<bool>& active, bool robust,
                        int max_iterations, PoseParameters& pose) {
  constexpr double kFunctionTolerance = 1e-6;
  constexpr double kParameterTolerance = 1e-8;
  constexpr double kGradientTolerance = 1e-10;
  constexpr double kMinRelativeDecrease = 1e-3;
  constexpr double kMinRadius = 1e-32, kMaxRadius = 1e16;
  constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;
  constexpr int kMaxConsecutiveInvalidSteps = 5;
  double radius = 1e4;
  double decrease_factor = 2.0;
  // Steps go through PoseManifold::Plus, which keeps the rotation a unit
  // quaternion: a rotation matrix updated in place would drift off SO(3), and
  // Tracking's motion model (velocity = T_k T_k-1^-1) amplifies such drift frame by frame.
  const PoseManifold manifold;
  using Ambient = Eigen::Matrix<double, kPoseParameterSize, 1>;
  auto ambient = [](const PoseParameters& x) { return Eigen::Map<const Ambient>(x.data()); };
  auto projectedGradientMaxNorm = [&](const PoseParameters& x, const Vec6& g) {
    const Vec6 minus_g = -g;
    PoseParameters moved;
    manifold.Plus(x.data(), minus_g.data(), moved.data());
    return (ambient(x) - ambient(moved)).lpNorm<Eigen::Infinity>();
  };
  SE3 T_cw = poseFromParameters(pose.data());
  double cost = problem.cost(T_cw, active, robust);
  Mat6 H;
  Vec6 g;
  problem.normalEquations(T_cw, active, robust, H, g);
  Vec6 scale;
  for (int k = 0; k < 6; ++k) scale(k) = 1.0 / (1.0 + std::sqrt(H(k, k)));
  double x_norm = -1.0;  // Ceres sets it at the first kept step
  double gradient_max_norm = projectedGradientMaxNorm(pose, g);
  int invalid_steps = 0;
  for (int iteration = 0;; ++iteration) {
    if (iteration >= max_iterations) return false;
    if (gradient_max_norm <= kGradientTolerance) return true;
    if (radius < kMinRadius) return true;
    // The scaled problem: J S, so J'J becomes S H S and the gradient S g.
    const Mat6 H_scaled = scale.asDiagonal() * H * scale.asDiagonal();
    const Vec6 g_scaled = scale.cwiseProduct(g);
    Mat6 damped = H_scaled;
    for (int k = 0; k < 6; ++k) damped(k, k) += std::clamp(H_scaled(k, k), kMinDiagonal, kMaxDiagonal) / radius;
    const Vec6 step_scaled = -damped.llt().solve(g_scaled);
    // The model's decrease -(J s)'(r + J s / 2).
    const double model_decrease = -(g_scaled.dot(step_scaled) + 0.5 * step_scaled.dot(H_scaled * step_scaled));
    if (!(model_decrease > 0.0) || !step_scaled.allFinite()) {
      if (++invalid_steps >= kMaxConsecutiveInvalidSteps) return false;
      radius /= decrease_factor;  // Ceres: an invalid step is a rejected one
      decrease_factor *= 2.0;
      continue;
    }
    invalid_steps = 0;
    const Vec6 step = step_scaled.cwiseProduct(scale);
    PoseParameters candidate_pose;
    manifold.Plus(pose.data(), step.data(), candidate_pose.data());
    const SE3 candidate = poseFromParameters(candidate_pose.data());
    const double new_cost = problem.cost(candidate, active, robust);
    const double step_norm = (ambient(pose) - ambient(candidate_pose)).norm();
    if (step_norm <= kParameterTolerance * (x_norm + kParameterTolerance)) return true;
    if (std::abs(cost - new_cost) <= kFunctionTolerance * cost) return true;
    const double relative_decrease = (cost - new_cost) / model_decrease;
    if (relative_decrease > kMinRelativeDecrease) {
      pose = candidate_pose;
      T_cw = candidate;
      cost = new_cost;
      x_norm = ambient(pose).norm();
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative_decrease - 1.0, 3)));
      decrease_factor = 2.0;
      problem.normalEquations(T_cw, active, robust, H, g);
      gradient_max_norm = projectedGradientMaxNorm(pose, g);
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
  }
}

}  // namespace

PoseOptimizationResult optimizePose(const PinholeCamera& camera, double bf, const SE3& T_cw_initial,
                                    const std::vector<Vec3>& points_w,
                                    const std::vector<Observation2D>& observations,
                                    const PoseOptimizationOptions& options) {
  const ProjectionModel model(camera, bf);
  for (const Observation2D& obs : observations) {
    if (obs.point < 0 || obs.point >= static_cast<int>(points_w.size())) {
      throw std::invalid_argument("optimizePose: observation refers to point " + std::to_string(obs.point) +
                                  " of " + std::to_string(points_w.size()));
    }
    if (hasRightCoordinate(obs.u_right) && bf <= 0) throw std::invalid_argument("optimizePose: stereo observation with bf <= 0");
  }

  PoseParameters pose = poseToParameters(T_cw_initial);
  SE3 T_cw = poseFromParameters(pose.data());
  PoseOptimizationResult result;
  result.inlier.assign(observations.size(), true);  // the first round uses every observation

  auto classify = [&]() {
    result.n_inliers = 0;
    for (size_t i = 0; i < observations.size(); ++i) {
      const Observation2D& obs = observations[i];
      const ReprojectionCheck check =
          checkReprojection(model, T_cw, points_w[obs.point], obs.pixel, obs.u_right, obs.inv_sigma2);
      result.inlier[i] = check.depth_positive && check.chi2 < chi2Bound(obs, options);
      result.n_inliers += result.inlier[i] ? 1 : 0;
    }
  };

  if (observations.size() < 3) {
    classify();
    result.T_cw = T_cw;
    return result;
  }

  const PoseProblem problem(model, points_w, observations, options);
  for (int round = 0; round < options.rounds; ++round) {
    const bool robust = round < options.robust_rounds;
    const std::vector<bool> used_in_this_round = result.inlier;
    const bool converged =
        levenbergMarquardt(problem, used_in_this_round, robust, options.iterations_per_round, pose);
    T_cw = poseFromParameters(pose.data());
    classify();
    if (result.n_inliers < 10) break;  // too few left to refine further (ORB-SLAM stops here too)
    // A converged round without the robust loss that keeps the same inliers
    // leaves nothing for another round to do.
    if (converged && !robust && result.inlier == used_in_this_round) break;
  }
  result.T_cw = T_cw;
  return result;
}

}  // namespace vslam
