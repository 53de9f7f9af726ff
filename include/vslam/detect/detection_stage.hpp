#pragma once
// What Tracking needs from the detector, built from the configuration in one
// call: the YOLO network on its own thread, a frame ahead, and the ids of the
// dynamic classes for the keypoint filter.
#include <memory>
#include <string>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/detect/async_detector.hpp"
#include "vslam/detect/detector.hpp"

namespace vslam {

class DetectionStage {
 public:
  // Locates and loads the model, checks its weights and the dynamic class
  // names; throws InputError for any of them. With a `timer`, each frame's
  // network time is recorded as stage "detect" (on the detection thread).
  explicit DetectionStage(const DetectorParams& params, StageTimer* timer = nullptr);

  void submit(int frame_index, const cv::Mat& bgr) { async_->submit(frame_index, bgr); }
  std::vector<Detection> wait(int frame_index) { return async_->wait(frame_index); }

  const DetectorParams& params() const { return params_; }
  const ModelFiles& files() const { return detector_->files(); }
  const std::vector<std::string>& classNames() const { return detector_->classNames(); }
  const std::vector<int>& dynamicClassIds() const { return dynamic_class_ids_; }
  const std::vector<int>& movingClassIds() const { return moving_class_ids_; }
  double totalWaitMs() const { return async_->totalWaitMs(); }  // Tracking's time blocked on detection

 private:
  DetectorParams params_;
  std::unique_ptr<YoloDetector> detector_;
  std::vector<int> dynamic_class_ids_;
  std::vector<int> moving_class_ids_;
  std::unique_ptr<AsyncDetector> async_;  // last: its thread uses detector_, so it stops first
};

// nullptr when params.model is "none": Tracking then behaves as plain ORB-SLAM.
std::unique_ptr<DetectionStage> makeDetectionStage(const DetectorParams& params, StageTimer* timer = nullptr);

}  // namespace vslam
