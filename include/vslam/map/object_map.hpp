#pragma once
// Object landmarks: the labelled map points of one class that lie together in
// 3D, grouped into one object each (the semantic map of issue 5).
//
// Grouping is single-linkage: two points of the same class belong to the same
// object when a chain of same-class points joins them, every step either
// shorter than `link_distance`, or shorter than `box_link_factor` times that
// between two points seen in one detection box (the same box of the same
// keyframe: the detector said they are one object, however sparse the points
// between them; the bound keeps out a badly triangulated point far behind).
// Monocular maps have an arbitrary scale, so callers give the distance
// relative to the scene (see linkDistanceFor).
//
// An object's extent comes only from the points that agree with it: a point
// far out of the others' distances from the object's median position, or of
// their depths along the viewing rays (background seen through the detection
// box), is rejected; the box spans the inner percentiles of the rest. Then
// objects of confusable classes (a monitor the detector sometimes calls a
// laptop) whose boxes overlap become one object of the class with more points.
#include <utility>
#include <string>
#include <vector>

#include "vslam/core/types.hpp"

namespace vslam {

struct LabelledPoint {
  long id = -1;
  Vec3 position = Vec3::Zero();
  int class_id = -1;
  double confidence = 0.0;         // share of its observations that carry class_id
  std::vector<long> keyframe_ids;  // keyframes observing it
  // (keyframe id, detection id) of the observations inside a box of class_id.
  std::vector<std::pair<long, int>> detections;
  // Mean unit ray from its observing keyframes' centres towards it; zero when
  // unknown (then only its distance from the object's median is checked).
  Vec3 viewing_direction = Vec3::Zero();
};

struct ObjectLandmark {
  int class_id = -1;
  std::string class_name;
  double confidence = 0.0;  // mean of its points' class confidences
  Vec3 centroid = Vec3::Zero();                         // mean of its points (outliers excluded)
  Vec3 box_min = Vec3::Zero(), box_max = Vec3::Zero();  // robust axis-aligned box (percentiles of its points)
  std::vector<long> point_ids;                          // its points, ascending (outliers excluded)
  std::vector<long> rejected_point_ids;                 // linked to it but disagreeing in position or depth
  std::vector<long> keyframe_ids;                       // every keyframe observing one of its points, ascending
  // Classes of the instances merged into it other than its own, by name, ascending.
  std::vector<std::string> merged_classes;
};

struct ObjectMapParams {
  double link_distance_ratio = 0.08;  // link distance = this x the median keyframe-to-point depth
  double box_link_factor = 5.0;       // points sharing a detection box link up to this x the link distance
  int min_points = 5;                 // groups with fewer points (outliers excluded) are dropped as stray labels
  double box_percentile = 0.05;       // box spans [p, 1 - p] of the points per axis
  // Outliers (Tukey's "far out" fences): a distance from the object's median
  // position above the distances' third quartile, or a depth along the point's
  // own viewing ray (from the median) outside the depths' quartiles, by more
  // than this x the interquartile range.
  double outlier_iqr_factor = 3.0;
  // Floor of the interquartile range, x the link distance: points on a flat
  // face agree in depth to within noise, which must not reject a fair share of them.
  double min_spread_ratio = 0.25;
  // Classes the detector confuses on one object (names of the model's names
  // file; both spellings of COCO's renamed classes). Kept small: see
  // docs/SEMANTIC_MAP.md for why each group is here.
  std::vector<std::vector<std::string>> confusable_classes = {
      {"tvmonitor", "tv", "laptop"}, {"chair", "sofa", "couch", "bench"}, {"car", "truck", "bus"}, {"cup", "bowl"}};
  // Two objects of one confusable group merge when their boxes, each grown by
  // half a link distance, share at least this fraction of the smaller one.
  double merge_overlap = 0.3;
};

// Link distance for a scene whose median keyframe-to-point depth is `median_depth`.
inline double linkDistanceFor(double median_depth, const ObjectMapParams& params) {
  return params.link_distance_ratio * median_depth;
}

// Groups `points` (class_id < 0 ignored) into objects. Deterministic: objects
// come ordered by class id, then by the smallest id of the points linked into
// them. `class_names` names the classes (an id beyond it is named by its number).
std::vector<ObjectLandmark> buildObjectMap(const std::vector<LabelledPoint>& points, double link_distance,
                                           const ObjectMapParams& params, const std::vector<std::string>& class_names);

// Value at fraction q in [0, 1] of `values` (linear interpolation); 0 for none.
double percentile(std::vector<double> values, double q);

// Whether boxes a and b, each grown by `margin` on every side, share at least
// `fraction` of the smaller grown box's volume.
bool boxesOverlap(const Vec3& a_min, const Vec3& a_max, const Vec3& b_min, const Vec3& b_max, double margin,
                  double fraction);

}  // namespace vslam
