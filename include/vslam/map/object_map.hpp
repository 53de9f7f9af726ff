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
};

struct ObjectLandmark {
  int class_id = -1;
  std::string class_name;
  double confidence = 0.0;  // mean of its points' class confidences
  Vec3 centroid = Vec3::Zero();
  Vec3 box_min = Vec3::Zero(), box_max = Vec3::Zero();  // robust axis-aligned box (percentiles)
  std::vector<long> point_ids;
  std::vector<long> keyframe_ids;  // every keyframe observing one of its points, ascending
};

struct ObjectMapParams {
  double link_distance_ratio = 0.08;  // link distance = this x the median keyframe-to-point depth
  double box_link_factor = 5.0;       // points sharing a detection box link up to this x the link distance
  int min_points = 5;                 // smaller groups are dropped as noise (stray labels)
  double box_percentile = 0.05;       // box spans [p, 1 - p] of the points per axis
};

// Link distance for a scene whose median keyframe-to-point depth is `median_depth`.
inline double linkDistanceFor(double median_depth, const ObjectMapParams& params) {
  return params.link_distance_ratio * median_depth;
}

// Groups `points` (class_id < 0 ignored) into objects. Deterministic: objects
// come ordered by class id, then by their smallest point id. `class_names`
// names the classes (an id beyond it is named by its number).
std::vector<ObjectLandmark> buildObjectMap(const std::vector<LabelledPoint>& points, double link_distance,
                                           const ObjectMapParams& params, const std::vector<std::string>& class_names);

// Value at fraction q in [0, 1] of `values` (linear interpolation); 0 for none.
double percentile(std::vector<double> values, double q);

}  // namespace vslam
