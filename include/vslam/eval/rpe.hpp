#pragma once
// Relative pose error (RPE): the drift of the estimate over a fixed interval,
// measured without any global alignment. For pose pairs (i, j) an interval
// `delta` apart, the error is E = (G_i^-1 G_j)^-1 (S_i^-1 S_j), G ground truth,
// S estimate (with its translation multiplied by `scale`); its translation
// norm and rotation angle are divided by the interval. See docs/EVALUATION.md.
//  - Association::Timestamp (TUM, and KITTI with times.txt): delta in seconds;
//    j is the pose nearest in time to t_i + delta, kept if within
//    interval_tolerance; units m/s and deg/s.
//  - Association::Index (KITTI): delta in metres of ground-truth path; j is the
//    first pose at least delta further along; units % and deg/100m.
#include <string>

#include "vslam/core/types.hpp"
#include "vslam/eval/ate.hpp"

namespace vslam {

struct RpeOptions {
  double delta = 1.0;  // seconds (Timestamp) or metres (Index); TUM uses 1 s, KITTI 100 m
  Association association = Association::Timestamp;
  double max_time_diff = 0.02;  // pairing of estimate and ground truth
  // How far from t_i + delta the pose j may lie (Timestamp only). 0 = automatic:
  // the larger of max_time_diff and 0.6 of the median time step between the
  // paired poses, so that 30 Hz TUM keeps 0.02 s and KITTI's 0.1036 s steps
  // (where t_i + 1 s falls up to half a step from any frame) still pair.
  double interval_tolerance = 0;
  double scale = 1.0;           // applied to the estimate's translations (the Sim(3) scale of a monocular run)
};

struct RpeResult {
  double trans_rmse = 0, trans_mean = 0;      // m/s (Timestamp) or % of distance (Index)
  double rot_rmse_deg = 0, rot_mean_deg = 0;  // deg/s (Timestamp) or deg/100m (Index)
  int pairs = 0;                              // 0 when no two poses are delta apart (the figures are then undefined)
  std::vector<std::pair<int, int>> pairs_idx;  // (i, j) estimate indices of each interval, by increasing i
  double interval_tolerance = 0;              // the tolerance used (Timestamp)
  std::string units;                          // "m/s, deg/s" or "%, deg/100m"
  std::string trans_units, rot_units;
};

RpeResult computeRpe(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     const RpeOptions& options);

// The error figures are null when there are no pairs: no interval, no figure.
nlohmann::json toJson(const RpeResult& result);

}  // namespace vslam
