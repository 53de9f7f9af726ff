#include "vslam/eval/rpe.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

double rotationAngleDeg(const Mat3& R) {
  // Through the quaternion: acos((trace - 1) / 2) loses all precision for the
  // tiny angles that good estimates have.
  return Eigen::AngleAxisd(Quat(R).normalized()).angle() * 180.0 / M_PI;
}

// The median spacing of increasing times (0 for fewer than two).
double medianStep(const std::vector<double>& times) {
  std::vector<double> steps;
  for (size_t k = 1; k < times.size(); ++k) steps.push_back(times[k] - times[k - 1]);
  if (steps.empty()) return 0.0;
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  return steps[steps.size() / 2];
}

}  // namespace

RpeResult computeRpe(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     const RpeOptions& options) {
  if (!(options.delta > 0)) throw InputError("RPE interval (--rpe-delta) must be positive");
  RpeResult result;
  const bool by_time = options.association == Association::Timestamp;
  result.trans_units = by_time ? "m/s" : "%";
  result.rot_units = by_time ? "deg/s" : "deg/100m";
  result.units = result.trans_units + ", " + result.rot_units;

  const auto pairs = associatePoses(estimate, groundtruth, options.association, options.max_time_diff);
  const int n = static_cast<int>(pairs.size());
  // Position along the sequence: time (TUM) or distance travelled on the ground truth (KITTI).
  std::vector<double> along(n, 0.0);
  for (int k = 0; k < n; ++k) {
    if (by_time)
      along[k] = estimate[pairs[k].first].timestamp;
    else if (k > 0)
      along[k] = along[k - 1] + (groundtruth[pairs[k].second].T_wc.t - groundtruth[pairs[k - 1].second].T_wc.t).norm();
  }

  if (by_time)
    result.interval_tolerance = options.interval_tolerance > 0
                                    ? options.interval_tolerance
                                    : std::max(options.max_time_diff, 0.6 * medianStep(along));

  double trans_sum = 0, trans_squares = 0, rot_sum = 0, rot_squares = 0;
  for (int i = 0; i < n; ++i) {
    const double target = along[i] + options.delta;
    int j = static_cast<int>(std::lower_bound(along.begin() + i + 1, along.end(), target) - along.begin());
    if (by_time) {
      // Nearest in time to the target, within the tolerance.
      if (j > i + 1 && (j == n || target - along[j - 1] < along[j] - target)) --j;
      if (j >= n || std::abs(along[j] - target) > result.interval_tolerance) continue;
    } else if (j >= n) {
      continue;
    }
    const SE3& G_i = groundtruth[pairs[i].second].T_wc;
    const SE3& G_j = groundtruth[pairs[j].second].T_wc;
    SE3 estimate_motion = estimate[pairs[i].first].T_wc.inverse() * estimate[pairs[j].first].T_wc;
    estimate_motion.t *= options.scale;
    const SE3 error = (G_i.inverse() * G_j).inverse() * estimate_motion;
    const double per_unit = by_time ? 1.0 / options.delta : 100.0 / options.delta;
    const double trans = error.t.norm() * per_unit;
    const double rot = rotationAngleDeg(error.R) * per_unit;
    trans_sum += trans;
    trans_squares += trans * trans;
    rot_sum += rot;
    rot_squares += rot * rot;
    ++result.pairs;
    result.pairs_idx.emplace_back(pairs[i].first, pairs[j].first);
  }
  if (result.pairs > 0) {
    result.trans_mean = trans_sum / result.pairs;
    result.trans_rmse = std::sqrt(trans_squares / result.pairs);
    result.rot_mean_deg = rot_sum / result.pairs;
    result.rot_rmse_deg = std::sqrt(rot_squares / result.pairs);
  }
  return result;
}

nlohmann::json toJson(const RpeResult& result) {
  if (result.pairs == 0)
    return {{"trans_rmse", nullptr}, {"trans_mean", nullptr},          {"rot_rmse_deg", nullptr},
            {"rot_mean_deg", nullptr}, {"pairs", 0},                  {"trans_units", result.trans_units},
            {"rot_units", result.rot_units}};
  return {
      {"trans_rmse", result.trans_rmse},     {"trans_mean", result.trans_mean}, {"rot_rmse_deg", result.rot_rmse_deg},
      {"rot_mean_deg", result.rot_mean_deg}, {"pairs", result.pairs},           {"trans_units", result.trans_units},
      {"rot_units", result.rot_units}};
}

}  // namespace vslam
