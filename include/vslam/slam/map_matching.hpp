#pragma once
// Matching between frames and the map: search by projection (last frame,
// local map, keyframe), descriptor matching against a keyframe, and fusion of
// duplicate map points. Callers hold the map lock (see map/map.hpp).
#include <optional>
#include <vector>

#include "vslam/map/frame.hpp"
#include "vslam/map/keyframe.hpp"
#include "vslam/map/map_point.hpp"

namespace vslam {


// Projects the last frame's map points with the current frame's (predicted)
// pose and matches them in a window of `radius_px` times the keypoint's scale.
int searchByProjection(Frame& current, const Frame& last, double radius_px, bool check_orientation = true);

// Whether a map point projects into the frame, within its scale range and
// viewing angle; fills the point's track_* scratch (projection, level, view cos).
bool isInFrustum(MapPoint* point, const Frame& frame, double min_view_cos = 0.5);

// Matches local map points (already checked with isInFrustum) into the frame.
int searchLocalPoints(Frame& frame, const std::vector<MapPoint*>& points, double radius_factor);

// Projects a keyframe's map points (those not in `already_found`) with the
// frame's pose and matches them; used after relocalisation and as a fallback.
int searchByProjection(Frame& frame, const KeyFrame& keyframe, const std::vector<MapPoint*>& already_found,
                       double radius_px, int max_descriptor_distance);

// Matches the keyframe's map points to the frame by descriptor alone (best
// match among all features with a ratio test and rotation consistency);
// fills `matches` (per frame keypoint) and returns the count. Used to track the
// reference keyframe when the motion model fails.
int searchByDescriptor(const KeyFrame& keyframe, const Frame& frame, std::vector<MapPoint*>& matches,
                       double ratio = 0.7);

// Matches the keyframe's map points to the frame's features that fall under
// the same vocabulary node (the direct indices `keyframe.bow_features` and
// `frame_features`), with a ratio test and rotation consistency: ORB-SLAM's
// SearchByBoW, used by relocalisation. Fills `matches` per frame keypoint.
int searchByBoW(const KeyFrame& keyframe, const Frame& frame, const FeatureVector& frame_features,
                std::vector<MapPoint*>& matches, double ratio = 0.75);
// The same between two keyframes (loop detection): matches[i] is the map
// point of kf2 matched to keypoint i of kf1, for keypoints of kf1 with a map point.
int searchByBoW(const KeyFrame& kf1, const KeyFrame& kf2, std::vector<MapPoint*>& matches, double ratio = 0.75);

// Pairs of keypoints (index in kf1, index in kf2), both without a map point,
// whose descriptors agree and which satisfy the epipolar constraint of the two
// keyframes' poses; candidates for triangulating new map points.
std::vector<std::pair<int, int>> searchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2);

// Where `point` would be observed by `keyframe` if the keyframe's world->camera
// transform were S_cw (its own pose, or a loop-corrected one) with camera
// centre `centre_w`: in front of the camera, inside the image, within the
// point's scale range and viewing angle (60 degrees), at the predicted level.
struct PredictedObservation {
  Vec2 pixel;
  int level = 0;
};
std::optional<PredictedObservation> predictObservation(const MapPoint& point, const KeyFrame& keyframe,
                                                       const Sim3& S_cw, const Vec3& centre_w);

// ORB-SLAM's SearchBySim3, the guided search of a loop after its Sim(3)
// RANSAC. S12 maps kf2's camera coordinates into kf1's. kf1's map points are
// projected into kf2 with S12^-1 and kf2's into kf1 with S12; each takes the
// keypoint with the nearest descriptor (Hamming <= 100) within `radius_px`
// times the scale of its predicted level, at that level or the one below,
// among keypoints not yet matched. A pair is kept only when both directions
// chose it. `matches12` holds, per kf1 keypoint, the kf2 map point matched to
// it; the pairs already in it stay and take no part in the search (neither
// their keypoints nor their points). Returns the number of pairs added.
int searchBySim3(const KeyFrame& kf1, const KeyFrame& kf2, const Sim3& S12, std::vector<MapPoint*>& matches12,
                 double radius_px = 7.5);

// Which point survives when a projected point meets a keypoint that already
// has one: Local Mapping keeps the one seen more (ORB-SLAM2's Fuse); loop
// fusion keeps the projected loop-side point, so the corrected map is the
// one the loop was verified against (ORB-SLAM2's SearchAndFuse).
enum class FuseKeeps { MoreObserved, Projected };

// Projects `points` into `keyframe` and fuses each with the keyframe's
// matching keypoint: adds an observation, or merges with the point already
// there (the survivor chosen by `keeps`). Returns the number fused.
int fuse(KeyFrame* keyframe, const std::vector<MapPoint*>& points, double radius_factor = 3.0,
         FuseKeeps keeps = FuseKeeps::MoreObserved);

}  // namespace vslam
