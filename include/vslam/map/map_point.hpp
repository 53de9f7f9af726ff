#pragma once
// A 3D landmark: position, the keyframes that observe it (and which keypoint),
// its most distinctive descriptor, viewing direction, scale-invariance range,
// and the object class most of its observations carry.
//
// Not thread-safe by itself: every access goes through Map's lock (see map.hpp).
#include <map>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"
#include "vslam/map/id_order.hpp"

namespace vslam {

class KeyFrame;
struct ScalePyramid;

class MapPoint {
 public:
  MapPoint(long id, const Vec3& position_w, KeyFrame* reference, long first_keyframe_id);

  long id() const { return id_; }
  const Vec3& position() const { return position_w_; }
  void setPosition(const Vec3& p) { position_w_ = p; }
  bool isBad() const { return bad_; }

  // Observations: keyframe -> keypoint index.
  const KeyFrameMap<int>& observations() const { return observations_; }
  int observationCount() const { return static_cast<int>(observations_.size()); }
  // Observations as ORB-SLAM2 counts them for its survival rules: one with
  // depth (RGB-D) counts twice, as a stereo pair fixes the point in 3D on its
  // own. Equals observationCount() in monocular runs.
  int observationWeight() const { return observation_weight_; }
  void addObservation(KeyFrame* keyframe, int keypoint);
  // Removes one observation; the point turns bad when a weight below 2 remains,
  // or, once it has passed its probation (confirm()), below the map's minimum
  // (the paper: a map point lives only while seen in at least 3 keyframes).
  void eraseObservation(KeyFrame* keyframe);
  // Called by Local Mapping when the point survives its probation.
  void confirm(int min_observations) { confirmed_min_observations_ = min_observations; }
  bool confirmed() const { return confirmed_min_observations_ > 0; }
  int keypointIn(const KeyFrame* keyframe) const;  // -1 if not observed there
  KeyFrame* reference() const { return reference_; }
  long firstKeyframeId() const { return first_keyframe_id_; }

  // Marks bad and detaches from every keyframe.
  void setBad();
  // Moves every observation to `other` (duplicate fusion), then turns bad.
  void replaceWith(MapPoint* other);
  MapPoint* replacement() const { return replaced_by_; }

  // Derived data, refreshed after observations change.
  void updateDescriptor();
  void updateNormalAndDepth(const ScalePyramid& pyramid);
  void updateClass();
  const cv::Mat& descriptor() const { return descriptor_; }
  const Vec3& normal() const { return normal_; }
  double minDistance() const { return 0.8 * min_distance_; }
  double maxDistance() const { return 1.2 * max_distance_; }
  int predictLevel(double distance, const ScalePyramid& pyramid) const;

  // Tracking statistics (ORB-SLAM's found/visible ratio for culling).
  void increaseVisible(int n = 1) { visible_ += n; }
  void increaseFound(int n = 1) { found_ += n; }
  double foundRatio() const { return visible_ > 0 ? static_cast<double>(found_) / visible_ : 0.0; }

  int classId() const { return class_id_; }
  double classConfidence() const { return class_confidence_; }  // share of observations voting for class_id
  cv::Vec3b colour() const { return colour_; }
  void setColour(const cv::Vec3b& bgr) { colour_ = bgr; }

  // Everything about the point that is not its position or observations, as a
  // saved map stores it (map_io/): restoring it gives the point back exactly,
  // without recomputing it from keyframes that may have been culled since.
  struct SavedState {
    cv::Mat descriptor;
    Vec3 normal = Vec3::Zero();
    double min_distance = 0, max_distance = 0;  // unscaled (minDistance() is 0.8x)
    int visible = 1, found = 1;
    int class_id = -1;
    double class_confidence = 0.0;
    cv::Vec3b colour{128, 128, 128};
    int confirmed_min_observations = 0;
  };
  SavedState savedState() const;
  void restoreState(const SavedState& state);

  // Per-frame scratch used by Tracking to avoid duplicate work; only Tracking touches these.
  long last_frame_seen = -1;
  long track_reference_frame = -1;
  bool track_in_view = false;
  double track_proj_x = 0, track_proj_y = 0, track_view_cos = 0;
  int track_level = 0;
  // Scratch for Local Mapping and BA.
  long fuse_candidate_for_kf = -1;
  long ba_local_for_kf = -1;

 private:
  long id_;
  long first_keyframe_id_;
  Vec3 position_w_;
  KeyFrameMap<int> observations_;
  int observation_weight_ = 0;
  KeyFrame* reference_;
  cv::Mat descriptor_;
  Vec3 normal_ = Vec3::Zero();
  double min_distance_ = 0, max_distance_ = 0;
  int visible_ = 1, found_ = 1;
  int class_id_ = -1;
  double class_confidence_ = 0.0;
  cv::Vec3b colour_{128, 128, 128};
  bool bad_ = false;
  int confirmed_min_observations_ = 0;  // 0 while on probation
  MapPoint* replaced_by_ = nullptr;
};

}  // namespace vslam
