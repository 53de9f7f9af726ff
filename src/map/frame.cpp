#include "vslam/map/frame.hpp"

#include <cmath>

namespace vslam {

double ScalePyramid::logScaleFactor() const { return std::log(scale_factor); }

void Frame::finalizeFeatures(const cv::Rect2f& bounds) {
  const size_t n = keypoints.size();
  map_points.assign(n, nullptr);
  outlier.assign(n, false);
  if (labels.size() != n) labels.assign(n, FeatureLabel{});
  std::vector<int> levels(n);
  for (size_t i = 0; i < n; ++i) levels[i] = keypoints[i].octave;
  grid = FeatureGrid(points, std::move(levels), bounds);
}

int Frame::trackedCount() const {
  int count = 0;
  for (size_t i = 0; i < map_points.size(); ++i)
    if (map_points[i] && !outlier[i]) ++count;
  return count;
}

}  // namespace vslam
