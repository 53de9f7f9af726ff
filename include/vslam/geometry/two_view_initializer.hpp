#pragma once
// Monocular map initialisation from two views (ORB-SLAM's scheme): a
// homography H and a fundamental matrix F are estimated by RANSAC on the same
// minimal sets, scored by symmetric transfer error, and the ratio
// S_H / (S_H + S_F) picks the model; the motion is recovered from it and the
// matches are triangulated. See docs/GEOMETRY.md for the thresholds and rules.
#include <cstdint>
#include <string>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

struct TwoViewResult {
  bool success = false;
  bool used_homography = false;
  double score_ratio = 0;          // S_H / (S_H + S_F)
  double score_h = 0, score_f = 0;  // the two scores behind the ratio
  SE3 T_cur_ref;                   // current camera w.r.t. the reference (p_cur = T_cur_ref * p_ref); |t| = 1
  std::vector<Vec3> points_ref;    // triangulated points in the reference camera frame, one per match (0 if none)
  std::vector<bool> triangulated;  // per match: in front of both, reprojects within chi2, enough parallax
  std::vector<bool> model_inliers;  // per match: inlier of the chosen H or F
  int n_model_inliers = 0;
  int n_triangulated = 0;
  double median_parallax_deg = 0;  // over the triangulated points of the chosen motion
  // First-order standard deviation of the chosen motion's translation
  // direction, rotation marginalised (+inf when unconstrained).
  double translation_direction_std_deg = 0;
  std::string failure_reason;      // why it failed (for the log); empty on success
  // On failure the other fields still describe the best attempt, for logging;
  // nothing in them may be used to build a map.
};

class TwoViewInitializer {
 public:
  // K: intrinsics of the (undistorted) images. `seed` makes the RANSAC sets,
  // and so the whole result, reproducible.
  TwoViewInitializer(const Mat3& K, const InitializerParams& params, uint32_t seed = 0);

  // pts_ref[i] and pts_cur[i] are a match, in undistorted pixels. Every point
  // has the standard deviation params.sigma_px.
  TwoViewResult initialize(const std::vector<Vec2>& pts_ref, const std::vector<Vec2>& pts_cur) const;
  // The same with a variance (pixels^2) per point, e.g. scale_factor^(2*octave)
  // for a keypoint of pyramid level `octave`; an empty vector means sigma_px^2.
  TwoViewResult initialize(const std::vector<Vec2>& pts_ref, const std::vector<Vec2>& pts_cur,
                           const std::vector<double>& sigma2_ref, const std::vector<double>& sigma2_cur) const;

  const InitializerParams& params() const { return params_; }

 private:
  Mat3 K_;
  InitializerParams params_;
  uint32_t seed_;
};

// ---- Building blocks, public so that they can be tested and reused. ----

// Homography with p2 ~ H p1 by the normalised DLT (Hartley); needs >= 4 points.
Mat3 computeHomography(const std::vector<Vec2>& p1, const std::vector<Vec2>& p2);
// Fundamental matrix with p2^T F p1 = 0 by the normalised 8-point algorithm,
// rank 2 enforced; needs >= 8 points.
Mat3 computeFundamental(const std::vector<Vec2>& p1, const std::vector<Vec2>& p2);
// The fundamental matrix of the essential matrix nearest to K^T F K (equal
// singular values, Frobenius norm): F restricted to motions a camera with
// intrinsics K can make.
Mat3 nearestCalibratedFundamental(const Mat3& F, const Mat3& K);
// The four (R, t) with E ~ [t]x R (|t| = 1), i.e. T_2_1 candidates for
// x2^T E x1 = 0 in normalised coordinates.
std::vector<SE3> motionsFromEssential(const Mat3& E);
// The motions (R, t/d) of a homography between pixel images with intrinsics K
// (up to four, from cv::decomposeHomographyMat), t normalised to 1.
std::vector<SE3> motionsFromHomography(const Mat3& H, const Mat3& K);

// Median z of the points with use[i] (all if `use` is empty); 0 if there are none.
double medianDepth(const std::vector<Vec3>& points, const std::vector<bool>& use = {});

}  // namespace vslam
