#include "vslam/geometry/sim3_solver.hpp"

#include <array>
#include <cmath>
#include <numeric>
#include <random>

#include <Eigen/Geometry>

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
  result.S12 = best;
  result.inliers = std::move(best_inliers);
  result.n_inliers = best_count;
  result.success = best_count >= params.min_inliers;
  return result;
}

}  // namespace vslam
