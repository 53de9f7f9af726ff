#pragma once
// A keyframe: a frame kept in the map, with its matched map points, its place
// in the covisibility graph and spanning tree, and its bag-of-words vectors.
//
// Not thread-safe by itself: every access goes through Map's lock (see map.hpp).
#include <map>
#include <set>
#include <vector>

#include "vslam/map/frame.hpp"
#include "vslam/map/id_order.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {

class KeyFrame {
 public:
  KeyFrame(long id, const Frame& frame);

  long id() const { return id_; }
  long frameId() const { return frame_id_; }
  int frameIndex() const { return frame_index_; }
  double timestamp() const { return timestamp_; }
  bool isBad() const { return bad_; }

  const SE3& pose() const { return T_cw_; }  // world -> camera
  void setPose(const SE3& T_cw) { T_cw_ = T_cw; }
  Vec3 cameraCentre() const { return -(T_cw_.R.transpose() * T_cw_.t); }

  // Features (copied from the frame, fixed for the keyframe's life).
  const PinholeCamera& camera() const { return *camera_; }
  const ScalePyramid& pyramid() const { return *pyramid_; }
  size_t size() const { return keypoints.size(); }
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Point2f> points;  // undistorted
  cv::Mat descriptors;
  std::vector<FeatureLabel> labels;
  std::vector<cv::Vec3b> colours;
  std::vector<float> depth;    // RGB-D, as Frame::depth
  std::vector<float> u_right;  // RGB-D, as Frame::u_right
  FeatureGrid grid;
  FeatureView view() const { return {keypoints, points, descriptors}; }
  Vec2 point(size_t i) const { return Vec2(points[i].x, points[i].y); }
  bool hasDepth(size_t i) const { return i < depth.size() && depth[i] > 0; }
  double rightCoordinate(size_t i) const { return hasDepth(i) ? u_right[i] : kNoRightCoordinate; }
  // What keypoint i's observation of a map point counts for in the survival
  // rules: 2 with depth (it fixes the point in 3D on its own, as a stereo pair
  // does in ORB-SLAM2), else 1 (MapPoint::observationWeight).
  int observationWeight(size_t i) const { return hasDepth(i) ? 2 : 1; }
  // The keypoint's 3D point from its depth, in world coordinates (hasDepth(i)).
  Vec3 unprojectToWorld(size_t i) const;
  // Bag of words and direct index, set once by Local Mapping when it takes the
  // keyframe (empty without a vocabulary); read-only afterwards.
  BowVector bow;
  FeatureVector bow_features;
  bool hasBow() const { return !bow_features.empty(); }

  // Map point associations, one slot per keypoint.
  MapPoint* mapPoint(size_t i) const { return map_points_[i]; }
  const std::vector<MapPoint*>& mapPoints() const { return map_points_; }
  void setMapPoint(size_t i, MapPoint* point) { map_points_[i] = point; }
  void eraseMapPoint(MapPoint* point);
  // Good map points observed by at least `min_observations` keyframes.
  int trackedMapPoints(int min_observations) const;
  MapPointSet goodMapPoints() const;

  // Covisibility graph: weight = number of shared map points.
  void updateConnections();
  void addConnection(KeyFrame* other, int weight);
  void eraseConnection(KeyFrame* other);
  std::vector<KeyFrame*> bestCovisibles(size_t n) const;
  std::vector<KeyFrame*> covisiblesWithWeight(int min_weight) const;
  const std::vector<KeyFrame*>& orderedCovisibles() const { return ordered_covisibles_; }
  int weight(KeyFrame* other) const;

  // Spanning tree (strongest covisibility parent) and loop edges. Invariant:
  // every live keyframe but the root (id 0) has a live parent, so the tree
  // reaches every keyframe. A keyframe that shares no point with any other when
  // it is linked takes its fallback parent (Tracking's reference keyframe when
  // it was created, or the nearest live ancestor of it) until a real
  // covisibility link replaces it.
  KeyFrame* parent() const { return parent_; }
  void setFallbackParent(KeyFrame* fallback) { fallback_parent_ = fallback; }
  const KeyFrameSet& children() const { return children_; }
  void changeParent(KeyFrame* parent);
  void addLoopEdge(KeyFrame* other) { loop_edges_.insert(other); }
  const KeyFrameSet& loopEdges() const { return loop_edges_; }

  // Removes the keyframe from the graph (reparenting its children) and detaches
  // its points. Does nothing for the root, a keyframe held from erasure, or one
  // without a parent to hand its children to.
  void setBad();
  // Loop Closing holds the keyframes it is working with, so that Local Mapping
  // cannot cull them between verification and correction (each hold is
  // released once); loop keyframes are held for good (not_erase).
  void holdFromErase() { ++erase_holds_; }
  void releaseErase() { if (erase_holds_ > 0) --erase_holds_; }
  bool erasable() const { return id_ != 0 && !not_erase && erase_holds_ == 0; }
  // Pose relative to its parent, frozen when the keyframe is culled, so frames
  // that referred to it still get a pose: T_this_parent.
  const SE3& poseRelativeToParent() const { return T_c_parent_; }

  // Median depth of its map points in its camera (scene depth for baselines).
  double medianSceneDepth() const;

  bool not_erase = false;  // a loop keyframe: anchors the essential graph, never culled
  // Scratch for Tracking's local map and Local Mapping.
  long track_local_for_frame = -1;
  long fuse_target_for_kf = -1;
  long ba_local_for_kf = -1;
  long ba_fixed_for_kf = -1;
  // Scratch for relocalisation and loop detection (place queries).
  long reloc_query_for_frame = -1;
  long loop_query_for_kf = -1;

 private:
  void updateOrder();
  bool isDescendant(const KeyFrame* other) const;  // true when `other` is this keyframe or below it in the tree

  long id_;
  long frame_id_;
  int frame_index_;
  double timestamp_;
  const PinholeCamera* camera_;
  const ScalePyramid* pyramid_;
  SE3 T_cw_;
  std::vector<MapPoint*> map_points_;
  KeyFrameMap<int> connection_weights_;
  std::vector<KeyFrame*> ordered_covisibles_;
  std::vector<int> ordered_weights_;
  KeyFrame* parent_ = nullptr;
  bool parent_is_fallback_ = false;
  KeyFrame* fallback_parent_ = nullptr;
  int erase_holds_ = 0;
  KeyFrameSet children_;
  KeyFrameSet loop_edges_;
  SE3 T_c_parent_;
  bool bad_ = false;
};

// The world-to-camera pose of a frame recorded relative to `reference`
// (T_c_ref), carried up the spanning tree past culled keyframes, whose
// poseRelativeToParent() is frozen. `live_reference`, if given, receives the
// keyframe the walk ends at. Caller holds the map lock.
SE3 poseThroughReference(KeyFrame* reference, SE3 T_c_ref, KeyFrame** live_reference = nullptr);

}  // namespace vslam
