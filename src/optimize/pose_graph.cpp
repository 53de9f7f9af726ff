#include "vslam/optimize/pose_graph.hpp"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "sim3_parameters.hpp"

namespace vslam {
namespace {

class Sim3EdgeResidual {
 public:
  Sim3EdgeResidual(const Sim3& S_to_from, double weight)
      : measured_inverse_(S_to_from.inverse()),
        measured_rotation_inverse_(Quat(measured_inverse_.R).normalized()),
        sqrt_weight_(std::sqrt(weight)) {}

  template <typename T>
  bool operator()(const T* q_from, const T* t_from, const T* log_s_from, const T* q_to, const T* t_to,
                  const T* log_s_to, T* residuals) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    using QuatT = Eigen::Quaternion<T>;
    const Eigen::Map<const QuatT> rotation_from(q_from), rotation_to(q_to);
    const Eigen::Map<const Vec3T> translation_from(t_from), translation_to(t_to);

    // Estimated S_to_from = S_to_w * S_from_w^-1.
    const T log_scale = log_s_to[0] - log_s_from[0];
    const QuatT rotation = rotation_to * rotation_from.conjugate();
    const Vec3T translation = translation_to - ceres::exp(log_scale) * (rotation * translation_from);

    // Error E = measured^-1 * estimate.
    const QuatT measured_rotation_inverse = measured_rotation_inverse_.cast<T>();
    const QuatT error_rotation = measured_rotation_inverse * rotation;
    const Vec3T error_translation =
        T(measured_inverse_.s) * (measured_rotation_inverse * translation) + measured_inverse_.t.cast<T>();
    const T error_log_scale = std::log(measured_inverse_.s) + log_scale;

    writeRotationError(error_rotation, residuals);
    for (int i = 0; i < 3; ++i) residuals[3 + i] = error_translation[i];
    residuals[6] = error_log_scale;
    for (int i = 0; i < 7; ++i) residuals[i] *= sqrt_weight_;
    return true;
  }

 private:
  Sim3 measured_inverse_;
  Quat measured_rotation_inverse_;
  double sqrt_weight_;
};

ceres::LinearSolverType poseGraphLinearSolver(ceres::SparseLinearAlgebraLibraryType* library) {
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    *library = ceres::SUITE_SPARSE;
    return ceres::SPARSE_NORMAL_CHOLESKY;
  }
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    *library = ceres::EIGEN_SPARSE;
    return ceres::SPARSE_NORMAL_CHOLESKY;
  }
  return ceres::DENSE_QR;
}

}  // namespace

SE3 rigidPoseFromSim3(const Sim3& S_cw) { return SE3(S_cw.R, S_cw.t / S_cw.s); }

PoseGraphResult optimizeSim3PoseGraph(std::vector<PoseGraphVertex>& vertices, const std::vector<PoseGraphEdge>& edges,
                                      const PoseGraphOptions& options) {
  const int n_vertices = static_cast<int>(vertices.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    const PoseGraphEdge& edge = edges[i];
    if (edge.from < 0 || edge.from >= n_vertices || edge.to < 0 || edge.to >= n_vertices || edge.from == edge.to) {
      throw std::invalid_argument("optimizeSim3PoseGraph: edge " + std::to_string(i) + " (" +
                                  std::to_string(edge.from) + " -> " + std::to_string(edge.to) + ") is invalid for " +
                                  std::to_string(n_vertices) + " vertices");
    }
    if (!(edge.weight > 0)) throw std::invalid_argument("optimizeSim3PoseGraph: edge weight must be > 0");
  }

  for (const PoseGraphVertex& vertex : vertices) {
    if (!(vertex.S_cw.s > 0)) {
      throw std::invalid_argument("optimizeSim3PoseGraph: vertex " + std::to_string(vertex.id) +
                                  " has a non-positive scale");
    }
  }

  std::vector<Sim3Parameters> parameters;
  parameters.reserve(vertices.size());
  for (const PoseGraphVertex& vertex : vertices) parameters.emplace_back(vertex.S_cw);

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  std::vector<bool> in_problem(vertices.size(), false);
  for (const PoseGraphEdge& edge : edges) {
    Sim3Parameters& from = parameters[edge.from];
    Sim3Parameters& to = parameters[edge.to];
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Sim3EdgeResidual, 7, 4, 3, 1, 4, 3, 1>(
                                 new Sim3EdgeResidual(edge.S_to_from, edge.weight)),
                             nullptr, from.q.data(), from.t.data(), &from.log_scale, to.q.data(), to.t.data(),
                             &to.log_scale);
    in_problem[edge.from] = in_problem[edge.to] = true;
  }
  for (size_t v = 0; v < vertices.size(); ++v) {
    if (!in_problem[v]) continue;
    Sim3Parameters& vertex = parameters[v];
    problem.SetManifold(vertex.q.data(), &quaternion_manifold);
    if (vertices[v].fixed) {
      problem.SetParameterBlockConstant(vertex.q.data());
      problem.SetParameterBlockConstant(vertex.t.data());
    }
    if (vertices[v].fixed || options.fix_scale) problem.SetParameterBlockConstant(&vertex.log_scale);
  }

  PoseGraphResult result;
  if (edges.empty()) return result;
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = poseGraphLinearSolver(&solver_options.sparse_linear_algebra_library_type);
  solver_options.max_num_iterations = options.iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.iterations = summary.iterations.empty() ? 0 : static_cast<int>(summary.iterations.size()) - 1;

  for (size_t v = 0; v < vertices.size(); ++v) {
    if (in_problem[v] && !vertices[v].fixed) vertices[v].S_cw = parameters[v].toSim3();
  }
  return result;
}

}  // namespace vslam
