#include "vslam/detect/detection_stage.hpp"

#include <algorithm>
#include <iterator>
#include <optional>
#include <utility>

#include <opencv2/core/utility.hpp>

#include "vslam/detect/model_locator.hpp"

namespace vslam {
namespace {

BoxCarrierParams carrierParams(const DetectorParams& params) {
  BoxCarrierParams carrier;
  carrier.max_age = params.max_box_age;
  return carrier;
}

// The stage keeps one rate, the one in force: unset in the config, it is resolved here.
DetectorParams withRateResolved(DetectorParams params) {
  params.detect_every = vslam::detectEvery(params);
  return params;
}

}  // namespace

DetectionStage::DetectionStage(const DetectorParams& params, StageTimer* timer, bool deterministic)
    : params_(withRateResolved(params)),
      deterministic_(deterministic),
      detector_(std::make_unique<YoloDetector>(params, locateModel(params))),
      carrier_(carrierParams(params)) {
  dynamic_class_ids_ = classIdsOf(params_.dynamic_classes, detector_->classNames(), detector_->files().names);
  moving_class_ids_ = classIdsOf(params_.moving_classes, detector_->classNames(), detector_->files().names);
  // OpenCV has one thread pool for the process (TBB in Debian's build): the
  // budget holds for the network and for Tracking's resizes and blurs alike,
  // until this stage is gone.
  if (params_.dnn_threads > 0) {
    opencv_threads_before_ = cv::getNumThreads();
    cv::setNumThreads(params_.dnn_threads);
  }
  YoloDetector* detector = detector_.get();
  async_ = std::make_unique<AsyncDetector>([detector, timer](const cv::Mat& bgr) {
    std::vector<Detection> detections = detector->detect(bgr);
    if (timer) timer->record("detect", detector->lastMs());
    return detections;
  });
}

DetectionStage::~DetectionStage() {
  async_.reset();  // the network's thread stops before the budget is lifted
  if (opencv_threads_before_ >= 0) cv::setNumThreads(opencv_threads_before_);
}

bool DetectionStage::isTurn(int frame_index) const {
  return detectEvery().mode == DetectEvery::Mode::Frames && frame_index % detectEvery().frames == 0;
}

void DetectionStage::submitAhead(int frame_index, const cv::Mat& bgr) {
  if (!isTurn(frame_index) || async_->pending(frame_index)) return;
  async_->submit(frame_index, bgr);
}

void DetectionStage::submitWithSnapshot(const FeatureSnapshot& frame, const cv::Mat& bgr) {
  if (async_->pending(frame.frame_index)) return;
  async_->submit(frame.frame_index, bgr);
  submitted_[frame.frame_index] = frame;
}

std::vector<Detection> DetectionStage::boxesFor(const FeatureSnapshot& frame, const cv::Mat& bgr) {
  if (detectEvery().mode == DetectEvery::Mode::Frames) {
    if (isTurn(frame.frame_index)) {
      if (!async_->pending(frame.frame_index)) async_->submit(frame.frame_index, bgr);
      const std::vector<Detection> detections = async_->wait(frame.frame_index);
      if (detectEvery().frames > 1) {
        // Carry the old boxes here too, only to measure them against the new ones.
        carrier_.advance(frame);
        for (const Detection& fresh : detections) {
          double best = 0.0;
          for (const CarriedBox& carried : carrier_.boxes())
            if (carried.detection.class_id == fresh.class_id)
              best = std::max(best, static_cast<double>(iou(carried.detection.box, fresh.box)));
          stats_.carried_iou.push_back(best);
        }
      } else {
        carrier_.clear();  // every frame is detected: nothing to carry
        carrier_.advance(frame);
      }
      carrier_.replace(detections, frame);
      ++stats_.network_frames;
    } else {
      carrier_.advance(frame);
    }
  } else {
    carrier_.advance(frame);
    std::optional<std::pair<int, std::vector<Detection>>> finished;
    if (deterministic_) {
      // The oldest pending result, waited for: the same boxes whatever the timing.
      if (!submitted_.empty()) {
        const int index = submitted_.begin()->first;
        finished = std::make_pair(index, async_->wait(index));
      }
    } else {
      finished = async_->takeNewest();
    }
    if (finished) {
      const auto detected = submitted_.find(finished->first);
      if (detected != submitted_.end()) {
        carrier_.replace(finished->second, detected->second);
        ++stats_.network_frames;
      }
      submitted_.erase(submitted_.begin(), detected == submitted_.end() ? detected : std::next(detected));
    }
  }
  bool fresh = false;
  for (const CarriedBox& box : carrier_.boxes()) {
    stats_.ages.push_back(box.age);
    fresh = fresh || box.age == 0;
  }
  ++(fresh ? stats_.fresh_frames : stats_.carried_frames);
  return carrier_.detections();
}

void DetectionStage::afterTrack(const FeatureSnapshot& frame, const cv::Mat& bgr, bool made_keyframe) {
  const DetectEvery::Mode mode = detectEvery().mode;
  if (mode == DetectEvery::Mode::Frames) return;
  if (mode == DetectEvery::Mode::KeyFrames || deterministic_) {
    if (made_keyframe) submitWithSnapshot(frame, bgr);
    return;
  }
  // Auto: the newest frame, once the network has rested (1 / duty - 1) times
  // its last run, so it keeps its thread busy at most kAutoDetectionDuty of the time.
  if (!async_->idle() || (!submitted_.empty() && async_->pending(submitted_.rbegin()->first))) return;
  const auto rested = std::chrono::steady_clock::now() - async_->lastFinish();
  const double rest_needed_ms = async_->lastRunMs() * (1.0 / kAutoDetectionDuty - 1.0);
  if (std::chrono::duration<double, std::milli>(rested).count() >= rest_needed_ms) submitWithSnapshot(frame, bgr);
}

DetectionScheduleStats DetectionStage::scheduleStats() const {
  DetectionScheduleStats stats = stats_;
  stats.expired = carrier_.expired();
  stats.unmoved = carrier_.unmoved();
  return stats;
}

std::unique_ptr<DetectionStage> makeDetectionStage(const DetectorParams& params, StageTimer* timer,
                                                   bool deterministic) {
  if (params.model == "none") return nullptr;
  return std::make_unique<DetectionStage>(params, timer, deterministic);
}

}  // namespace vslam
