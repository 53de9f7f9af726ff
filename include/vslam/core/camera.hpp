#pragma once
// Pinhole camera with OpenCV's radial-tangential (k1, k2, p1, p2, k3) distortion.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"

namespace vslam {

struct PinholeCamera {
  std::string name;
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  double fps = 30.0;
  // Depth and stereo (ORB-SLAM2's settings keys in brackets).
  double depth_factor = 5000.0;  // raw depth units per metre [DepthMapFactor] (TUM: 5000)
  // fx times the (virtual) stereo baseline in metres [Camera.bf]; 0 for a
  // monocular camera. RGB-D keypoints get the right-image coordinate
  // u_R = u - bf / depth a stereo rig of that baseline would have measured.
  double bf = 0.0;
  // Points closer than th_depth baselines are "close" [ThDepth]: their depth
  // is trusted as a stereo measurement (ORB-SLAM2's 40 on TUM).
  double th_depth = 40.0;
  // Depth readings beyond this (metres) are dropped: the keypoint stays monocular.
  double max_depth_m = 10.0;
  // Rolling shutter: seconds from the first row's exposure to the last row's
  // (0: a global shutter). Used when frames are posed again after the final
  // BA (docs/GEOMETRY.md, "Rolling shutter").
  double readout_s = 0.0;

  double baseline() const { return fx > 0 ? bf / fx : 0.0; }
  // Depth below which a point counts as close (ORB-SLAM2's mThDepth).
  double closeDepth() const { return baseline() * th_depth; }

  bool hasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  cv::Mat K() const;          // 3x3 CV_64F
  cv::Mat distCoeffs() const;  // 1x5 CV_64F (k1 k2 p1 p2 k3)
  Mat3 Keigen() const;

  // Pixel of a point in camera coordinates (no distortion: keypoints are undistorted first).
  Vec2 project(const Vec3& p_c) const { return Vec2(fx * p_c.x() / p_c.z() + cx, fy * p_c.y() / p_c.z() + cy); }
  // Bearing with z = 1 for an undistorted pixel.
  Vec3 unproject(const Vec2& px) const { return Vec3((px.x() - cx) / fx, (px.y() - cy) / fy, 1.0); }
  bool inImage(const Vec2& px, double border = 0.0) const {
    return px.x() >= border && px.y() >= border && px.x() < width - border && px.y() < height - border;
  }
  // Undistorted pixel coordinates of distorted ones (identity when there is no distortion).
  std::vector<cv::Point2f> undistort(const std::vector<cv::Point2f>& distorted) const;
};

}  // namespace vslam
