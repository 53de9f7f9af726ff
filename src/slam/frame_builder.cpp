#include "vslam/slam/frame_builder.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "vslam/slam/moving_objects.hpp"

namespace vslam {

FrameBuilder::FrameBuilder(const Config& config, const PinholeCamera& camera, std::vector<int> dynamic_class_ids,
                           std::vector<int> moving_class_ids)
    : config_(config),
      camera_(camera),
      extractor_(config.orb),
      dynamic_class_ids_(std::move(dynamic_class_ids)),
      moving_class_ids_(std::move(moving_class_ids)) {
  pyramid_.levels = extractor_.levels();
  pyramid_.scale_factor = config.orb.scale_factor;
  pyramid_.scale = extractor_.scaleFactors();
  pyramid_.sigma2 = extractor_.levelSigma2();
  pyramid_.inv_sigma2 = extractor_.invLevelSigma2();
  undistorted_bounds_ = undistortedImageBounds(camera_);
}

void FrameBuilder::sampleDepth(const cv::Mat& depth_m, Frame& frame) const {
  const size_t n = frame.points.size();
  frame.depth.assign(n, -1.0f);
  frame.u_right.assign(n, 0.0f);  // read only where depth > 0
  const double bf = camera_.bf;
  for (size_t i = 0; i < n; ++i) {
    // The depth image is registered to the colour camera's pinhole model (the
    // driver reprojects depth without the lens distortion), so the keypoint's
    // depth is read at its undistorted position. On fr1_xyz that halves the
    // scale error and takes keyframe ATE from ~1.0 to ~0.77 cm against
    // reading at the detected pixel (docs/BENCHMARKS.md).
    const int row = cvRound(frame.points[i].y), col = cvRound(frame.points[i].x);
    if (row < 0 || col < 0 || row >= depth_m.rows || col >= depth_m.cols) continue;
    const float d = depth_m.at<float>(row, col);
    if (!(d > 0.0f) || !std::isfinite(d) || d > camera_.max_depth_m) continue;  // no reading: monocular
    const double u_right = rightCoordinateFromDepth(frame.points[i].x, d, bf);
    // A real stereo pair would not see the point in its right image (u_R < 0),
    // so it stays monocular, as in ORB-SLAM2. Measured on fr1_xyz: taking
    // these close left-border points as stereo too gave keyframe ATE
    // 1.00-1.16 cm and a Sim(3) scale of 0.985-0.993, against 0.72-0.85 cm
    // and 0.998-1.002 without them (docs/RGBD.md).
    if (u_right < 0) continue;
    frame.depth[i] = d;
    frame.u_right[i] = static_cast<float>(u_right);
  }
}

Frame FrameBuilder::build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m,
                          int n_features, const std::vector<Detection>* detections,
                          FrameFilterResult* filter) const {
  BoxSource boxes;
  if (detections) boxes = [detections](const FeatureSnapshot&) { return *detections; };
  return build(id, index, timestamp, bgr, depth_m, n_features, boxes, filter, nullptr);
}

ExtractedFeatures FrameBuilder::extractFeatures(const cv::Mat& bgr, int n_features) const {
  ExtractedFeatures features;
  features.n_features = resolvedFeatureCount(n_features);
  if (bgr.channels() == 3)
    cv::cvtColor(bgr, features.gray, cv::COLOR_BGR2GRAY);
  else
    features.gray = bgr;
  features.pyramid = extractor_.buildPyramid(features.gray);
  const bool keep_corners = config_.detector.box_filter == "reuse";
  extractor_.extract(features.pyramid, features.keypoints, features.descriptors, cv::Rect(), features.n_features,
                     keep_corners ? &features.corners : nullptr);
  return features;
}

Frame FrameBuilder::build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m,
                          int n_features, const BoxSource& boxes, FrameFilterResult* filter,
                          FeatureSnapshot* own_features) const {
  return build(id, index, timestamp, bgr, depth_m, extractFeatures(bgr, n_features), boxes, filter, own_features);
}

Frame FrameBuilder::build(long id, int index, double timestamp, const cv::Mat& bgr, const cv::Mat& depth_m,
                          ExtractedFeatures features, const BoxSource& boxes, FrameFilterResult* filter,
                          FeatureSnapshot* own_features) const {
  Frame frame;
  frame.id = id;
  frame.index = index;
  frame.timestamp = timestamp;
  frame.camera = &camera_;
  frame.pyramid = &pyramid_;

  const cv::Mat& gray = features.gray;
  const ImagePyramid& image_pyramid = features.pyramid;
  const bool reuse_corners = boxes && config_.detector.box_filter == "reuse";
  OrbCorners& corners = features.corners;
  frame.keypoints = std::move(features.keypoints);
  frame.descriptors = std::move(features.descriptors);
  // A copy: the boxes are carried by these after the filter has changed the frame's own.
  const FeatureSnapshot own{index, frame.keypoints, frame.descriptors.clone()};
  if (own_features) *own_features = own;
  std::vector<Detection> detections;
  if (boxes) {
    detections = boxes(own);
    const auto start = std::chrono::steady_clock::now();
    // Per box: the configured count (or the frame's), on the same pyramid, as Algorithm 1 asks.
    const int per_box = featuresPerBox(config_.detector, config_.orb);
    int reused = 0;
    const BoxExtractor label_only = [](const cv::Rect&, std::vector<cv::KeyPoint>&, cv::Mat&) {};
    const BoxExtractor extract_in_box =
        config_.detector.box_filter == "label"
            ? label_only
            : (reuse_corners ? cornerBoxExtractor(extractor_, image_pyramid, corners, per_box, &reused)
                             : orbBoxExtractor(extractor_, image_pyramid, per_box));
    std::vector<KeypointLabel> labels;
    const KeypointFilterStats stats =
        applyKeypointFilter(gray.size(), detections, config_.detector.min_box_px, dynamic_class_ids_, extract_in_box,
                            frame.keypoints, frame.descriptors, labels);
    frame.labels.resize(labels.size());
    for (size_t i = 0; i < labels.size(); ++i) frame.labels[i] = {labels[i].class_id, labels[i].detection_id};
    labelMovableKeypoints(detections, moving_class_ids_, frame);
    if (filter) {
      filter->stats = stats;
      filter->frame_keypoints_reused = reused;
      filter->ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    }
  }

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
  // A monocular run ignores depth even when given one: every keypoint stays monocular.
  if (!depth_m.empty() && config_.sensor == SensorMode::RgbD) {
    if (depth_m.size() != bgr.size() || depth_m.type() != CV_32F)
      throw std::invalid_argument("FrameBuilder: the depth image must be CV_32F and of the colour image's size");
    sampleDepth(depth_m, frame);
    releaseBackgroundByDepth(detections, frame);
  }
  frame.finalizeFeatures(undistorted_bounds_);
  return frame;
}

}  // namespace vslam
