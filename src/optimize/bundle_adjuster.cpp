#include "vslam/optimize/bundle_adjuster.hpp"

#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/ceres.h>

namespace vslam {
namespace {

// Above this many free keyframes the reduced camera system is solved sparsely;
// below it a dense Schur complement is faster (see docs/OPTIMIZATION.md).
constexpr int kMaxKeyframesForDenseSchur = 40;

class AbortCallback : public ceres::IterationCallback {
 public:
  explicit AbortCallback(const std::atomic<bool>* flag) : flag_(flag) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& /*summary*/) override {
    if (flag_ && flag_->load(std::memory_order_relaxed)) {
      triggered_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;  // keep the progress made so far
    }
    return ceres::SOLVER_CONTINUE;
  }
  bool triggered() const { return triggered_; }

 private:
  const std::atomic<bool>* flag_;
  bool triggered_ = false;
};

void validate(const BundleProblem& problem, double bf) {
  const int n_keyframes = static_cast<int>(problem.keyframes.size());
  const int n_points = static_cast<int>(problem.points.size());
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    const BaObservation& obs = problem.observations[i];
    if (obs.keyframe < 0 || obs.keyframe >= n_keyframes || obs.point < 0 || obs.point >= n_points) {
      throw std::invalid_argument("bundleAdjust: observation " + std::to_string(i) + " refers to keyframe " +
                                  std::to_string(obs.keyframe) + " / point " + std::to_string(obs.point) +
                                  " out of range");
    }
    if (hasRightCoordinate(obs.u_right) && bf <= 0) {
      throw std::invalid_argument("bundleAdjust: stereo observation " + std::to_string(i) + " with bf <= 0");
    }
  }
}

ceres::LinearSolverType chooseLinearSolver(BundleLinearSolver requested, int free_keyframes, int free_points,
                                           ceres::SparseLinearAlgebraLibraryType* sparse_library) {
  const bool have_suitesparse = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE);
  const bool have_eigen_sparse = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE);
  *sparse_library = have_suitesparse ? ceres::SUITE_SPARSE : ceres::EIGEN_SPARSE;
  const bool have_sparse = have_suitesparse || have_eigen_sparse;
  // Schur solvers need both points (eliminated) and cameras (kept).
  if (free_keyframes == 0 || free_points == 0) return have_sparse ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
  switch (requested) {
    case BundleLinearSolver::DenseSchur: return ceres::DENSE_SCHUR;
    case BundleLinearSolver::SparseSchur: return have_sparse ? ceres::SPARSE_SCHUR : ceres::ITERATIVE_SCHUR;
    case BundleLinearSolver::IterativeSchur: return ceres::ITERATIVE_SCHUR;
    case BundleLinearSolver::Automatic: break;
  }
  if (free_keyframes <= kMaxKeyframesForDenseSchur) return ceres::DENSE_SCHUR;
  return have_sparse ? ceres::SPARSE_SCHUR : ceres::ITERATIVE_SCHUR;
}

// Ceres' losses act on the squared norm s: Huber(a) is quadratic up to
// s = a^2, Cauchy(b) is b^2 log(1 + s / b^2).
ceres::LossFunction* makeRobustLoss(const BundleOptions& options, double scale) {
  if (!options.robust) return nullptr;
  switch (options.robust_loss) {
    case RobustLoss::Cauchy: return new ceres::CauchyLoss(scale);
    case RobustLoss::Huber: break;
  }
  return new ceres::HuberLoss(scale);
}

}  // namespace

