#include "vslam/eval/ate.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>

#include "vslam/core/error.hpp"
#include "vslam/io/timestamp_association.hpp"

namespace vslam {

std::vector<std::pair<int, int>> associatePoses(const std::vector<StampedPose>& estimate,
                                                const std::vector<StampedPose>& groundtruth, Association association,
                                                double max_time_diff) {
  std::vector<std::pair<int, int>> pairs;
  if (association == Association::Index) {
    const int n = static_cast<int>(std::min(estimate.size(), groundtruth.size()));
    for (int i = 0; i < n; ++i) pairs.emplace_back(i, i);
    return pairs;
  }
  std::vector<double> estimate_times, groundtruth_times;
  for (const StampedPose& p : estimate) estimate_times.push_back(p.timestamp);
  for (const StampedPose& p : groundtruth) groundtruth_times.push_back(p.timestamp);
  // associate.py sorts the matches by the ground truth's time; with both lists
  // increasing and greedy matching that is also the estimate's order.
  pairs = associateTimestamps(estimate_times, groundtruth_times, max_time_diff);
  std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  return pairs;
}

AteResult computeAte(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     const AteOptions& options) {
  AteResult result;
  if (estimate.empty()) throw InputError("the estimate holds no poses; at least 3 are needed to align");
  result.pairs_idx = associatePoses(estimate, groundtruth, options.association, options.max_time_diff);
  result.pairs = static_cast<int>(result.pairs_idx.size());
  if (result.pairs < 3)
    throw InputError("only " + std::to_string(result.pairs) + " of " + std::to_string(estimate.size()) +
                     " estimated poses pair with ground truth" +
                     (options.association == Association::Timestamp
                          ? " within " + std::to_string(options.max_time_diff) + " s"
                          : std::string()) +
                     "; at least 3 are needed to align");

  Eigen::Matrix3Xd estimate_xyz(3, result.pairs), groundtruth_xyz(3, result.pairs);
  for (int k = 0; k < result.pairs; ++k) {
    estimate_xyz.col(k) = estimate[result.pairs_idx[k].first].T_wc.t;
    groundtruth_xyz.col(k) = groundtruth[result.pairs_idx[k].second].T_wc.t;
  }
  // A trajectory that never moves (e.g. a run lost from the start) has no
  // defined alignment; say so instead of reporting NaN.
  const double estimate_spread = (estimate_xyz.colwise() - estimate_xyz.rowwise().mean()).squaredNorm();
  if (!(estimate_spread > 1e-18 * result.pairs))
    throw InputError("the " + std::to_string(result.pairs) +
                     " paired estimated positions are all the same point; no alignment is defined");
  // Least-squares similarity (or rigid) transform taking estimate onto ground truth.
  const Mat4 T = Eigen::umeyama(estimate_xyz, groundtruth_xyz, options.alignment == Alignment::Sim3);
  const Mat3 sR = T.topLeftCorner<3, 3>();
  // umeyama returns s*R in one block; det(s*R) = s^3 (exactly 1 for SE(3), so say so exactly).
  result.scale = options.alignment == Alignment::Sim3 ? std::cbrt(sR.determinant()) : 1.0;
  result.alignment = Sim3(result.scale, sR / result.scale, T.topRightCorner<3, 1>());

  result.errors_m.resize(result.pairs);
  for (int k = 0; k < result.pairs; ++k)
    result.errors_m[k] = (result.alignment * Vec3(estimate_xyz.col(k)) - groundtruth_xyz.col(k)).norm();

  const std::vector<double>& e = result.errors_m;
  const double n = static_cast<double>(result.pairs);
  const double sum_squares = std::inner_product(e.begin(), e.end(), e.begin(), 0.0);
  result.rmse_m = std::sqrt(sum_squares / n);
  result.mean_m = std::accumulate(e.begin(), e.end(), 0.0) / n;
  // Population standard deviation, as numpy.std in evaluate_ate.py (two passes: no cancellation).
  double sum_deviations = 0.0;
  for (double error : e) sum_deviations += (error - result.mean_m) * (error - result.mean_m);
  result.std_m = std::sqrt(sum_deviations / n);
  std::vector<double> sorted = e;
  std::sort(sorted.begin(), sorted.end());
  const size_t mid = sorted.size() / 2;
  result.median_m = sorted.size() % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  result.min_m = sorted.front();
  result.max_m = sorted.back();
  return result;
}

nlohmann::json toJson(const AteResult& result) {
  return {{"rmse_m", result.rmse_m}, {"mean_m", result.mean_m}, {"median_m", result.median_m}, {"std_m", result.std_m},
          {"min_m", result.min_m},   {"max_m", result.max_m},   {"scale", result.scale},       {"pairs", result.pairs}};
}

const char* toString(Alignment alignment) { return alignment == Alignment::Sim3 ? "sim3" : "se3"; }

}  // namespace vslam
