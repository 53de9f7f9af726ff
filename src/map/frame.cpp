#include "vslam/map/frame.hpp"

#include <cmath>

namespace vslam {

double ScalePyramid::logScaleFactor() const { return std::log(scale_factor); }

void Frame::finalizeFeatures() {
  const size_t n = keypoints.size();
  map_points.assign(n, nullptr);
  outlier.assign(n, false);
  if (labels.size() != n) labels.assign(n, FeatureLabel{});
  std::vector<cv::Point2f> undistorted(n);
  std::vector<int> levels(n);
  for (size_t i = 0; i < n; ++i) {
    undistorted[i] = cv::Point2f(static_cast<float>(points[i].x()), static_cast<float>(points[i].y()));
    levels[i] = keypoints[i].octave;
  }
  grid.build(undistorted, levels, camera->width, camera->height);
}

int Frame::trackedCount() const {
  int count = 0;
  for (size_t i = 0; i < map_points.size(); ++i)
    if (map_points[i] && !outlier[i]) ++count;
  return count;
}

}  // namespace vslam
