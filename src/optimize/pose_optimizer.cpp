#include "vslam/optimize/pose_optimizer.hpp"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/ceres.h>

namespace vslam {
namespace {

// One observation's residual block. Only one of the two cost functions is set.
struct PoseOnlyTerm {
  std::unique_ptr<PoseOnlyReprojectionCost<2>> mono;
  std::unique_ptr<PoseOnlyReprojectionCost<3>> stereo;
  void setActive(bool active) {
    if (mono) {
      mono->setActive(active);
    } else {
      stereo->setActive(active);
    }
  }
};

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
  PoseOptimizationResult result;
  result.inlier.assign(observations.size(), true);  // the first round uses every observation

  auto classify = [&]() {
    const SE3 T_cw = poseFromParameters(pose.data());
    result.n_inliers = 0;
    for (size_t i = 0; i < observations.size(); ++i) {
      const Observation2D& obs = observations[i];
      const ReprojectionCheck check =
          checkReprojection(model, T_cw, points_w[obs.point], obs.pixel, obs.u_right, obs.inv_sigma2);
      const double threshold = hasRightCoordinate(obs.u_right) ? options.chi2_stereo : options.chi2_mono;
      result.inlier[i] = check.depth_positive && check.chi2 < threshold;
      result.n_inliers += result.inlier[i] ? 1 : 0;
    }
  };

  if (observations.size() < 3) {
    classify();
    result.T_cw = poseFromParameters(pose.data());
    return result;
  }

  // One problem for all rounds: outliers are switched off in their cost
  // function, and the Huber loss is removed by resetting the wrappers.
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::LossFunctionWrapper huber_mono(new ceres::HuberLoss(std::sqrt(options.chi2_mono)), ceres::TAKE_OWNERSHIP);
  ceres::LossFunctionWrapper huber_stereo(new ceres::HuberLoss(std::sqrt(options.chi2_stereo)),
                                          ceres::TAKE_OWNERSHIP);
  PoseManifold manifold;

  std::vector<PoseOnlyTerm> terms(observations.size());
  for (size_t i = 0; i < observations.size(); ++i) {
    const Observation2D& obs = observations[i];
    const Vec3& point = points_w[obs.point];
    if (!hasRightCoordinate(obs.u_right)) {
      terms[i].mono = std::make_unique<PoseOnlyReprojectionCost<2>>(model, point, obs.pixel, obs.u_right,
                                                                     obs.inv_sigma2);
      problem.AddResidualBlock(terms[i].mono.get(), &huber_mono, pose.data());
    } else {
      terms[i].stereo = std::make_unique<PoseOnlyReprojectionCost<3>>(model, point, obs.pixel, obs.u_right,
                                                                       obs.inv_sigma2);
      problem.AddResidualBlock(terms[i].stereo.get(), &huber_stereo, pose.data());
    }
  }
  problem.SetManifold(pose.data(), &manifold);

  ceres::Solver::Options solver_options;
  // Six unknowns: the normal equations are a 6x6 dense system.
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.iterations_per_round;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;

  for (int round = 0; round < options.rounds; ++round) {
    if (round == options.robust_rounds) {
      huber_mono.Reset(nullptr, ceres::TAKE_OWNERSHIP);
      huber_stereo.Reset(nullptr, ceres::TAKE_OWNERSHIP);
    }
    const std::vector<bool> used_in_this_round = result.inlier;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    classify();
    if (result.n_inliers < 10) break;  // too few left to refine further (ORB-SLAM stops here too)
    // A converged round without the robust loss that keeps the same inliers
    // leaves nothing for another round to do.
    const bool converged = summary.termination_type == ceres::CONVERGENCE;
    if (converged && round >= options.robust_rounds && result.inlier == used_in_this_round) break;
    for (size_t i = 0; i < terms.size(); ++i) terms[i].setActive(result.inlier[i]);
  }
  result.T_cw = poseFromParameters(pose.data());
  return result;
}

}  // namespace vslam
