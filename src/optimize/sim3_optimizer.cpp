// optimizeSim3: Sim(3) refinement between the two keyframes of a loop candidate.
#include <cmath>
#include <memory>
#include <stdexcept>

#include <ceres/ceres.h>

#include "sim3_parameters.hpp"
#include "vslam/optimize/pose_graph.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {
namespace {

// Whitened pixel error of a camera-frame point. Behind the camera it is
// bounded and grows with the distance behind, as in reprojectionResidual (no
// cost cliff); the outlier test rejects such matches.
template <typename T>
void pixelResidual(const ProjectionModel& model, const Vec2& pixel, double sqrt_information,
                   const Eigen::Matrix<T, 3, 1>& p_c, T* residual) {
  if (p_c.z() < T(kMinPositiveDepth)) {
    T norm = p_c.norm();
    if (norm < T(kMinPositiveDepth)) norm = T(kMinPositiveDepth);
    const T behind = (T(kMinPositiveDepth) - p_c.z()) / norm;
    residual[0] = sqrt_information * model.fx * (T(2) + behind);
    residual[1] = sqrt_information * model.fy * (T(2) + behind);
    return;
  }
  residual[0] = sqrt_information * (model.fx * p_c.x() / p_c.z() + model.cx - pixel.x());
  residual[1] = sqrt_information * (model.fy * p_c.y() / p_c.z() + model.cy - pixel.y());
}

// Point of keyframe 2 mapped by S12 into camera 1, against its keypoint in image 1.
class PointOfTwoInImageOne {
 public:
  PointOfTwoInImageOne(const ProjectionModel& model, const Sim3Match& match)
      : model_(model), point_(match.point2_c2), pixel_(match.pixel1),
        sqrt_information_(std::sqrt(match.inv_sigma2_1)) {}

  template <typename T>
  bool operator()(const T* q, const T* t, const T* log_scale, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> p1 = ceres::exp(log_scale[0]) * (rotation * point_.cast<T>()) + translation;
    pixelResidual(model_, pixel_, sqrt_information_, p1, residual);
    return true;
  }

 private:
  ProjectionModel model_;
  Vec3 point_;
  Vec2 pixel_;
  double sqrt_information_;
};

// Point of keyframe 1 mapped by S12^-1 into camera 2, against its keypoint in image 2.
class PointOfOneInImageTwo {
 public:
  PointOfOneInImageTwo(const ProjectionModel& model, const Sim3Match& match)
      : model_(model), point_(match.point1_c1), pixel_(match.pixel2),
        sqrt_information_(std::sqrt(match.inv_sigma2_2)) {}

  template <typename T>
  bool operator()(const T* q, const T* t, const T* log_scale, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(q);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> translation(t);
    const Eigen::Matrix<T, 3, 1> p2 =
        ceres::exp(-log_scale[0]) * (rotation.conjugate() * (point_.cast<T>() - translation));
    pixelResidual(model_, pixel_, sqrt_information_, p2, residual);
    return true;
  }

 private:
  ProjectionModel model_;
  Vec3 point_;
  Vec2 pixel_;
  double sqrt_information_;
};

bool isInlier(const ProjectionModel& model, const Sim3& S12, const Sim3& S21, const Sim3Match& match,
              double chi2_threshold) {
  const Vec3 p1 = S12 * match.point2_c2;
  const Vec3 p2 = S21 * match.point1_c1;
  if (p1.z() < kMinPositiveDepth || p2.z() < kMinPositiveDepth) return false;
  double r1[2], r2[2];
  pixelResidual<double>(model, match.pixel1, std::sqrt(match.inv_sigma2_1), p1, r1);
  pixelResidual<double>(model, match.pixel2, std::sqrt(match.inv_sigma2_2), p2, r2);
  return r1[0] * r1[0] + r1[1] * r1[1] < chi2_threshold && r2[0] * r2[0] + r2[1] * r2[1] < chi2_threshold;
}

}  // namespace

Sim3OptimizationResult optimizeSim3(const PinholeCamera& camera, const std::vector<Sim3Match>& matches, Sim3& S12,
                                    const Sim3OptimizationOptions& options) {
  if (!(S12.s > 0)) throw std::invalid_argument("optimizeSim3: the initial scale must be > 0");
  const ProjectionModel model(camera, 0.0);
  Sim3Parameters parameters(S12);

  ceres::Problem::Options problem_options;
  problem_options.enable_fast_removal = true;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::HuberLoss huber(std::sqrt(options.chi2_threshold));
  ceres::EigenQuaternionManifold quaternion_manifold;

  double* q = parameters.q.data();
  double* t = parameters.t.data();
  double* log_scale = &parameters.log_scale;
  std::vector<std::array<ceres::ResidualBlockId, 2>> residual_ids(matches.size());
  for (size_t i = 0; i < matches.size(); ++i) {
    residual_ids[i][0] = problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<PointOfTwoInImageOne, 2, 4, 3, 1>(new PointOfTwoInImageOne(model, matches[i])),
        &huber, q, t, log_scale);
    residual_ids[i][1] = problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<PointOfOneInImageTwo, 2, 4, 3, 1>(new PointOfOneInImageTwo(model, matches[i])),
        &huber, q, t, log_scale);
  }

  auto classify = [&](std::vector<bool>& inlier) {
    const Sim3 current = parameters.toSim3();
    const Sim3 inverse = current.inverse();
    int n = 0;
    for (size_t i = 0; i < matches.size(); ++i) {
      inlier[i] = isInlier(model, current, inverse, matches[i], options.chi2_threshold);
      n += inlier[i] ? 1 : 0;
    }
    return n;
  };

  Sim3OptimizationResult result;
  result.inlier.assign(matches.size(), false);
  if (matches.empty()) return result;
  problem.SetManifold(q, &quaternion_manifold);
  if (options.fix_scale) problem.SetParameterBlockConstant(log_scale);

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // 7 unknowns
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  solver_options.max_num_iterations = options.iterations_first;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  const int first_inliers = classify(result.inlier);
  for (size_t i = 0; i < matches.size(); ++i) {
    if (result.inlier[i]) continue;
    problem.RemoveResidualBlock(residual_ids[i][0]);
    problem.RemoveResidualBlock(residual_ids[i][1]);
  }
  const bool removed_any = first_inliers < static_cast<int>(matches.size());
  if (first_inliers > 0) {
    solver_options.max_num_iterations = removed_any ? options.iterations_second : options.iterations_first;
    ceres::Solve(solver_options, &problem, &summary);
  }

  result.n_inliers = classify(result.inlier);
  S12 = parameters.toSim3();
  return result;
}

}  // namespace vslam
