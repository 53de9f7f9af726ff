#pragma once
// Absolute trajectory error (ATE), as the TUM RGB-D benchmark's evaluate_ate
// defines it: pair estimate and ground-truth poses, align the estimate's
// positions to the ground truth's in the least-squares sense (Horn / Umeyama;
// rigid for metric runs, with scale for monocular ones), and take statistics of
// the remaining position differences. See docs/EVALUATION.md.
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "vslam/core/types.hpp"

namespace vslam {

enum class Alignment { SE3, Sim3 };
enum class Association {
  Timestamp,  // nearest timestamps within max_time_diff, associate.py's greedy rule (TUM)
  Index,      // line i with line i (KITTI)
};

struct AteOptions {
  Alignment alignment = Alignment::SE3;
  Association association = Association::Timestamp;
  double max_time_diff = 0.02;  // seconds; pairs must differ by strictly less
};

struct AteResult {
  double rmse_m = 0, mean_m = 0, median_m = 0, std_m = 0, min_m = 0, max_m = 0;
  double scale = 1.0;  // scale of `alignment` (1 for SE3)
  int pairs = 0;
  Sim3 alignment;                              // maps estimate positions into the ground-truth frame
  std::vector<double> errors_m;                // one per pair, in the order of pairs_idx
  std::vector<std::pair<int, int>> pairs_idx;  // (estimate index, ground-truth index), by increasing time
};

// Throws InputError when fewer than 3 pose pairs are found (no alignment is defined then).
AteResult computeAte(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
                     const AteOptions& options);

// Index pairs (estimate, ground truth) by the chosen association; shared with the RPE.
std::vector<std::pair<int, int>> associatePoses(const std::vector<StampedPose>& estimate,
                                                const std::vector<StampedPose>& groundtruth, Association association,
                                                double max_time_diff);

// {"rmse_m", "mean_m", "median_m", "std_m", "min_m", "max_m", "scale", "pairs"}
nlohmann::json toJson(const AteResult& result);

const char* toString(Alignment alignment);  // "se3" | "sim3"

}  // namespace vslam
