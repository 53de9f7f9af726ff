#include "vslam/core/camera.hpp"

#include <opencv2/calib3d.hpp>

namespace vslam {

cv::Mat PinholeCamera::K() const {
  return (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat PinholeCamera::distCoeffs() const {
  return (cv::Mat_<double>(1, 5) << k1, k2, p1, p2, k3);
}

Mat3 PinholeCamera::Keigen() const {
  Mat3 k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

std::vector<cv::Point2f> PinholeCamera::undistort(const std::vector<cv::Point2f>& distorted) const {
  if (!hasDistortion() || distorted.empty()) return distorted;
  std::vector<cv::Point2f> out;
  // P = K keeps the result in pixels of the same camera.
  cv::undistortPoints(distorted, out, K(), distCoeffs(), cv::noArray(), K());
  return out;
}

}  // namespace vslam
