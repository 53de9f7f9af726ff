#include "vslam/geometry/sim3_solver.hpp"

#include <array>
#include <cmath>
#include <numeric>
#include <random>

#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace vslam {
namespace {

constexpr int kSampleSize = 3;

// Three points fix a similarity only if they span a triangle; a sliver (area
// tiny against the squared side lengths) gives an arbitrary rotation.
bool wellShaped(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a;
  const double scale2 = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
  return scale2 > 0 && ab.cross(ac).norm() > 1e-6 * scale2;
}

double variance(const std::vector<double>& sigma2, size_t i) { return sigma2.empty() ? 1.0 : sigma2[i]; }

std::vector<bool> findInliers(const Sim3& S12, const Sim3Correspondences& m, const Mat3& K1, const Mat3& K2,
                              double chi2_threshold, int* count) {
  const Sim3 S21 = S12.inverse();
  std::vector<bool> inliers(m.points_1.size(), false);
  *count = 0;
  for (size_t i = 0; i < m.points_1.size(); ++i) {
    const Vec3 p2_in_1 = S12 * m.points_2[i];
    const Vec3 p1_in_2 = S21 * m.points_1[i];
    if (!(p2_in_1.z() > 0) || !(p1_in_2.z() > 0)) continue;
    const double error2_1 = ((K1 * p2_in_1).hnormalized() - m.pixels_1[i]).squaredNorm();
    const double error2_2 = ((K2 * p1_in_2).hnormalized() - m.pixels_2[i]).squaredNorm();
    if (error2_1 < chi2_threshold * variance(m.sigma2_1, i) && error2_2 < chi2_threshold * variance(m.sigma2_2, i)) {
      inliers[i] = true;
      ++*count;
    }
  }
  return inliers;
}

// Reprojection of both points of a correspondence through S12 = (s, R, t),
// parameterised as angle-axis, t and log(s) (so that s stays positive).
struct Sim3ReprojectionResidual {
  Sim3ReprojectionResidual(const Vec3& point_1, const Vec3& point_2, const Vec2& pixel_1, const Vec2& pixel_2,
                           const Mat3& K1, const Mat3& K2, double inv_sigma_1, double inv_sigma_2)
      : point_1(point_1), point_2(point_2), pixel_1(pixel_1), pixel_2(pixel_2), K1(K1), K2(K2),
        inv_sigma_1(inv_sigma_1), inv_sigma_2(inv_sigma_2) {}

  template <typename T>
  bool operator()(const T* angle_axis, const T* translation, const T* log_scale, T* residual) const {
    const T scale = exp(log_scale[0]);
    // Camera 2's point seen from camera 1: p1 = s R p2 + t.
    const T p2[3] = {T(point_2.x()), T(point_2.y()), T(point_2.z())};
    T rotated[3];
    ceres::AngleAxisRotatePoint(angle_axis, p2, rotated);
    const T in_1[3] = {scale * rotated[0] + translation[0], scale * rotated[1] + translation[1],
                       scale * rotated[2] + translation[2]};
    // Camera 1's point seen from camera 2: p2 = R^T (p1 - t) / s.
    const T minus_angle_axis[3] = {-angle_axis[0], -angle_axis[1], -angle_axis[2]};
    const T shifted[3] = {T(point_1.x()) - translation[0], T(point_1.y()) - translation[1],
                          T(point_1.z()) - translation[2]};
    T in_2[3];
    ceres::AngleAxisRotatePoint(minus_angle_axis, shifted, in_2);
    for (T& c : in_2) c /= scale;
    project(K1, in_1, pixel_1, inv_sigma_1, residual);
    project(K2, in_2, pixel_2, inv_sigma_2, residual + 2);
    return true;
  }

  template <typename T>
  static void project(const Mat3& K, const T* p, const Vec2& pixel, double inv_sigma, T* residual) {
    residual[0] = T(inv_sigma) * (T(K(0, 0)) * p[0] / p[2] + T(K(0, 2)) - T(pixel.x()));
    residual[1] = T(inv_sigma) * (T(K(1, 1)) * p[1] / p[2] + T(K(1, 2)) - T(pixel.y()));
  }

