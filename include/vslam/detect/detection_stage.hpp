#pragma once
// What Tracking needs from the detector, built from the configuration in one
// call: the YOLO network on its own thread, when to run it (every N-th frame,
// on keyframes, or auto), the boxes carried to the frames it did not see, and
// the ids of the dynamic classes for the keypoint filter.
//
// Per frame, on Tracking's thread:
//   stage.submitAhead(i + 1, next_image);                  // Frames mode: only on its turn
//   boxes = stage.boxesFor(own_features_of_i);              // after the frame's own ORB
//   ... keypoint filter with `boxes`, track ...
//   stage.afterTrack(own_features_of_i, image_i, made_keyframe);  // keyframes / auto submit here
#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/detect/async_detector.hpp"
#include "vslam/detect/box_carrier.hpp"
#include "vslam/detect/detector.hpp"

namespace vslam {

// Share of wall time the network may keep its thread busy in auto mode: it
// rests three times as long as it last ran, so on 2 cores it leaves Tracking
// and Local Mapping most of the machine (docs/BENCHMARKS.md, issue 15).
constexpr double kAutoDetectionDuty = 0.25;

// How the boxes of a run came about, for the report.
struct DetectionScheduleStats {
  int network_frames = 0;   // frames the network ran on and whose result was used
  int fresh_frames = 0;     // frames whose boxes came from their own detection
  int carried_frames = 0;   // frames whose boxes were carried (age > 0) or empty
  std::vector<int> ages;    // age of every box handed to the filter
  int expired = 0, unmoved = 0;
  // Every N-th frame with N > 1: on each detected frame, per fresh detection the
  // best IoU with a carried box of its class (0 when none): how well carrying held.
  std::vector<double> carried_iou;
};

class DetectionStage {
 public:
  // Locates and loads the model, checks its weights and the dynamic class
  // names; throws InputError for any of them. With a `timer`, each frame's
  // network time is recorded as stage "detect" (on the detection thread).
  // `deterministic`: keyframes/auto results are waited for at the next frame
  // (and auto behaves as keyframes), so a run does not depend on timing.
  DetectionStage(const DetectorParams& params, StageTimer* timer = nullptr, bool deterministic = false);
  // Gives OpenCV back the thread count it had before (params.dnn_threads).
  ~DetectionStage();
  DetectionStage(const DetectionStage&) = delete;
  DetectionStage& operator=(const DetectionStage&) = delete;

  // Frames mode: starts detection of the frame `boxesFor` gets next when the
  // network is to see it. Does nothing otherwise or when already submitted.
  void submitAhead(int frame_index, const cv::Mat& bgr);
  // The boxes for this frame (`frame` holds its own keypoints, before the
  // filter): its own detections when it is a Frames-mode turn (waiting for
  // them), else the carried ones, replaced by any detection that has finished.
  // `bgr` is the frame's image, detected now when its turn was not submitted ahead.
  std::vector<Detection> boxesFor(const FeatureSnapshot& frame, const cv::Mat& bgr);
  // After Tracking: keyframes mode detects each new keyframe, auto mode the
  // frame in hand when the network has rested long enough. Never waits.
  void afterTrack(const FeatureSnapshot& frame, const cv::Mat& bgr, bool made_keyframe);

  // The params in force: detect_every is always set, resolved by detectEvery().
  const DetectorParams& params() const { return params_; }
  const DetectEvery& detectEvery() const { return *params_.detect_every; }
  const ModelFiles& files() const { return detector_->files(); }
  cv::Size inputSize() const { return detector_->inputSize(); }
  bool placeholderWeights() const { return detector_->placeholderWeights(); }
  const std::vector<std::string>& classNames() const { return detector_->classNames(); }
  const std::vector<int>& dynamicClassIds() const { return dynamic_class_ids_; }
  const std::vector<int>& movingClassIds() const { return moving_class_ids_; }
  double totalWaitMs() const { return async_->totalWaitMs(); }  // Tracking's time blocked on detection
  DetectionScheduleStats scheduleStats() const;

 private:
  bool isTurn(int frame_index) const;  // Frames mode: the network sees this frame
  void submitWithSnapshot(const FeatureSnapshot& frame, const cv::Mat& bgr);

  DetectorParams params_;
  bool deterministic_;
  std::unique_ptr<YoloDetector> detector_;
  std::vector<int> dynamic_class_ids_;
  std::vector<int> moving_class_ids_;
  BoxCarrier carrier_;
  std::map<int, FeatureSnapshot> submitted_;  // keyframes/auto: frames sent to the network, by index
  DetectionScheduleStats stats_;
  int opencv_threads_before_ = -1;  // -1: the thread count was left alone
  std::unique_ptr<AsyncDetector> async_;  // last: its thread uses detector_, so it stops first
};

// nullptr when params.model is "none": Tracking then behaves as plain ORB-SLAM.
std::unique_ptr<DetectionStage> makeDetectionStage(const DetectorParams& params, StageTimer* timer = nullptr,
                                                   bool deterministic = false);

}  // namespace vslam
