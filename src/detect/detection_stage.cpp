#include "vslam/detect/detection_stage.hpp"

#include "vslam/detect/model_locator.hpp"

namespace vslam {

DetectionStage::DetectionStage(const DetectorParams& params, StageTimer* timer)
    : params_(params), detector_(std::make_unique<YoloDetector>(params, locateModel(params))) {
  dynamic_class_ids_ = classIdsOf(params_.dynamic_classes, detector_->classNames(), detector_->files().names);
  moving_class_ids_ = classIdsOf(params_.moving_classes, detector_->classNames(), detector_->files().names);
  YoloDetector* detector = detector_.get();
  async_ = std::make_unique<AsyncDetector>([detector, timer](const cv::Mat& bgr) {
    std::vector<Detection> detections = detector->detect(bgr);
    if (timer) timer->record("detect", detector->lastMs());
    return detections;
  });
}

std::unique_ptr<DetectionStage> makeDetectionStage(const DetectorParams& params, StageTimer* timer) {
  if (params.model == "none") return nullptr;
  return std::make_unique<DetectionStage>(params, timer);
}

}  // namespace vslam
