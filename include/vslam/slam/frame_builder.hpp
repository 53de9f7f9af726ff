#pragma once
// Turns an image into a Frame: ORB extraction on one pyramid, the paper's
// keypoint filter with the frame's detections, undistortion, colours, depth.
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/feature/orb_extractor.hpp"
#include "vslam/map/frame.hpp"

namespace vslam {

class FrameBuilder {
 public:
  FrameBuilder(const Config& config, const PinholeCamera& camera);

  // `bgr` is the colour image (or grey, CV_8UC1); `depth_m` is CV_32F metres or
  // empty; `n_features` < 0 means the configured number.
  Frame build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m = cv::Mat(),
              int n_features = -1) const;

  const ScalePyramid& pyramid() const { return pyramid_; }
  const PinholeCamera& camera() const { return camera_; }
  const OrbExtractor& extractor() const { return extractor_; }

 private:
  Config config_;
  PinholeCamera camera_;
  OrbExtractor extractor_;
  ScalePyramid pyramid_;
  cv::Rect2f undistorted_bounds_;
};

}  // namespace vslam
