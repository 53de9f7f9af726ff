#pragma once
// Bundle adjustment over plain values: two-view initialisation, Local Mapping's
// local BA, and the full BA after a loop closure or at the end of a run.
//
// The caller decides the shape: local BA passes the covisible keyframes as
// free and the other keyframes that observe the same points as fixed; full BA
// passes every keyframe with the first one fixed.
//
// Gauge. Fixed keyframes fix the gauge. A monocular problem with a single
// fixed keyframe still has a free scale; Levenberg-Marquardt's damping copes
// with that, but `fix_translation_norm` on a second keyframe removes it (the
// norm of its t_cw stays as given: with keyframe 0 at the world origin that is
// the baseline between the two).
#include <atomic>
#include <cmath>
#include <istream>
#include <string>
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {

struct BaKeyframe {
  long id = -1;  // the caller's id, carried through untouched
  SE3 T_cw;
  bool fixed = false;
  bool fix_translation_norm = false;  // ignored when `fixed`
  // With BundleProblem::readout_s > 0: the camera's velocity as the keyframe
  // was exposed, and T_cw is its middle row's pose (rolling_shutter.hpp).
  CameraVelocity velocity = {};
};

struct BaPoint {
  long id = -1;
  Vec3 position_w = Vec3::Zero();
  bool fixed = false;
};

// Indices into BundleProblem::keyframes and ::points.
struct BaObservation {
  int keyframe = 0;
  int point = 0;
  Vec2 pixel = Vec2::Zero();
  double inv_sigma2 = 1.0;
  double u_right = kNoRightCoordinate;  // stereo / RGB-D: u - bf / depth
};

struct BundleProblem {
  std::vector<BaKeyframe> keyframes;
  std::vector<BaPoint> points;
  std::vector<BaObservation> observations;
  // A rolling shutter's readout (first to last row, seconds; 0: global
  // shutter): each observation is seen at its row's time, the camera moved by
  // its keyframe's velocity. Not saved by saveBundleProblem.
  double readout_s = 0;
};

enum class BundleLinearSolver {
  Automatic,  // dense Schur up to 40 free keyframes, else sparse Schur (SuiteSparse or Eigen)
  DenseSchur,
  SparseSchur,
  IterativeSchur,
};

// Loss of phase 1. Huber is ORB-SLAM's choice. Cauchy redescends: on short
// tracks (3-4 observations) a gross outlier at the end of a track can pull
// the point under Huber so that good observations fail the chi2 test instead;
// Cauchy resists that better (see docs/OPTIMIZATION.md).
enum class RobustLoss { Huber, Cauchy };

struct BundleOptions {
  // Phase 1 runs with the robust loss (if `robust`). If `remove_outliers`, the
  // observations failing the chi2 test are then dropped and phase 2 runs
  // without a robust loss; otherwise there is no phase 2.
  int iterations_first = 5;
  int iterations_second = 10;
  bool robust = true;
  RobustLoss robust_loss = RobustLoss::Huber;
  bool remove_outliers = true;
  // Scale of the robust loss on the whitened residual norm (Huber's delta,
  // Cauchy's b = delta^2).
  double huber_mono = std::sqrt(kChi2Mono);
  double huber_stereo = std::sqrt(kChi2Stereo);
  double chi2_mono = kChi2Mono;
  double chi2_stereo = kChi2Stereo;
  int num_threads = 1;
  BundleLinearSolver linear_solver = BundleLinearSolver::Automatic;
  // Local Mapping sets this when a new keyframe arrives; the solver stops
  // after its current iteration, keeps the progress made, and skips phase 2.
  const std::atomic<bool>* abort_flag = nullptr;
};

struct BundleResult {
  // Per observation, with the final values: chi2 above the threshold (mono
  // 5.991, stereo 7.815) or the point not in front of the camera. Always
  // filled, also with remove_outliers = false.
  std::vector<bool> outlier;
  int n_outliers = 0;
  // Half the sum of the plain (non-robust) chi2 of the observations that are
  // inliers at the end, before and after: the two are comparable.
  double initial_cost = 0;
  double final_cost = 0;
  int iterations = 0;  // Ceres iterations over both phases
  bool aborted = false;
};

// Optimises the free poses and points of `problem` in place (fixed ones are
// not written). Throws std::invalid_argument for out-of-range indices, or
// stereo observations with bf <= 0.
BundleResult bundleAdjust(const PinholeCamera& camera, double bf, BundleProblem& problem,
                          const BundleOptions& options = {});

// A bundle problem with the camera it was recorded with, so a real Local
// Mapping problem can be saved and replayed in benchmarks.
struct RecordedBundleProblem {
  PinholeCamera camera;  // fx, fy, cx, cy, width, height only
  double bf = 0;
  BundleProblem problem;
};

// Plain text, full double precision; see docs/OPTIMIZATION.md for the format.
// Throw InputError when the file cannot be written / read or is malformed.
void saveBundleProblem(const std::string& path, const PinholeCamera& camera, double bf,
                       const BundleProblem& problem);
RecordedBundleProblem loadBundleProblem(const std::string& path);
// The same from a stream; `name` is the file named in errors.
RecordedBundleProblem loadBundleProblem(std::istream& in, const std::string& name);

}  // namespace vslam
