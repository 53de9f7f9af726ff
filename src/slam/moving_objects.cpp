#include "vslam/slam/moving_objects.hpp"

#include <algorithm>
#include <map>

#include "vslam/map/keyframe.hpp"
#include "vslam/map/map_point.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {

void labelMovableKeypoints(const std::vector<Detection>& detections, const std::vector<int>& movable_class_ids,
                           Frame& frame) {
  if (movable_class_ids.empty()) return;
  std::vector<const Detection*> movable;
  for (const Detection& detection : detections)
    for (int id : movable_class_ids)
      if (detection.class_id == id) movable.push_back(&detection);
  if (movable.empty()) return;
  frame.labels.resize(frame.size());
  for (size_t i = 0; i < frame.size(); ++i) {
    // Boxes are in the detector's (distorted) image, as the keypoints are.
    const cv::Point2f& p = frame.keypoints[i].pt;
    const Detection* smallest = nullptr;
    for (const Detection* detection : movable) {
      const cv::Rect2f& box = detection->box;
      if (p.x < box.x || p.y < box.y || p.x >= box.x + box.width || p.y >= box.y + box.height) continue;
      if (!smallest || box.area() < smallest->box.area()) smallest = detection;
    }
    if (!smallest) continue;
    frame.labels[i] = {smallest->class_id, smallest->id, ObjectMotion::Unchecked};
  }
}

void releaseBackgroundByDepth(const std::vector<Detection>& detections, Frame& frame) {
  if (frame.labels.size() != frame.size() || !frame.hasDepthImage()) return;
  // Only keypoints labelMovableKeypoints put in a movable box, and with depth.
  auto inBoxWithDepth = [&frame](size_t i, int detection_id) {
    const FeatureLabel& label = frame.labels[i];
    return label.detection_id == detection_id && label.motion == ObjectMotion::Unchecked && frame.hasDepth(i);
  };
  if (std::none_of(frame.labels.begin(), frame.labels.end(),
                   [](const FeatureLabel& label) { return label.motion == ObjectMotion::Unchecked; }))
    return;  // no movable box in this frame
  std::vector<float> core_depths;
  for (const Detection& detection : detections) {
    const cv::Rect2f& box = detection.box;
    const float margin_x = 0.5f * (1.f - kObjectCoreFraction) * box.width;
    const float margin_y = 0.5f * (1.f - kObjectCoreFraction) * box.height;
    const cv::Rect2f core(box.x + margin_x, box.y + margin_y, kObjectCoreFraction * box.width,
                          kObjectCoreFraction * box.height);
    core_depths.clear();
    for (size_t i = 0; i < frame.size(); ++i)
      if (inBoxWithDepth(i, detection.id) && core.contains(frame.keypoints[i].pt)) core_depths.push_back(frame.depth[i]);
    if (static_cast<int>(core_depths.size()) < kMinObjectCoreDepths) continue;
    auto middle = core_depths.begin() + core_depths.size() / 2;
    std::nth_element(core_depths.begin(), middle, core_depths.end());
    const double background_from = *middle * (1.0 + kBackgroundDepthRatio) + kBackgroundDepthMargin;
    for (size_t i = 0; i < frame.size(); ++i)
      if (inBoxWithDepth(i, detection.id) && frame.depth[i] > background_from)
        frame.labels[i] = FeatureLabel();  // not the object's: no class either
  }
}

std::vector<ObjectMotionVerdict> checkObjectMotion(Frame& frame, std::vector<bool>* consistent) {
  std::map<int, ObjectMotionVerdict> by_box;
  std::map<int, int> parked_evidence;  // per box: consistent points old enough
  if (consistent) consistent->assign(frame.size(), false);
  if (frame.labels.size() != frame.size()) return {};
  const ProjectionModel model(*frame.camera, frame.camera->bf);
  for (size_t i = 0; i < frame.size(); ++i) {
    const FeatureLabel& label = frame.labels[i];
    if (label.motion != ObjectMotion::Unchecked) continue;
    ObjectMotionVerdict& verdict = by_box[label.detection_id];
    verdict.detection_id = label.detection_id;
    verdict.class_id = label.class_id;
    const MapPoint* point = frame.map_points[i];
    if (!point || point->isBad()) continue;
    ++verdict.matched;
    const double u_right = frame.rightCoordinate(i);
    const ReprojectionCheck check = checkReprojection(model, frame.T_cw, point->position(), frame.point(i), u_right,
                                                      frame.pyramid->inv_sigma2[frame.level(i)]);
    if (check.depth_positive && check.chi2 <= chi2Bound95(u_right)) {
      ++verdict.consistent;
      if (consistent) (*consistent)[i] = true;
      // Points without a reference keyframe (hand-built ones) count as old.
      const KeyFrame* made_in = point->reference();
      if (!made_in || frame.id - made_in->frameId() >= kMotionCheckMinPointAgeFrames) {
        ++verdict.evidence;
        ++parked_evidence[label.detection_id];
      }
    } else {
      ++verdict.evidence;
    }
  }
  std::vector<ObjectMotionVerdict> verdicts;
  for (auto& [box, verdict] : by_box) {
    if (verdict.evidence >= kMotionCheckMinMatches)
      verdict.motion = parked_evidence[box] >= kMotionCheckParkedShare * verdict.evidence ? ObjectMotion::Parked
                                                                                           : ObjectMotion::Moving;
    verdicts.push_back(verdict);
  }
  for (size_t i = 0; i < frame.size(); ++i) {
    FeatureLabel& label = frame.labels[i];
    if (label.motion != ObjectMotion::Unchecked) continue;
    label.motion = by_box[label.detection_id].motion;
  }
  return verdicts;
}

}  // namespace vslam
