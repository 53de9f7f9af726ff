#pragma once
// Moving objects told from parked ones. Keypoints in boxes of the classes
// given by --moving-classes are kept out of the camera's pose at first; once
// the pose is known from the static scene, each box's matched map points are
// checked against it: where they agree (within the 95 % chi-square bound,
// with depth where there is depth) the object is parked and its points count
// again; where most do not, the instance is moving, and its keypoints and map
// points are kept out of tracking and mapping.
#include <vector>

#include "vslam/detect/detector.hpp"
#include "vslam/map/frame.hpp"

namespace vslam {

// A box needs this many matched map points as evidence before it is judged.
constexpr int kMotionCheckMinMatches = 5;
// Parked when at least this share of the evidence agrees with the pose.
constexpr double kMotionCheckParkedShare = 0.5;
// A point that agrees with the pose is evidence of a parked object only when
// it was made at least this many frames ago: a walking person's points made a
// frame or two ago have not had time to move away from where they were made.
// (A point that disagrees is evidence of motion at any age.)
constexpr long kMotionCheckMinPointAgeFrames = 10;

// Marks the keypoints inside boxes of `movable_class_ids` as Unchecked,
// labelled with that box (the smallest one, where boxes overlap).
void labelMovableKeypoints(const std::vector<Detection>& detections, const std::vector<int>& movable_class_ids,
                           Frame& frame);

// With depth, a movable box's keypoints well behind the object are the
// static scene seen around it, not the object: they are given back to the
// static scene (NotMovable, no class) before the box is judged, so that a person's box
// is judged by the person's own points rather than by the wall behind them.
// The object's depth is the median depth of the box's keypoints in its central
// part; "well behind" is beyond that by kBackgroundDepthMargin plus
// kBackgroundDepthRatio of it. Keypoints without depth keep their label.
constexpr double kBackgroundDepthMargin = 0.3;  // metres
constexpr double kBackgroundDepthRatio = 0.15;
// The central part: the middle half of the box's width and height.
constexpr float kObjectCoreFraction = 0.5f;
// Fewer keypoints with depth in the central part than this: the box is left alone.
constexpr int kMinObjectCoreDepths = 5;
void releaseBackgroundByDepth(const std::vector<Detection>& detections, Frame& frame);

struct ObjectMotionVerdict {
  int detection_id = -1;
  int class_id = -1;
  int matched = 0;     // keypoints of the box matched to map points
  int consistent = 0;  // of those, within the chi-square bound under frame.T_cw
  int evidence = 0;    // the inconsistent ones, and the consistent ones old enough
  ObjectMotion motion = ObjectMotion::Unchecked;
};

// Judges every box with Unchecked keypoints under frame.T_cw (the pose from
// the static scene) and relabels its keypoints Parked or Moving; a box with
// less evidence than kMotionCheckMinMatches stays Unchecked. With
// `consistent`, also says per keypoint whether its match agrees with the
// pose. Reads frame.map_points' positions: call with the map locked.
std::vector<ObjectMotionVerdict> checkObjectMotion(Frame& frame, std::vector<bool>* consistent = nullptr);

}  // namespace vslam