BundleResult bundleAdjust(const PinholeCamera& camera, double bf, BundleProblem& problem,
                          const BundleOptions& options) {
  validate(problem, bf);
  const ProjectionModel model(camera, bf);
  const size_t n_obs = problem.observations.size();

  std::vector<PoseParameters> poses;
  poses.reserve(problem.keyframes.size());
  for (const BaKeyframe& kf : problem.keyframes) poses.push_back(poseToParameters(kf.T_cw));
  std::vector<Vec3> points;
  points.reserve(problem.points.size());
  for (const BaPoint& point : problem.points) points.push_back(point.position_w);

  // A rolling shutter: each observation's camera motion since the middle row.
  std::vector<SE3> row_motion;
  if (problem.readout_s > 0) {
    row_motion.reserve(n_obs);
    for (const BaObservation& obs : problem.observations)
      row_motion.push_back(motionOverRowTime(problem.keyframes[obs.keyframe].velocity,
                                             rowTime(obs.pixel.y(), camera.height, problem.readout_s)));
  }
  auto chi2Of = [&](size_t i) {
    const BaObservation& obs = problem.observations[i];
    const SE3 T_cw = poseFromParameters(poses[obs.keyframe].data());
    return checkReprojection(model, row_motion.empty() ? T_cw : row_motion[i] * T_cw, points[obs.point], obs.pixel,
                             obs.u_right, obs.inv_sigma2);
  };
  auto isOutlier = [&](size_t i) {
    const BaObservation& obs = problem.observations[i];
    const ReprojectionCheck check = chi2Of(i);
    const double threshold = hasRightCoordinate(obs.u_right) ? options.chi2_stereo : options.chi2_mono;
    return !check.depth_positive || check.chi2 > threshold;
  };
  std::vector<double> initial_chi2(n_obs);
  for (size_t i = 0; i < n_obs; ++i) initial_chi2[i] = chi2Of(i).chi2;

  ceres::Problem::Options problem_options;
  problem_options.enable_fast_removal = options.remove_outliers;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  ceres::LossFunctionWrapper loss_mono(makeRobustLoss(options, options.huber_mono), ceres::TAKE_OWNERSHIP);
  ceres::LossFunctionWrapper loss_stereo(makeRobustLoss(options, options.huber_stereo), ceres::TAKE_OWNERSHIP);
  PoseManifold pose_manifold;
  PoseFixedTranslationNormManifold fixed_norm_manifold;

  std::vector<ceres::ResidualBlockId> residual_ids(n_obs);
  std::vector<int> residuals_of_keyframe(problem.keyframes.size(), 0);
  std::vector<int> residuals_of_point(problem.points.size(), 0);
  for (size_t i = 0; i < n_obs; ++i) {
    const BaObservation& obs = problem.observations[i];
    double* pose = poses[obs.keyframe].data();
    double* point = points[obs.point].data();
    const SE3* motion = row_motion.empty() ? nullptr : &row_motion[i];
    if (!hasRightCoordinate(obs.u_right)) {
      residual_ids[i] = ceres_problem.AddResidualBlock(
          new ReprojectionCost<2>(model, obs.pixel, obs.u_right, obs.inv_sigma2, motion), &loss_mono, pose, point);
    } else {
      residual_ids[i] = ceres_problem.AddResidualBlock(
          new ReprojectionCost<3>(model, obs.pixel, obs.u_right, obs.inv_sigma2, motion), &loss_stereo, pose, point);
    }
    ++residuals_of_keyframe[obs.keyframe];
    ++residuals_of_point[obs.point];
  }

  const std::vector<int> initial_residuals_of_keyframe = residuals_of_keyframe;
  int free_keyframes = 0;
  for (size_t k = 0; k < problem.keyframes.size(); ++k) {
    if (residuals_of_keyframe[k] == 0) continue;
    const BaKeyframe& kf = problem.keyframes[k];
    if (kf.fixed) {
      ceres_problem.SetParameterBlockConstant(poses[k].data());
    } else {
      ceres_problem.SetManifold(poses[k].data(),
                                kf.fix_translation_norm ? static_cast<ceres::Manifold*>(&fixed_norm_manifold)
                                                        : &pose_manifold);
      ++free_keyframes;
    }
  }
  int free_points = 0;
  for (size_t p = 0; p < problem.points.size(); ++p) {
    if (residuals_of_point[p] == 0) continue;
    if (problem.points[p].fixed) {
      ceres_problem.SetParameterBlockConstant(points[p].data());
    } else {
      ++free_points;
    }
  }

  AbortCallback abort_callback(options.abort_flag);
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type =
      chooseLinearSolver(options.linear_solver, free_keyframes, free_points,
                         &solver_options.sparse_linear_algebra_library_type);
  solver_options.num_threads = options.num_threads;
  // Schur-Jacobi preconditioning is the usual choice for bundle adjustment.
  solver_options.preconditioner_type = ceres::SCHUR_JACOBI;
  solver_options.logging_type = ceres::SILENT;
  solver_options.callbacks.push_back(&abort_callback);

  // Schur solvers: eliminate the points first. Rebuilt before each solve
  // because phase 2 may have removed blocks.
  auto setOrdering = [&]() {
    if (solver_options.linear_solver_type != ceres::DENSE_SCHUR &&
        solver_options.linear_solver_type != ceres::SPARSE_SCHUR &&
        solver_options.linear_solver_type != ceres::ITERATIVE_SCHUR) {
      return;
    }
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t p = 0; p < points.size(); ++p) {
      if (residuals_of_point[p] > 0) ordering->AddElementToGroup(points[p].data(), 0);
    }
    for (size_t k = 0; k < poses.size(); ++k) {
      if (residuals_of_keyframe[k] > 0) ordering->AddElementToGroup(poses[k].data(), 1);
    }
    solver_options.linear_solver_ordering = ordering;
  };

  BundleResult result;
  auto solve = [&](int iterations) {
    if (iterations <= 0 || ceres_problem.NumResidualBlocks() == 0) return;
    setOrdering();
    solver_options.max_num_iterations = iterations;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &ceres_problem, &summary);
    // summary.iterations[0] is the evaluation at the starting point, not a step.
    if (!summary.iterations.empty()) result.iterations += static_cast<int>(summary.iterations.size()) - 1;
  };

  solve(options.iterations_first);
  result.aborted = abort_callback.triggered();

  if (options.remove_outliers && !result.aborted && options.iterations_second > 0) {
    for (size_t i = 0; i < n_obs; ++i) {
      const BaObservation& obs = problem.observations[i];
      if (!isOutlier(i)) continue;
      ceres_problem.RemoveResidualBlock(residual_ids[i]);
      // A block left without residuals would only be a null column for the solver.
      if (--residuals_of_keyframe[obs.keyframe] == 0) ceres_problem.RemoveParameterBlock(poses[obs.keyframe].data());
      if (--residuals_of_point[obs.point] == 0) ceres_problem.RemoveParameterBlock(points[obs.point].data());
    }
    // ORB-SLAM's second pass: the outliers are gone, so plain least squares.
    loss_mono.Reset(nullptr, ceres::TAKE_OWNERSHIP);
    loss_stereo.Reset(nullptr, ceres::TAKE_OWNERSHIP);
    solve(options.iterations_second);
    result.aborted = abort_callback.triggered();
  }

  result.outlier.assign(n_obs, false);
  for (size_t i = 0; i < n_obs; ++i) {
    result.outlier[i] = isOutlier(i);
    if (result.outlier[i]) {
      ++result.n_outliers;
    } else {
      result.initial_cost += 0.5 * initial_chi2[i];
      result.final_cost += 0.5 * chi2Of(i).chi2;
    }
  }

  for (size_t k = 0; k < problem.keyframes.size(); ++k) {
    const bool optimised = !problem.keyframes[k].fixed && initial_residuals_of_keyframe[k] > 0;
    if (optimised) problem.keyframes[k].T_cw = poseFromParameters(poses[k].data());
  }
  for (size_t p = 0; p < problem.points.size(); ++p) {
    if (!problem.points[p].fixed) problem.points[p].position_w = points[p];
  }
  return result;
}

}  // namespace vslam
