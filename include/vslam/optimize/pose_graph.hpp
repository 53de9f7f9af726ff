#pragma once
// Loop closing: Sim(3) optimisation of the essential graph, and Sim(3)
// refinement between the two keyframes of a loop candidate.
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

// ---------------------------------------------------------------------------
// Essential-graph optimisation.

struct PoseGraphVertex {
  long id = -1;  // the caller's id, carried through untouched
  Sim3 S_cw;     // world -> camera similarity
  bool fixed = false;
};

// Relative measurement between two vertices (indices into the vertex vector):
// S_to_from = S_to_w * S_from_w^-1, i.e. it maps points of camera `from` into
// camera `to`. Spanning-tree, strong-covisibility and loop edges all have this form.
struct PoseGraphEdge {
  int from = 0;
  int to = 0;
  Sim3 S_to_from;
  double weight = 1.0;  // multiplies the squared residual
};

struct PoseGraphOptions {
  int iterations = 20;
  // Stereo / RGB-D maps have a known scale: optimise SE(3) and keep each
  // vertex's scale as given.
  bool fix_scale = false;
};

struct PoseGraphResult {
  double initial_cost = 0;  // Ceres cost, 0.5 * sum of squared weighted residuals
  double final_cost = 0;
  int iterations = 0;
};

// Optimises the free vertices in place. The residual of an edge is the
// error similarity E = S_to_from^-1 * S_to_w * S_from_w^-1 written as
// (2 * vec(quaternion of E), translation of E, log scale of E): zero exactly
// when the estimate agrees with the measurement. Vertices without edges are
// left unchanged. Throws std::invalid_argument for bad edge indices or
// weights, or a vertex scale <= 0.
PoseGraphResult optimizeSim3PoseGraph(std::vector<PoseGraphVertex>& vertices, const std::vector<PoseGraphEdge>& edges,
                                      const PoseGraphOptions& options = {});

// The rigid pose a keyframe gets back from its optimised S_cw: the same
// rotation and camera centre, i.e. (R, t / s).
SE3 rigidPoseFromSim3(const Sim3& S_cw);

// ---------------------------------------------------------------------------
// Sim(3) between two keyframes from matched map points.

// One match: the map point of keyframe 1 in camera 1 coordinates, the matched
// map point of keyframe 2 in camera 2 coordinates, and the keypoints that
// observe them in each image.
struct Sim3Match {
  Vec3 point1_c1 = Vec3::Zero();
  Vec3 point2_c2 = Vec3::Zero();
  Vec2 pixel1 = Vec2::Zero();
  Vec2 pixel2 = Vec2::Zero();
  double inv_sigma2_1 = 1.0;
  double inv_sigma2_2 = 1.0;
};

struct Sim3OptimizationOptions {
  double chi2_threshold = 10.0;  // per image, 2 dof (ORB-SLAM's loop-closing value)
  bool fix_scale = false;        // stereo / RGB-D: optimise SE(3) only
  int iterations_first = 5;
  int iterations_second = 10;  // after removing outliers (5 when there were none)
};

struct Sim3OptimizationResult {
  int n_inliers = 0;
  std::vector<bool> inlier;  // per match
};

// Refines S12 (maps camera-2 points into camera 1) in place by minimising the
// reprojection errors of point2 into image 1 and of point1 into image 2, with
// a Huber loss. After the first iterations, matches whose error in either
// image exceeds the threshold (or with a point behind a camera) are removed
// and the rest is optimised again; the final classification is returned.
// Throws std::invalid_argument if S12.s <= 0.
Sim3OptimizationResult optimizeSim3(const PinholeCamera& camera, const std::vector<Sim3Match>& matches, Sim3& S12,
                                    const Sim3OptimizationOptions& options = {});

}  // namespace vslam
