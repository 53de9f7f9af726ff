#pragma once
// Similarity between two keyframes from matched map points (loop closing):
// closed-form Umeyama/Horn on minimal sets of 3 in a seeded RANSAC loop, with
// inliers judged by reprojection in both images, then a re-fit on the inliers.
// The reprojection-error refinement that should follow (the 3D fit weighs the
// map points' uncertain depths) is optimize::optimizeSim3.
#include <cstdint>
#include <vector>

#include "vslam/core/types.hpp"

namespace vslam {

// Correspondence i is one physical point: its coordinates in camera 1 and in
// camera 2, and where each keyframe observed it (undistorted pixels).
struct Sim3Correspondences {
  std::vector<Vec3> points_1, points_2;
  std::vector<Vec2> pixels_1, pixels_2;
  std::vector<double> sigma2_1, sigma2_2;  // observation variances (px^2); empty means 1
};

struct Sim3SolverParams {
  int iterations = 300;
  double chi2_threshold = 9.21;  // chi-square 99 %, 2 dof, times sigma^2 (ORB-SLAM's loop threshold)
  int min_inliers = 20;
  bool fix_scale = false;  // true for stereo / RGB-D, whose scale is observed
};

struct Sim3Result {
  bool success = false;
  Sim3 S12;                   // maps camera-2 coordinates into camera 1: p1 = s R p2 + t
  std::vector<bool> inliers;  // per correspondence
  int n_inliers = 0;
};

// Least-squares similarity with points_1[i] ~ S12 * points_2[i] (Umeyama),
// scale fixed to 1 when fix_scale. Needs >= 3 non-collinear points.
Sim3 computeSim3(const std::vector<Vec3>& points_1, const std::vector<Vec3>& points_2, bool fix_scale);

// A correspondence is an inlier when S12 * p2 projects (K1) within
// chi2_threshold * sigma2_1 of pixels_1 and S12^-1 * p1 projects (K2) within
// chi2_threshold * sigma2_2 of pixels_2 (both in front of their camera).
// The same seed gives the same result.
Sim3Result solveSim3Ransac(const Sim3Correspondences& matches, const Mat3& K1, const Mat3& K2,
                           const Sim3SolverParams& params, uint32_t seed = 0);

}  // namespace vslam
