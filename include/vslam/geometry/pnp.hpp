#pragma once
// Camera pose from 3D-2D matches (relocalisation): P3P on minimal sets in a
// seeded RANSAC loop, then Levenberg-Marquardt on the inliers.
#include <cstdint>
#include <vector>

#include "vslam/core/types.hpp"

namespace vslam {

struct PnpResult {
  bool success = false;
  SE3 T_cw;                  // world -> camera
  std::vector<int> inliers;  // indices into the input, ascending
};

// points_w[i] is seen at the undistorted pixel pixels[i]. A match is an inlier
// when the point is in front of the camera and reprojects within
// `reproj_px` * pixel_sigma[i]: a keypoint detected at pyramid level l is
// measured to sigma = 1.2^l pixels, so ORB-SLAM2's chi-square 5.991 sigma^2
// is reproj_px = sqrt(5.991) with pixel_sigma[i] = 1.2^l (empty: sigma 1).
// Draws at most `iterations` minimal sets of 4 (P3P + a check point), stopping
// early once the best inlier ratio makes a better set unlikely (99 %);
// success needs `min_inliers` after refinement. The same seed gives the same
// result.
PnpResult solvePnpRansac(const std::vector<Vec3>& points_w, const std::vector<Vec2>& pixels, const Mat3& K,
                         int iterations = 300, double reproj_px = 2.4477 /* sqrt(5.991) */, int min_inliers = 15,
                         uint32_t seed = 0, const std::vector<double>& pixel_sigma = {});

}  // namespace vslam
