#pragma once
// The KITTI odometry benchmark's error (Geiger et al., CVPR 2012; its devkit's
// evaluate_odometry.cpp), as road SLAM results are quoted:
//  - d_k: distance travelled along the ground truth up to frame k (sum of the
//    distances between consecutive ground-truth positions, d_0 = 0);
//  - a subsequence starts at every `step_frames`-th frame f (0, 10, 20, ...) and,
//    for each length L (100, 200, ..., 800 m), ends at the first frame l with
//    d_l > d_f + L (strictly); starts with no such frame give no subsequence;
//  - E = (G_f^-1 G_l)^-1 (S_f^-1 S_l), G ground truth, S estimate (camera-to-world;
//    the devkit writes the inverse, which has the same angle and translation norm);
//  - translational error |trans(E)| / L, rotational error angle(E) / L, L the
//    nominal length (not d_l - d_f);
//  - the figures are the means over all subsequences of all lengths, reported
//    in % and deg/100 m.
// See docs/EVALUATION.md.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "vslam/core/types.hpp"

namespace vslam {

struct KittiOdometryOptions {
  std::vector<double> lengths_m = {100, 200, 300, 400, 500, 600, 700, 800};  // the benchmark's lengths
  int step_frames = 10;  // a subsequence starts every 10th frame (1 s at 10 Hz)
  double scale = 1.0;    // applied to the estimate's translations (a monocular run's Sim(3) scale)
};

struct KittiLengthError {
  double length_m = 0;
  int subsequences = 0;
  double translation_error_pct = 0;        // mean over this length's subsequences
  double rotation_error_deg_per_100m = 0;  // idem
};

struct KittiOdometryResult {
  // False when not one subsequence could be scored; `unavailable_reason` says why
  // and the figures are then undefined (reported as null, never 0).
  bool available = false;
  std::string unavailable_reason;
  std::vector<double> lengths_m;  // the options' lengths
  bool standard_lengths = true;   // they are the benchmark's 100, 200, ..., 800 m
  double translation_error_pct = 0;
  double rotation_error_deg_per_100m = 0;
  int subsequences = 0;  // scored
  // Subsequences whose first or last frame has no estimate (lost, or before
  // initialisation): not scored, counted here so that nothing is hidden.
  int subsequences_without_estimate = 0;
  double groundtruth_length_m = 0;  // d of the last frame
  std::vector<KittiLengthError> per_length;  // lengths with at least one scored subsequence
};

// `groundtruth[k]`: camera-to-world pose of frame k, every frame, in order.
// `estimate[k]`: the estimate of frame k, or nullopt where there is none; same size.
// Throws std::invalid_argument when the sizes differ or an option is not positive.
KittiOdometryResult computeKittiOdometryError(const std::vector<SE3>& groundtruth,
                                              const std::vector<std::optional<SE3>>& estimate,
                                              const KittiOdometryOptions& options = KittiOdometryOptions());

// {"available", "translation_error_pct", "rotation_error_deg_per_100m" (null when
// unavailable, with "reason"), "subsequences", "subsequences_without_estimate",
// "groundtruth_length_m", "lengths_m", "standard_lengths", "per_length": [...]}
nlohmann::json toJson(const KittiOdometryResult& result);

}  // namespace vslam
