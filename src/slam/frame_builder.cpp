#include "vslam/slam/frame_builder.hpp"

#include <opencv2/imgproc.hpp>

namespace vslam {

FrameBuilder::FrameBuilder(const Config& config, const PinholeCamera& camera)
    : config_(config), camera_(camera), extractor_(config.orb) {
  pyramid_.levels = extractor_.levels();
  pyramid_.scale_factor = config.orb.scale_factor;
  pyramid_.scale = extractor_.scaleFactors();
  pyramid_.sigma2 = extractor_.levelSigma2();
  pyramid_.inv_sigma2 = extractor_.invLevelSigma2();
  undistorted_bounds_ = undistortedImageBounds(camera_);
}

Frame FrameBuilder::build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m,
                          int n_features) const {
  Frame frame;
  frame.id = id;
  frame.index = index;
  frame.timestamp = timestamp;
  frame.camera = &camera_;
  frame.pyramid = &pyramid_;

  cv::Mat gray;
  if (bgr.channels() == 3)
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  else
    gray = bgr;
  const ImagePyramid image_pyramid = extractor_.buildPyramid(gray);
  extractor_.extract(image_pyramid, frame.keypoints, frame.descriptors, cv::Rect(), n_features);

  std::vector<cv::Point2f> distorted(frame.keypoints.size());
  for (size_t i = 0; i < frame.keypoints.size(); ++i) distorted[i] = frame.keypoints[i].pt;
  frame.points = camera_.undistort(distorted);
  frame.colours.resize(distorted.size());
  for (size_t i = 0; i < distorted.size(); ++i) {
    const cv::Point p(cvRound(distorted[i].x), cvRound(distorted[i].y));
    if (bgr.channels() == 3)
      frame.colours[i] = bgr.at<cv::Vec3b>(p);
    else
      frame.colours[i] = cv::Vec3b::all(gray.at<uint8_t>(p));
  }
  if (!depth_m.empty()) {
    frame.depth.resize(distorted.size());
    for (size_t i = 0; i < distorted.size(); ++i)
      frame.depth[i] = depth_m.at<float>(cvRound(distorted[i].y), cvRound(distorted[i].x));
  }
  frame.finalizeFeatures(undistorted_bounds_);
  return frame;
}

}  // namespace vslam
