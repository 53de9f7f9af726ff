#pragma once
// A camera frame after feature extraction: keypoints (as detected, distorted),
// their undistorted positions, descriptors, object labels, and — once tracked —
// a pose and the map points its keypoints were matched to.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"
#include "vslam/feature/matcher.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {

class MapPoint;

// Pyramid geometry shared by every frame of a run (from the ORB extractor).
struct ScalePyramid {
  int levels = 1;
  double scale_factor = 1.2;
  std::vector<double> scale;           // scale_factor^level
  std::vector<double> sigma2;          // scale^2
  std::vector<double> inv_sigma2;      // 1 / scale^2
  double logScaleFactor() const;
};

// Whether a keypoint lies on something that may move (a box of a class given
// by --moving-classes), and what its frame's motion check found.
enum class ObjectMotion : uint8_t {
  NotMovable,  // outside every such box: static scene
  Unchecked,   // in such a box, not (yet) enough evidence: kept out of the pose
  Parked,      // its box's matched points agree with the pose from the static scene
  Moving,      // they do not: kept out of tracking and mapping
};

// Per-keypoint semantic label from the keypoint filter (the paper's Algorithm 1).
struct FeatureLabel {
  int class_id = -1;      // COCO class, -1 = not inside a detection box
  int detection_id = -1;  // index of the detection in its frame, -1 = none
  ObjectMotion motion = ObjectMotion::NotMovable;
};

// A keypoint that may constrain the camera's pose.
inline bool drivesPose(const FeatureLabel& label) {
  return label.motion == ObjectMotion::NotMovable || label.motion == ObjectMotion::Parked;
}
inline bool onMovingObject(const FeatureLabel& label) { return label.motion == ObjectMotion::Moving; }

struct Frame {
  long id = -1;       // running frame number in the run
  int index = -1;     // position in the sequence
  double timestamp = 0.0;
  const PinholeCamera* camera = nullptr;
  const ScalePyramid* pyramid = nullptr;

  std::vector<cv::KeyPoint> keypoints;  // as detected (distorted pixels)
  std::vector<cv::Point2f> points;      // undistorted pixels
  cv::Mat descriptors;                  // N x 32, CV_8U
  std::vector<FeatureLabel> labels;     // one per keypoint
  std::vector<cv::Vec3b> colours;       // BGR at each keypoint
  // RGB-D: per keypoint the depth (metres) and the right-image coordinate
  // u_R = u - bf / depth of a virtual stereo pair (u_R may be negative).
  // depth < 0 where the depth image has no valid reading: a monocular
  // keypoint. Both empty for a frame without a depth image.
  std::vector<float> depth;
  std::vector<float> u_right;
  FeatureGrid grid;                     // spatial index of `points`

  // Tracking state.
  bool has_pose = false;
  SE3 T_cw;
  std::vector<MapPoint*> map_points;  // per keypoint, nullptr = unmatched
  std::vector<bool> outlier;          // per keypoint, set by pose optimisation

  size_t size() const { return keypoints.size(); }
  int level(size_t i) const { return keypoints[i].octave; }
  Vec3 cameraCentre() const { return -(T_cw.R.transpose() * T_cw.t); }
  // Prepares matching state after keypoints/points are filled; `bounds` is
  // the undistorted image's extent (undistortedImageBounds).
  void finalizeFeatures(const cv::Rect2f& bounds);
  FeatureView view() const { return {keypoints, points, descriptors}; }
  Vec2 point(size_t i) const { return Vec2(points[i].x, points[i].y); }
  bool hasDepth(size_t i) const { return i < depth.size() && depth[i] > 0; }
  // The optimisers' right coordinate: u_R, or kNoRightCoordinate for a monocular keypoint.
  double rightCoordinate(size_t i) const { return hasDepth(i) ? u_right[i] : kNoRightCoordinate; }
  bool hasDepthImage() const { return !depth.empty(); }
  int trackedCount() const;  // matched, non-outlier keypoints
};

}  // namespace vslam