  Vec3 point_1, point_2;
  Vec2 pixel_1, pixel_2;
  Mat3 K1, K2;
  double inv_sigma_1, inv_sigma_2;
};

Sim3 refineByReprojection(const Sim3& initial, const Sim3Correspondences& m, const std::vector<bool>& use,
                          const Mat3& K1, const Mat3& K2, const Sim3SolverParams& params) {
  double angle_axis[3];
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R_row = initial.R;
  ceres::RotationMatrixToAngleAxis(ceres::RowMajorAdapter3x3(R_row.data()), angle_axis);
  double translation[3] = {initial.t.x(), initial.t.y(), initial.t.z()};
  double log_scale = std::log(initial.s);
  ceres::Problem problem;
  for (size_t i = 0; i < m.points_1.size(); ++i) {
    if (!use[i]) continue;
    auto* cost = new ceres::AutoDiffCostFunction<Sim3ReprojectionResidual, 4, 3, 3, 1>(new Sim3ReprojectionResidual(
        m.points_1[i], m.points_2[i], m.pixels_1[i], m.pixels_2[i], K1, K2, 1.0 / std::sqrt(variance(m.sigma2_1, i)),
        1.0 / std::sqrt(variance(m.sigma2_2, i))));
    // Robust at the inlier bound, as ORB-SLAM's Sim(3) optimisation.
    problem.AddResidualBlock(cost, new ceres::HuberLoss(std::sqrt(params.chi2_threshold)), angle_axis, translation,
                             &log_scale);
  }
  if (problem.NumResidualBlocks() == 0) return initial;
  if (params.fix_scale) problem.SetParameterBlockConstant(&log_scale);
  ceres::Solver::Options options;
  options.max_num_iterations = 10;
  options.linear_solver_type = ceres::DENSE_QR;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return initial;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R_refined;
  ceres::AngleAxisToRotationMatrix(angle_axis, ceres::RowMajorAdapter3x3(R_refined.data()));
  const Sim3 refined(params.fix_scale ? 1.0 : std::exp(log_scale), R_refined,
                     Vec3(translation[0], translation[1], translation[2]));
  const bool finite = std::isfinite(refined.s) && refined.R.allFinite() && refined.t.allFinite();
  return finite ? refined : initial;
}

}  // namespace

Sim3 computeSim3(const std::vector<Vec3>& points_1, const std::vector<Vec3>& points_2, bool fix_scale) {
  Eigen::Matrix3Xd source(3, points_2.size()), target(3, points_1.size());
  for (size_t i = 0; i < points_1.size(); ++i) {
    source.col(i) = points_2[i];
    target.col(i) = points_1[i];
  }
  const Mat4 T = Eigen::umeyama(source, target, !fix_scale);
  // umeyama returns [sR t; 0 1]; the scale is the norm of any column of sR.
  const Mat3 sR = T.topLeftCorner<3, 3>();
  const double scale = fix_scale ? 1.0 : sR.col(0).norm();
  return Sim3(scale, sR / scale, T.topRightCorner<3, 1>());
}

Sim3Result solveSim3Ransac(const Sim3Correspondences& m, const Mat3& K1, const Mat3& K2,
                           const Sim3SolverParams& params, uint32_t seed) {
  Sim3Result result;
  const int n = static_cast<int>(m.points_1.size());
  result.inliers.assign(n, false);
  if (n < kSampleSize || m.points_2.size() != m.points_1.size() || m.pixels_1.size() != m.points_1.size() ||
      m.pixels_2.size() != m.points_1.size()) {
    return result;
  }
  std::mt19937 rng(seed);
  std::vector<int> pool(n);
  Sim3 best;
  int best_count = 0;
  std::vector<bool> best_inliers(n, false);
  std::vector<Vec3> sample_1(kSampleSize), sample_2(kSampleSize);
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    std::iota(pool.begin(), pool.end(), 0);
    for (int k = 0; k < kSampleSize; ++k) {
      std::swap(pool[k], pool[k + static_cast<int>(rng() % static_cast<uint32_t>(n - k))]);
      sample_1[k] = m.points_1[pool[k]];
      sample_2[k] = m.points_2[pool[k]];
    }
    if (!wellShaped(sample_2[0], sample_2[1], sample_2[2]) || !wellShaped(sample_1[0], sample_1[1], sample_1[2])) {
      continue;
    }
    const Sim3 S12 = computeSim3(sample_1, sample_2, params.fix_scale);
    if (!(S12.s > 0) || !S12.R.allFinite() || !S12.t.allFinite()) continue;
    int count = 0;
    std::vector<bool> inliers = findInliers(S12, m, K1, K2, params.chi2_threshold, &count);
    if (count > best_count) {
      best_count = count;
      best = S12;
      best_inliers = std::move(inliers);
      if (best_count == n) break;
    }
  }
  if (best_count < std::max(kSampleSize, params.min_inliers)) return result;

  // Least squares on all inliers; keep it while it does not lose inliers.
  for (int round = 0; round < 2; ++round) {
    std::vector<Vec3> inlier_1, inlier_2;
    for (int i = 0; i < n; ++i) {
      if (!best_inliers[i]) continue;
      inlier_1.push_back(m.points_1[i]);
      inlier_2.push_back(m.points_2[i]);
    }
    const Sim3 refined = computeSim3(inlier_1, inlier_2, params.fix_scale);
    int count = 0;
    std::vector<bool> inliers = findInliers(refined, m, K1, K2, params.chi2_threshold, &count);
    if (count < best_count) break;
    best = refined;
    best_count = count;
    best_inliers = std::move(inliers);
  }
  if (params.refine_reprojection) {
    const Sim3 refined = refineByReprojection(best, m, best_inliers, K1, K2, params);
    int count = 0;
    std::vector<bool> inliers = findInliers(refined, m, K1, K2, params.chi2_threshold, &count);
    if (count >= best_count) {
      best = refined;
      best_count = count;
      best_inliers = std::move(inliers);
    }
  }
  result.S12 = best;
  result.inliers = std::move(best_inliers);
  result.n_inliers = best_count;
  result.success = best_count >= params.min_inliers;
  return result;
}

}  // namespace vslam
