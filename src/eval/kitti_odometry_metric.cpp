#include "vslam/eval/kitti_odometry_metric.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <Eigen/Geometry>

namespace vslam {
namespace {

const std::vector<double> kBenchmarkLengths = {100, 200, 300, 400, 500, 600, 700, 800};

double rotationAngleRad(const Mat3& R) {
  // Through the quaternion: the devkit's acos((trace - 1) / 2) is the same angle
  // but loses its precision for the small angles of good estimates.
  return Eigen::AngleAxisd(Quat(R).normalized()).angle();
}

// The devkit's lastFrameFromSegmentLength: the first frame strictly beyond
// `length` metres from `first`, or -1.
int lastFrameOfSubsequence(const std::vector<double>& distance, int first, double length) {
  for (int k = first; k < static_cast<int>(distance.size()); ++k)
    if (distance[k] > distance[first] + length) return k;
  return -1;
}

std::string metres(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f m", value);
  return text;
}

}  // namespace

KittiOdometryResult computeKittiOdometryError(const std::vector<SE3>& groundtruth,
                                              const std::vector<std::optional<SE3>>& estimate,
                                              const KittiOdometryOptions& options) {
  if (groundtruth.size() != estimate.size())
    throw std::invalid_argument("computeKittiOdometryError: ground truth and estimate differ in length");
  if (options.step_frames <= 0 || options.lengths_m.empty())
    throw std::invalid_argument("computeKittiOdometryError: step_frames and lengths_m must be positive");
  for (double length : options.lengths_m)
    if (!(length > 0)) throw std::invalid_argument("computeKittiOdometryError: lengths must be positive");

  KittiOdometryResult result;
  result.lengths_m = options.lengths_m;
  result.standard_lengths = options.lengths_m == kBenchmarkLengths;
  const int frames = static_cast<int>(groundtruth.size());
  std::vector<double> distance(frames, 0.0);
  for (int k = 1; k < frames; ++k) distance[k] = distance[k - 1] + (groundtruth[k].t - groundtruth[k - 1].t).norm();
  result.groundtruth_length_m = frames > 0 ? distance.back() : 0.0;

  std::vector<KittiLengthError> per_length;
  for (double length : options.lengths_m) per_length.push_back({length, 0, 0.0, 0.0});
  double translation_sum = 0, rotation_sum = 0;  // fractions and rad per metre, as the devkit sums them
  for (int first = 0; first < frames; first += options.step_frames) {
    for (KittiLengthError& length_error : per_length) {
      const double length = length_error.length_m;
      const int last = lastFrameOfSubsequence(distance, first, length);
      if (last < 0) continue;
      if (!estimate[first] || !estimate[last]) {
        ++result.subsequences_without_estimate;
        continue;
      }
      const SE3 groundtruth_motion = groundtruth[first].inverse() * groundtruth[last];
      SE3 estimate_motion = estimate[first]->inverse() * *estimate[last];
      estimate_motion.t *= options.scale;
      const SE3 error = groundtruth_motion.inverse() * estimate_motion;
      const double translation = error.t.norm() / length;
      const double rotation = rotationAngleRad(error.R) / length;
      translation_sum += translation;
      rotation_sum += rotation;
      ++result.subsequences;
      ++length_error.subsequences;
      length_error.translation_error_pct += translation;
      length_error.rotation_error_deg_per_100m += rotation;
    }
  }
  constexpr double kRadToDegPer100m = 100.0 * 180.0 / M_PI;
  for (KittiLengthError& length_error : per_length) {
    if (length_error.subsequences == 0) continue;
    length_error.translation_error_pct *= 100.0 / length_error.subsequences;
    length_error.rotation_error_deg_per_100m *= kRadToDegPer100m / length_error.subsequences;
    result.per_length.push_back(length_error);
  }
  if (result.subsequences > 0) {
    result.available = true;
    result.translation_error_pct = 100.0 * translation_sum / result.subsequences;
    result.rotation_error_deg_per_100m = kRadToDegPer100m * rotation_sum / result.subsequences;
  } else if (result.subsequences_without_estimate > 0) {
    result.unavailable_reason = "none of the " + std::to_string(result.subsequences_without_estimate) +
                                " subsequences has an estimate at both its first and last frame";
  } else {
    double shortest = options.lengths_m.front();
    for (double length : options.lengths_m) shortest = std::min(shortest, length);
    result.unavailable_reason = "the ground truth covers " + metres(result.groundtruth_length_m) + " over " +
                                std::to_string(frames) + " frames; no subsequence of " + metres(shortest) +
                                " (the shortest length) fits";
  }
  return result;
}

nlohmann::json toJson(const KittiOdometryResult& result) {
  nlohmann::json json;
  json["available"] = result.available;
  if (result.available) {
    json["translation_error_pct"] = result.translation_error_pct;
    json["rotation_error_deg_per_100m"] = result.rotation_error_deg_per_100m;
  } else {
    json["translation_error_pct"] = nullptr;
    json["rotation_error_deg_per_100m"] = nullptr;
    json["reason"] = result.unavailable_reason;
  }
  json["subsequences"] = result.subsequences;
  json["subsequences_without_estimate"] = result.subsequences_without_estimate;
  json["groundtruth_length_m"] = result.groundtruth_length_m;
  json["lengths_m"] = result.lengths_m;
  json["standard_lengths"] = result.standard_lengths;
  nlohmann::json per_length = nlohmann::json::array();
  for (const KittiLengthError& length_error : result.per_length)
    per_length.push_back({{"length_m", length_error.length_m},
                          {"subsequences", length_error.subsequences},
                          {"translation_error_pct", length_error.translation_error_pct},
                          {"rotation_error_deg_per_100m", length_error.rotation_error_deg_per_100m}});
  json["per_length"] = per_length;
  return json;
}

}  // namespace vslam
