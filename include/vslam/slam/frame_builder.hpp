#pragma once
// Turns an image into a Frame: ORB extraction on one pyramid, the paper's
// keypoint filter with the frame's detections, undistortion, colours, depth.
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/detect/box_carrier.hpp"
#include "vslam/detect/detector.hpp"
#include "vslam/detect/keypoint_filter.hpp"
#include "vslam/feature/orb_extractor.hpp"
#include "vslam/map/frame.hpp"

namespace vslam {

// What the keypoint filter did to one frame, for the report.
struct FrameFilterResult {
  KeypointFilterStats stats;
  double ms = 0.0;  // wall time of the filter (ORB in the boxes included)
  // detector.box_filter "reuse": box winners that were the frame's own keypoints
  // already (the duplicates the paper's filter extracts again and drops).
  int frame_keypoints_reused = 0;
};

// A frame's own ORB features, before the keypoint filter: everything that
// follows from the image alone, so it can be computed ahead of Tracking
// (ExtractionAhead).
struct ExtractedFeatures {
  int n_features = 0;  // the count asked for, resolved (never < 0)
  cv::Mat gray;
  ImagePyramid pyramid;
  OrbCorners corners;  // every FAST corner considered: only for detector.box_filter "reuse"
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

// The boxes for a frame, given its own keypoints (before the filter).
using BoxSource = std::function<std::vector<Detection>(const FeatureSnapshot& own_features)>;

class FrameBuilder {
 public:
  // `dynamic_class_ids`: classes whose boxes remove keypoints (DetectionStage::dynamicClassIds()).
  // Keypoints in boxes of `dynamic_class_ids` are removed; those in boxes of
  // `moving_class_ids` are kept and labelled for the motion check.
  FrameBuilder(const Config& config, const PinholeCamera& camera, std::vector<int> dynamic_class_ids = {},
               std::vector<int> moving_class_ids = {});

  // `bgr` is the colour image (or grey, CV_8UC1); `depth_m` is CV_32F metres,
  // registered to it and of its size, or empty (no depth: a monocular frame;
  // a monocular config, config.sensor, ignores it); `n_features` < 0 means the configured number. With `detections`,
  // the keypoint filter (Algorithm 1) runs on the frame's own pyramid and its
  // outcome goes to `filter` (when given); without, no keypoint is labelled.
  Frame build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m = cv::Mat(),
              int n_features = -1, const std::vector<Detection>* detections = nullptr,
              FrameFilterResult* filter = nullptr) const;
  // The same with boxes that depend on the frame's own keypoints (carried
  // boxes); `boxes` empty: no filter. `own_features` (when given) receives the
  // frame's own keypoints and descriptors.
  Frame build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m, int n_features,
              const BoxSource& boxes, FrameFilterResult* filter, FeatureSnapshot* own_features) const;
  // The same from features extractFeatures() computed for this image.
  Frame build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m,
              ExtractedFeatures features, const BoxSource& boxes, FrameFilterResult* filter,
              FeatureSnapshot* own_features) const;

  // The image's own ORB features (`n_features` < 0: the configured number). A
  // pure function of its arguments, safe to call from any thread.
  ExtractedFeatures extractFeatures(const cv::Mat& bgr, int n_features = -1) const;
  int resolvedFeatureCount(int n_features) const { return n_features < 0 ? config_.orb.n_features : n_features; }

  const ScalePyramid& pyramid() const { return pyramid_; }
  const PinholeCamera& camera() const { return camera_; }
  const OrbExtractor& extractor() const { return extractor_; }

 private:
  // Depth and u_R per keypoint (after `frame.points`) from a depth image
  // (CV_32F metres) registered to the colour image.
  void sampleDepth(const cv::Mat& depth_m, Frame& frame) const;

  Config config_;
  PinholeCamera camera_;
  OrbExtractor extractor_;
  ScalePyramid pyramid_;
  cv::Rect2f undistorted_bounds_;
  std::vector<int> dynamic_class_ids_;
  std::vector<int> moving_class_ids_;
};

}  // namespace vslam
