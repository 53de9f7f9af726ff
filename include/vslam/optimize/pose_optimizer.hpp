#pragma once
// Pose-only optimisation for Tracking: refine one camera pose T_cw against
// known map points, rejecting outliers over a few rounds (as ORB-SLAM does).
//
// Plain values in and out: the map layer copies points and observations in
// under its own lock and writes the pose and outlier flags back.
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {

// One keypoint matched to a map point. Stereo / RGB-D observations also carry
// the right-image coordinate u_right = u - bf / depth (kNoRightCoordinate: monocular).
struct Observation2D {
  int point = 0;            // index into the points vector
  Vec2 pixel = Vec2::Zero();  // undistorted keypoint
  double inv_sigma2 = 1.0;  // 1 / sigma^2 of the keypoint's pyramid level
  double u_right = kNoRightCoordinate;
};

struct PoseOptimizationOptions {
  int rounds = 4;
  int iterations_per_round = 10;
  int robust_rounds = 2;  // Huber loss on the first rounds only, plain least squares afterwards
  double chi2_mono = kChi2Mono;
  double chi2_stereo = kChi2Stereo;
};

struct PoseOptimizationResult {
  SE3 T_cw;
  std::vector<bool> inlier;  // per observation, after the last round
  int n_inliers = 0;
};

// Each round optimises the pose over the observations currently classified as
// inliers (all, in the first round), then reclassifies every observation by
// chi2 < threshold with the point in front of the camera; an observation
// dropped in one round comes back if its error falls. Rounds stop early when
// fewer than 10 inliers remain, or when a round without the robust loss
// converged and left the classification unchanged (the next one would solve
// the same problem).
// With fewer than 3 observations the pose is returned unchanged, only classified.
PoseOptimizationResult optimizePose(const PinholeCamera& camera, double bf, const SE3& T_cw_initial,
                                    const std::vector<Vec3>& points_w,
                                    const std::vector<Observation2D>& observations,
                                    const PoseOptimizationOptions& options = {});

}  // namespace vslam
