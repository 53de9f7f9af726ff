#include "vslam/slam/tracking.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <map>
#include <optional>

#include <opencv2/calib3d.hpp>

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "vslam/feature/matcher.hpp"
#include "vslam/geometry/pnp.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/geometry/two_view_initializer.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
#include "vslam/optimize/pose_optimizer.hpp"
#include "vslam/optimize/reprojection.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"
#include "vslam/slam/local_mapping.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/map_matching.hpp"
#include "vslam/slam/moving_objects.hpp"
#include "vslam/slam/place_candidates.hpp"

namespace vslam {
namespace {

constexpr int kInitMinKeypoints = 100;
constexpr int kInitMinKeypointsWithDepth = 500;  // ORB-SLAM2's RGB-D initialisation
constexpr int kCloseTrackedFew = 100;             // ORB-SLAM2's close-point keyframe rule...
constexpr int kCloseUntrackedMany = 70;           // ...tracked < 100 and untracked > 70
constexpr long kOdometryPointId = -1;  // map points have ids >= 0
constexpr int kNewKeyFrameMinDepthPoints = 100;   // a keyframe adds depth points up to at least this many
constexpr double kRgbdLeavingMapRatio = 0.25;     // ORB-SLAM2's RGB-D c1c: tracked < 25 % of the reference's
constexpr int kInitMinMatches = 100;
constexpr int kMinStaticMatchesForPose = 20;  // fewer: objects that may move help the pose after all
constexpr double kInitWindowPx = 100.0;
constexpr double kProjectionRadiusPx = 15.0;  // monocular search window around the predicted position
constexpr size_t kMaxLocalKeyFrames = 80;
constexpr size_t kResetMaxKeyFrames = 3;       // lost with this many keyframes or fewer: start again
constexpr int kRelocMinBowMatches = 15;
constexpr int kRelocMinInliers = 50;

// A frame's pose and matches, kept to go back to after a later step fails.
struct TrackedPose {
  SE3 T_cw;
  std::vector<MapPoint*> map_points;
  std::vector<bool> outlier;
  static TrackedPose of(const Frame& frame) { return {frame.T_cw, frame.map_points, frame.outlier}; }
  void restore(Frame& frame) const {
    frame.T_cw = T_cw;
    frame.map_points = map_points;
    frame.outlier = outlier;
    frame.has_pose = true;
  }
};

// The matches that keep a frame tracked: inliers on points already in the
// map (a point just made by this frame's odometry has no observation yet),
// optionally without those on objects judged moving.
int mapInliers(const Frame& frame, bool skip_moving_objects) {
  int count = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    const MapPoint* point = frame.map_points[i];
    if (!point || frame.outlier[i] || point->observationCount() == 0) continue;
    if (skip_moving_objects && onMovingObject(frame.labels[i])) continue;
    ++count;
  }
  return count;
}

}  // namespace

bool motionModelAllowed(long frame_id, long last_relocalisation) {
  return last_relocalisation < 0 || frame_id >= last_relocalisation + 2;
}

bool keyFrameAllowedAfterRelocalisation(long frame_id, long last_relocalisation, int max_frames,
                                        size_t keyframes_in_map) {
  if (last_relocalisation < 0 || frame_id >= last_relocalisation + max_frames) return true;
  return keyframes_in_map <= static_cast<size_t>(max_frames);
}

Tracking::Tracking(const Config& config, Map& map, LocalMapping& local_mapping, StageTimer* timer,
                   KeyFrameInsertion insertion)
    : config_(config), map_(map), local_mapping_(local_mapping), timer_(timer), insertion_(insertion) {}

void Tracking::startInLoadedMap(bool localization_only) {
  map_loaded_ = true;
  localization_only_ = localization_only;
  state_ = TrackingState::Lost;  // the first frame relocalises in the loaded map
}

InitialisationMatches initialisationMatches(const Frame& reference, const Frame& current,
                                            const std::vector<int>& matches_ref_cur, double sigma_px) {
  InitialisationMatches out;
  const double sigma2_level0 = sigma_px * sigma_px;
  for (size_t i = 0; i < matches_ref_cur.size(); ++i) {
    const int j = matches_ref_cur[i];
    if (j < 0) continue;
    out.pts_ref.push_back(reference.point(i));
    out.pts_cur.push_back(current.point(j));
    out.sigma2_ref.push_back(sigma2_level0 * reference.pyramid->sigma2[reference.keypoints[i].octave]);
    out.sigma2_cur.push_back(sigma2_level0 * current.pyramid->sigma2[current.keypoints[j].octave]);
    out.pairs.emplace_back(static_cast<int>(i), j);
  }
  return out;
}

void Tracking::refreshLastFramePose() {
  if (!last_frame_ || !last_frame_->has_pose || records_.empty()) return;
  const FrameRecord& last = records_.back();
  if (!last.tracked || !last.reference || last.frame_id != last_frame_->id) return;
  last_frame_->T_cw = poseThroughReference(last.reference, last.T_c_ref);
}

bool Tracking::track(Frame& frame) {
  FrameRecord record;
  record.frame_id = frame.id;
  record.index = frame.index;
  record.timestamp = frame.timestamp;

  if (state_ == TrackingState::NotInitialized) {
    initialise(frame);
    if (state_ != TrackingState::Ok) {
      records_.push_back(record);
      return false;
    }
    // The initialising frame is now keyframe 1: record it and continue with the next frame.
    record.tracked = true;
    record.reference = last_keyframe_;
    record.T_c_ref = SE3();
    records_.push_back(record);
    return true;
  }

  if (insertion_ == KeyFrameInsertion::WaitForMapping) {
    // The previous keyframe's new points must be in the map before this frame
    // is tracked; otherwise a fast Tracking thread would keep tracking against
    // a map that lags one keyframe behind (and starve when tracking is weak).
    // A keyframe made because tracking was weak is waited for entirely (its
    // local BA and culling too), as in a deterministic run: that is when the
    // next frame depends most on the map being up to date.
    ScopedStage wait(timer_, "keyframe_link_wait");
    if (last_keyframe_was_weak_)
      local_mapping_.waitUntilIdle();
    else
      local_mapping_.waitUntilLinked();
    last_keyframe_was_weak_ = false;
  }
  std::unique_lock<std::mutex> lock(map_.mutex());
  refreshLastFramePose();
  bool ok = false;
  bool keyframe_made = false;
  if (state_ == TrackingState::Ok && odometry_only_) {
    ok = trackByOdometryOrRelocalise(frame);
  } else if (state_ == TrackingState::Ok) {
    if (velocity_ && last_frame_ && motionModelAllowed(frame.id, last_relocalisation_frame_id_)) {
      ok = trackWithMotionModel(frame);
      if (!ok) ++motion_model_misses_;
    }
    if (!ok) ok = trackReferenceKeyFrame(frame);
    // Right after a relocalisation the keyframe it was found from may see the
    // place from afar; the relocalised frame is the nearest view.
    if (!ok && last_relocalisation_frame_id_ >= 0 && !motionModelAllowed(frame.id, last_relocalisation_frame_id_)) {
      ok = trackFromLastFrameAtRest(frame);
      spdlog::info("frame {}: its reference keyframe failed after the relocalisation; from the last frame at rest: {}",
                   frame.index, ok ? "tracked" : "failed");
    }
  } else {
    // Lost: relocalise against the whole map by place recognition; without a
    // vocabulary, retry the reference keyframe.
    ok = database_ && vocabulary_ ? relocalise(frame) : trackReferenceKeyFrame(frame);
    if (ok) {
      last_relocalisation_frame_id_ = frame.id;
      ++relocalisations_;
      spdlog::info("frame {} (t={:.3f}): relocalised", frame.index, frame.timestamp);
    }
  }
  // A frame carried by odometry has too few map points for the local map.
  if (ok && !odometry_only_) {
    // Localisation mode: a frame the motion model placed with odometry points
    // stays tracked by them when the local map is too thin (past its edge).
    // ORB-SLAM2 would call it lost and only try to relocalise.
    const bool odometry_fallback = !odometry_points_.empty() && frame.trackedCount() > 20;
    const TrackedPose before_local_map = odometry_fallback ? TrackedPose::of(frame) : TrackedPose{};
    ok = trackLocalMap(frame);
    if (!ok && odometry_fallback) {
      before_local_map.restore(frame);
      odometry_only_ = true;
      ok = true;
    }
  }
  dropOdometryPoints(frame);

  if (ok) {
    state_ = TrackingState::Ok;
    if (last_frame_ && last_frame_->has_pose)
      velocity_ = frame.T_cw * last_frame_->T_cw.inverse();
    else
      velocity_.reset();
    if (!localization_only_ && needNewKeyFrame(frame)) {
      if (insertion_ == KeyFrameInsertion::WaitForMapping && !local_mapping_.acceptsKeyFrames()) {
        // Back-pressure: let Local Mapping finish the keyframe in hand. The map
        // may change meanwhile (local BA, culling, a loop correction), so the
        // frame keeps its pose relative to its reference keyframe.
        KeyFrame* reference = reference_keyframe_;
        const SE3 T_c_ref = frame.T_cw * reference->pose().inverse();
        ++keyframe_waits_;
        lock.unlock();
        {
          ScopedStage wait(timer_, "keyframe_wait");
          local_mapping_.waitUntilIdle();
        }
        lock.lock();
        KeyFrame* live = nullptr;
        frame.T_cw = poseThroughReference(reference, T_c_ref, &live);
        reference_keyframe_ = live;
      }
      createKeyFrame(frame);
      keyframe_made = true;
    }
    // Outliers must not be projected into the next frame.
    for (size_t i = 0; i < frame.size(); ++i)
      if (frame.outlier[i]) frame.map_points[i] = nullptr;
  } else {
    state_ = TrackingState::Lost;
    odometry_only_ = false;
    velocity_.reset();
    frame.has_pose = false;
    spdlog::warn("frame {} (t={:.3f}): tracking lost", frame.index, frame.timestamp);
  }

  last_tracked_points_ = ok ? matches_inliers_ : 0;
  last_matched_points_ = ok ? local_map_matches_ : 0;
  if (ok && reference_keyframe_) {
    record.tracked = true;
    record.reference = reference_keyframe_;
    record.T_c_ref = frame.T_cw * reference_keyframe_->pose().inverse();
    record.by_odometry = odometry_only_;
    // In localisation mode the map does not change, so the matches are only
    // kept for a rolling shutter's correction (System::finish).
    const bool keep_matches =
        config_.loop.refine_frames && (!localization_only_ || config_.camera.readout_s > 0);
    // A keyframe's frame too: should the keyframe be culled, the frame is
    // posed again in the final map like any other.
    if (keep_matches) recordMatches(frame, record);
    record.made_keyframe = keyframe_made;
  }
  records_.push_back(std::move(record));
  // Early failure: a map just initialised (a few keyframes) is not worth
  // keeping. A larger map is kept while relocalisation can still succeed.
  const bool reset = !ok && !map_loaded_ && map_.keyframeCount() <= kResetMaxKeyFrames;
  lock.unlock();

  if (insertion_ == KeyFrameInsertion::Synchronous) {
    local_mapping_.processQueued();
  } else if (keyframe_made && frame.id == last_relocalisation_frame_id_) {
    // A keyframe made where the camera was just relocalised is finished (its
    // local BA too) before the frame is reported, as in a deterministic run:
    // the relocalised pose comes from one keyframe's points and was measured
    // 2.1-3.1 cm off after a forward jump on fr3_teddy, 0.5-0.7 cm once
    // refined (docs/BENCHMARKS.md, issue 16). The next frame would wait for it
    // anyway when it is weak, so this costs a relocalisation no time.
    ScopedStage wait(timer_, "keyframe_link_wait");
    local_mapping_.waitUntilIdle();
    last_keyframe_was_weak_ = false;
  }

  if (reset) {
    spdlog::warn("tracking lost soon after initialisation: resetting the map");
    resetMap();
    return false;  // the frame's matches belonged to the old map: nothing of it is kept
  }
  last_frame_ = frame;
  last_frame_->has_pose = ok;
  return ok;
}

void Tracking::initialise(Frame& frame) {
  if (config_.sensor == SensorMode::RgbD) {
    initialiseFromDepth(frame);
    return;
  }
  if (!init_reference_) {
    if (static_cast<int>(frame.size()) > kInitMinKeypoints) {
      init_reference_ = std::make_unique<Frame>(frame);
      init_prev_matched_ = frame.points;
    }
    return;
  }
  if (static_cast<int>(frame.size()) <= kInitMinKeypoints) {
    start_failure_ = fmt::format("frame {}: {} keypoints, more than {} needed", frame.index, frame.size(),
                                 kInitMinKeypoints);
    init_reference_.reset();
    return;
  }
  const Frame& reference = *init_reference_;
  WindowMatchParams window;
  window.window = static_cast<float>(kInitWindowPx);
  window.max_level = config_.initializer.window_max_level;
  const WindowMatches matched = matchInWindow(reference.view(), frame.view(), frame.grid, init_prev_matched_, window);
  const std::vector<int>& matches_ref_cur = matched.matches12;
  if (matched.count < kInitMinMatches) {
    start_failure_ = fmt::format("frame {} against frame {}: {} window matches, {} needed", frame.index,
                                 reference.index, matched.count, kInitMinMatches);
    // Too little overlap: start again from this frame.
    init_reference_ = std::make_unique<Frame>(frame);
    init_prev_matched_ = frame.points;
    return;
  }
  const InitialisationMatches initial =
      initialisationMatches(reference, frame, matches_ref_cur, config_.initializer.sigma_px);
  const std::vector<std::pair<int, int>>& pairs = initial.pairs;
  const TwoViewInitializer initializer(frame.camera->Keigen(), config_.initializer);
  const TwoViewResult result =
      initializer.initialize(initial.pts_ref, initial.pts_cur, initial.sigma2_ref, initial.sigma2_cur);
  spdlog::debug("frame {}: init attempt with frame {}: {} matches, {} model inliers, {} triangulated, ratio {:.2f}, "
                "parallax {:.2f} deg, translation direction +-{:.2f} deg: {}",
                frame.index, reference.index, matched.count, result.n_model_inliers, result.n_triangulated,
                result.score_ratio, result.median_parallax_deg, result.translation_direction_std_deg,
                result.success ? "ok" : result.failure_reason);
  if (!result.success) {
    start_failure_ = fmt::format("frame {} against frame {}: {} matches, {}", frame.index, reference.index,
                                 matched.count, result.failure_reason);
    return;
  }

  std::lock_guard<std::mutex> lock(map_.mutex());
  Frame ref_frame = reference;
  ref_frame.T_cw = SE3();
  ref_frame.has_pose = true;
  frame.T_cw = result.T_cur_ref;
  frame.has_pose = true;
  ref_frame.map_points.assign(ref_frame.size(), nullptr);
  frame.map_points.assign(frame.size(), nullptr);
  KeyFrame* kf_ref = map_.createKeyFrame(ref_frame);
  KeyFrame* kf_cur = map_.createKeyFrame(frame);
  for (size_t m = 0; m < pairs.size(); ++m) {
    if (!result.triangulated[m]) continue;
    const auto [i_ref, i_cur] = pairs[m];
    MapPoint* point = map_.createMapPoint(result.points_ref[m], kf_ref);
    point->addObservation(kf_ref, i_ref);
    point->addObservation(kf_cur, i_cur);
    kf_ref->setMapPoint(i_ref, point);
    kf_cur->setMapPoint(i_cur, point);
    point->setColour(kf_ref->colours[i_ref]);
    point->updateDescriptor();
    point->updateNormalAndDepth(*frame.pyramid);
    point->updateClass();
  }
  kf_ref->updateConnections();
  kf_cur->updateConnections();

  // Two-view bundle adjustment, first keyframe fixed.
  BundleProblem problem;
  problem.keyframes = {{kf_ref->id(), kf_ref->pose(), true}, {kf_cur->id(), kf_cur->pose(), false}};
  std::vector<MapPoint*> points = map_.mapPoints();
  for (size_t p = 0; p < points.size(); ++p) {
    problem.points.push_back({points[p]->id(), points[p]->position(), false});
    int k = 0;
    for (KeyFrame* kf : {kf_ref, kf_cur}) {
      const int idx = points[p]->keypointIn(kf);
      problem.observations.push_back(
          {k, static_cast<int>(p), kf->point(idx), frame.pyramid->inv_sigma2[kf->keypoints[idx].octave]});
      ++k;
    }
  }
  BundleOptions options;
  options.iterations_first = 20;
  options.iterations_second = 0;
  options.remove_outliers = false;
  bundleAdjust(*frame.camera, 0.0, problem, options);
  kf_cur->setPose(problem.keyframes[1].T_cw);
  for (size_t p = 0; p < points.size(); ++p) points[p]->setPosition(problem.points[p].position_w);

  // Scale the map so the first keyframe's median scene depth is 1.
  const double median_depth = kf_ref->medianSceneDepth();
  const int tracked_points = kf_cur->trackedMapPoints(1);
  if (median_depth <= 0 || tracked_points < kInitMinKeypoints) {
    start_failure_ = fmt::format("frame {} against frame {}: rejected after the two-view bundle adjustment (median "
                                 "depth {:.3f}, {} points, {} needed)",
                                 frame.index, reference.index, median_depth, tracked_points, kInitMinKeypoints);
    spdlog::info("initialisation {}", start_failure_);
    map_.clear();
    return;
  }
  const double inv_depth = 1.0 / median_depth;
  SE3 T_cur = kf_cur->pose();
  T_cur.t *= inv_depth;
  kf_cur->setPose(T_cur);
  for (MapPoint* point : points) {
    point->setPosition(point->position() * inv_depth);
    point->updateNormalAndDepth(*frame.pyramid);
  }

  spdlog::info("map initialised at frame {} from frame {} with {} points ({}, score ratio {:.2f}, parallax {:.1f} deg)",
               frame.index, reference.index, points.size(), result.used_homography ? "homography" : "fundamental",
               result.score_ratio, result.median_parallax_deg);

  // The reference frame was never recorded as tracked: it is keyframe 0.
  for (FrameRecord& record : records_)
    if (record.frame_id == reference.id) {
      record.tracked = true;
      record.reference = kf_ref;
      record.T_c_ref = SE3();
    }

  local_mapping_.insertKeyFrame(kf_ref);
  local_mapping_.insertKeyFrame(kf_cur);
  frame.T_cw = kf_cur->pose();
  for (size_t i = 0; i < frame.size(); ++i) frame.map_points[i] = kf_cur->mapPoint(i);
  frame.outlier.assign(frame.size(), false);
  startTracking(frame, {kf_ref, kf_cur}, points);
  init_reference_.reset();
}

void Tracking::startTracking(const Frame& frame, std::vector<KeyFrame*> keyframes, std::vector<MapPoint*> points) {
  last_frame_ = frame;
  last_frame_->has_pose = true;
  velocity_.reset();
  reference_keyframe_ = keyframes.back();
  last_keyframe_ = keyframes.back();
  last_keyframe_frame_id_ = frame.id;
  keyframes_created_ = static_cast<int>(keyframes.size());
  local_keyframes_ = std::move(keyframes);
  local_points_ = std::move(points);
  initialised_at_index_ = frame.index;
  state_ = TrackingState::Ok;
}

void Tracking::initialiseFromDepth(Frame& frame) {
  // ORB-SLAM2's RGB-D initialisation: one frame with enough depth readings
  // becomes the first keyframe, at the world origin, and every keypoint with
  // depth becomes a map point. The map is metric from the start.
  int with_depth = 0;
  for (size_t i = 0; i < frame.size(); ++i)
    if (frame.hasDepth(i)) ++with_depth;
  if (with_depth < kInitMinKeypointsWithDepth) {
    start_failure_ = fmt::format("frame {}: {} keypoints with depth, {} needed", frame.index, with_depth,
                                 kInitMinKeypointsWithDepth);
    spdlog::debug("initialisation: {}", start_failure_);
    return;
  }
  std::lock_guard<std::mutex> lock(map_.mutex());
  frame.T_cw = SE3();
  frame.has_pose = true;
  frame.map_points.assign(frame.size(), nullptr);
  frame.outlier.assign(frame.size(), false);
  KeyFrame* keyframe = map_.createKeyFrame(frame);
  std::vector<MapPoint*> points;
  for (size_t i = 0; i < keyframe->size(); ++i) {
    if (!keyframe->hasDepth(i)) continue;
    points.push_back(createPointFromDepth(keyframe, i));
    frame.map_points[i] = points.back();
  }
  spdlog::info("map initialised at frame {} from depth with {} points", frame.index, points.size());
  local_mapping_.insertKeyFrame(keyframe);
  startTracking(frame, {keyframe}, std::move(points));
}

MapPoint* Tracking::createPointFromDepth(KeyFrame* keyframe, size_t keypoint) {
  MapPoint* point = map_.createMapPoint(keyframe->unprojectToWorld(keypoint), keyframe);
  point->addObservation(keyframe, static_cast<int>(keypoint));
  keyframe->setMapPoint(keypoint, point);
  point->setColour(keyframe->colours[keypoint]);
  point->updateDescriptor();
  point->updateNormalAndDepth(keyframe->pyramid());
  point->updateClass();
  return point;
}

// Which matched keypoints the frame's pose is optimised over: those on
// objects that may move are left out while the static scene alone can give
// the pose (checkObjectMotion judges them afterwards).
static std::vector<bool> matchesForPose(const Frame& frame) {
  std::vector<bool> used(frame.size(), false);
  const bool has_labels = frame.labels.size() == frame.size();
  int static_matches = 0;
  for (size_t i = 0; i < frame.size(); ++i)
    if (frame.map_points[i] && (!has_labels || drivesPose(frame.labels[i]))) ++static_matches;
  const bool static_only = static_matches >= kMinStaticMatchesForPose;
  for (size_t i = 0; i < frame.size(); ++i)
    used[i] = frame.map_points[i] &&
              !(has_labels && (onMovingObject(frame.labels[i]) || (static_only && !drivesPose(frame.labels[i]))));
  return used;
}

int Tracking::optimisePose(Frame& frame) {
  std::vector<Vec3> points_w;
  std::vector<Observation2D> observations;
  std::vector<int> keypoint_of;
  const bool has_labels = frame.labels.size() == frame.size();
  const std::vector<bool> for_pose = matchesForPose(frame);
  for (size_t i = 0; i < frame.size(); ++i) {
    MapPoint* point = frame.map_points[i];
    if (!for_pose[i]) continue;
    keypoint_of.push_back(static_cast<int>(i));
    // Keypoints with depth add the right coordinate: (u, v, u_R), 3-DOF chi-square.
    observations.push_back({static_cast<int>(points_w.size()), frame.point(i),
                            frame.pyramid->inv_sigma2[frame.keypoints[i].octave], frame.rightCoordinate(i)});
    points_w.push_back(point->position());
  }
  frame.outlier.assign(frame.size(), false);
  // Matches left out of the pose are not outliers of it; those on moving
  // objects are dropped (discardOutliers), the undecided ones kept for the check.
  if (has_labels)
    for (size_t i = 0; i < frame.size(); ++i)
      if (frame.map_points[i] && onMovingObject(frame.labels[i])) frame.outlier[i] = true;
  if (observations.size() < 3) return 0;
  const PoseOptimizationResult result =
      optimizePose(*frame.camera, frame.camera->bf, frame.T_cw, points_w, observations);
  frame.T_cw = result.T_cw;
  frame.has_pose = true;
  for (size_t k = 0; k < keypoint_of.size(); ++k)
    if (!result.inlier[k]) frame.outlier[keypoint_of[k]] = true;
  return result.n_inliers;
}

// Drops outlier matches after pose optimisation and counts what is left.
static int discardOutliers(Frame& frame) {
  int kept = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (!frame.map_points[i]) continue;
    if (frame.outlier[i]) {
      MapPoint* point = frame.map_points[i];
      frame.map_points[i] = nullptr;
      frame.outlier[i] = false;
      point->track_in_view = false;
      point->last_frame_seen = frame.id;
    } else if (frame.map_points[i]->observationCount() > 0) {
      ++kept;
    }
  }
  return kept;
}

bool Tracking::trackWithMotionModel(Frame& frame) {
  const bool with_odometry = localization_only_ && config_.sensor == SensorMode::RgbD;
  if (with_odometry) addOdometryPoints(*last_frame_);
  frame.T_cw = *velocity_ * last_frame_->T_cw;
  frame.map_points.assign(frame.size(), nullptr);
  int matches = searchByProjection(frame, *last_frame_, kProjectionRadiusPx);
  if (matches < 20) {
    frame.map_points.assign(frame.size(), nullptr);
    matches = searchByProjection(frame, *last_frame_, 2 * kProjectionRadiusPx);
  }
  if (matches < 20) return false;
  optimisePose(frame);
  const int map_inliers = discardOutliers(frame);
  if (!with_odometry) return map_inliers >= 10;
  // ORB-SLAM2's localisation mode: odometry points count toward the pose;
  // with under 10 map points among them the frame is tracked by odometry alone.
  const bool tracked = frame.trackedCount() > 20;
  odometry_only_ = tracked && map_inliers < 10;
  if (odometry_only_) matches_inliers_ = map_inliers;
  return tracked;
}

bool Tracking::trackFromLastFrameAtRest(Frame& frame) {
  if (!last_frame_ || !last_frame_->has_pose) return false;
  velocity_ = SE3();
  ++at_rest_attempts_;
  return trackWithMotionModel(frame);
}

bool Tracking::trackByOdometryOrRelocalise(Frame& frame) {
  bool by_odometry = false;
  TrackedPose odometry;
  if (velocity_ && last_frame_) {
    by_odometry = trackWithMotionModel(frame);
    odometry = TrackedPose::of(frame);
  }
  if (database_ && vocabulary_ && relocalise(frame)) {
    odometry_only_ = false;
    last_relocalisation_frame_id_ = frame.id;
    ++relocalisations_;
    spdlog::debug("frame {} (t={:.3f}): relocalised after visual odometry", frame.index, frame.timestamp);
    return true;
  }
  if (!by_odometry) return false;
  odometry.restore(frame);
  odometry_only_ = true;
  return true;
}

void Tracking::addOdometryPoints(Frame& last) {
  if (!last.hasDepthImage() || !last.has_pose) return;
  // As ORB-SLAM2: the keypoints with depth and no map point, nearest first;
  // all the close ones, and at least the 100 nearest.
  std::vector<std::pair<float, size_t>> by_depth;
  for (size_t i = 0; i < last.size(); ++i) {
    const MapPoint* point = last.map_points[i];
    if (last.hasDepth(i) && (!point || point->observationCount() == 0)) by_depth.emplace_back(last.depth[i], i);
  }
  std::sort(by_depth.begin(), by_depth.end());
  const double close_depth = last.camera->closeDepth();
  const SE3 T_wc = last.T_cw.inverse();
  int added = 0;
  for (const auto& [depth, i] : by_depth) {
    if (depth > close_depth && added >= kNewKeyFrameMinDepthPoints) break;
    const Vec3 position_w = T_wc * (last.camera->unproject(last.point(i)) * static_cast<double>(depth));
    // No keyframe observes it, so matching treats it as replaceable and
    // discardOutliers() never counts it as a map point.
    auto point = std::make_unique<MapPoint>(kOdometryPointId, position_w, nullptr, -1);
    MapPoint::SavedState state;
    state.descriptor = last.descriptors.row(static_cast<int>(i));
    point->restoreState(state);
    last.map_points[i] = point.get();
    if (i < last.outlier.size()) last.outlier[i] = false;
    odometry_points_.push_back(std::move(point));
    ++added;
  }
}

void Tracking::dropOdometryPoints(Frame& frame) {
  if (odometry_points_.empty()) return;
  const auto unlink = [](Frame& f) {
    for (MapPoint*& point : f.map_points)
      if (point && point->id() == kOdometryPointId) point = nullptr;
  };
  if (last_frame_) unlink(*last_frame_);
  if (frame.hasDepthImage() || !frame.has_pose) {
    unlink(frame);
    odometry_points_.clear();
    return;
  }
  // A frame without a depth image has none to make the next frame's points
  // from: it keeps the ones it matched for one more frame.
  std::vector<std::unique_ptr<MapPoint>> kept;
  for (std::unique_ptr<MapPoint>& point : odometry_points_)
    if (std::find(frame.map_points.begin(), frame.map_points.end(), point.get()) != frame.map_points.end())
      kept.push_back(std::move(point));
  odometry_points_ = std::move(kept);
}

bool Tracking::trackReferenceKeyFrame(Frame& frame) {
  KeyFrame* reference = reference_keyframe_ ? reference_keyframe_ : last_keyframe_;
  if (!reference || reference->isBad()) {
    const auto keyframes = map_.keyframes();
    if (keyframes.empty()) return false;
    reference = keyframes.back();
  }
  std::vector<MapPoint*> matches;
  if (searchByDescriptor(*reference, frame, matches) < 15) return false;
  frame.map_points = matches;
  frame.T_cw = last_frame_ && last_frame_->has_pose ? last_frame_->T_cw : reference->pose();
  optimisePose(frame);
  return discardOutliers(frame) >= 10;
}

bool Tracking::relocalise(Frame& frame) {
  ScopedStage stage(timer_, "relocalisation");
  BowVector bow;
  FeatureVector features;
  vocabulary_->transform(frame.descriptors, bow, features);
  for (KeyFrame* keyframe : selectPlaceCandidates(*database_, map_, bow, {}, 0.0)) {
    std::vector<MapPoint*> matches;
    if (searchByBoW(*keyframe, frame, features, matches) < kRelocMinBowMatches) continue;

    // PnP with RANSAC on the BoW matches (seeded by the keyframe: deterministic).
    // The inlier threshold is chi-square 5.991 at the keypoint's scale, as ORB-SLAM2's.
    std::vector<Vec3> points_w;
    std::vector<Vec2> pixels;
    std::vector<double> pixel_sigma;
    std::vector<int> keypoint_of;
    for (size_t i = 0; i < matches.size(); ++i) {
      if (!matches[i]) continue;
      points_w.push_back(matches[i]->position());
      pixels.push_back(frame.point(i));
      pixel_sigma.push_back(frame.pyramid->scale[frame.keypoints[i].octave]);
      keypoint_of.push_back(static_cast<int>(i));
    }
    const PnpResult pnp = solvePnpRansac(points_w, pixels, frame.camera->Keigen(), 300, std::sqrt(5.991), 10,
                                         static_cast<uint32_t>(keyframe->id()), pixel_sigma);
    if (!pnp.success) continue;
    const SE3 T_cw = pnp.T_cw;
    const std::vector<int>& inliers = pnp.inliers;
    frame.T_cw = T_cw;
    frame.map_points.assign(frame.size(), nullptr);
    for (int k : inliers) frame.map_points[keypoint_of[k]] = matches[keypoint_of[k]];
    if (refineRelocalisedPose(frame, *keyframe) >= kRelocMinInliers) {
      reference_keyframe_ = keyframe;
      return true;
    }
  }
  frame.map_points.assign(frame.size(), nullptr);
  return false;
}

int Tracking::refineRelocalisedPose(Frame& frame, const KeyFrame& candidate) {
  optimisePose(frame);
  int good = discardOutliers(frame);
  if (good < 10) return good;
  // Too few: project the candidate's other points with the new pose, then optimise again.
  if (good < kRelocMinInliers) {
    const int added = searchByProjection(frame, candidate, frame.map_points, 10.0, 100);
    if (good + added >= kRelocMinInliers) {
      optimisePose(frame);
      good = discardOutliers(frame);
      if (good < kRelocMinInliers) {
        searchByProjection(frame, candidate, frame.map_points, 3.0, 64);
        optimisePose(frame);
        good = discardOutliers(frame);
      }
    }
  }
  return good;
}

void Tracking::updateLocalMap(Frame& frame) {
  // Keyframes that see the frame's points, voting by how many they see.
  KeyFrameMap<int> votes;
  for (size_t i = 0; i < frame.size(); ++i) {
    MapPoint* point = frame.map_points[i];
    if (!point) continue;
    if (point->isBad()) {
      frame.map_points[i] = nullptr;
      continue;
    }
    for (const auto& [keyframe, index] : point->observations()) ++votes[keyframe];
  }
  local_keyframes_.clear();
  KeyFrame* best = nullptr;
  int best_votes = 0;
  for (const auto& [keyframe, count] : votes) {
    if (keyframe->isBad()) continue;
    if (count > best_votes || (count == best_votes && best && keyframe->id() < best->id())) {
      best_votes = count;
      best = keyframe;
    }
    local_keyframes_.push_back(keyframe);
    keyframe->track_local_for_frame = frame.id;
  }
  // Their neighbours, children and parents widen the local map.
  const size_t direct = local_keyframes_.size();
  for (size_t k = 0; k < direct && local_keyframes_.size() < kMaxLocalKeyFrames; ++k) {
    KeyFrame* keyframe = local_keyframes_[k];
    auto add = [&](KeyFrame* other) {
      if (!other || other->isBad() || other->track_local_for_frame == frame.id) return false;
      other->track_local_for_frame = frame.id;
      local_keyframes_.push_back(other);
      return true;
    };
    for (KeyFrame* neighbour : keyframe->bestCovisibles(10))
      if (add(neighbour)) break;
    for (KeyFrame* child : keyframe->children())
      if (add(child)) break;
    add(keyframe->parent());
  }
  if (best) reference_keyframe_ = best;

  local_points_.clear();
  for (KeyFrame* keyframe : local_keyframes_)
    for (MapPoint* point : keyframe->mapPoints()) {
      if (!point || point->isBad() || point->track_reference_frame == frame.id) continue;
      point->track_reference_frame = frame.id;
      local_points_.push_back(point);
    }
}

bool Tracking::trackLocalMap(Frame& frame) {
  updateLocalMap(frame);
  // Points already matched are not searched again.
  for (size_t i = 0; i < frame.size(); ++i) {
    MapPoint* point = frame.map_points[i];
    if (!point) continue;
    if (!localization_only_) point->increaseVisible();
    point->last_frame_seen = frame.id;
    point->track_in_view = false;
  }
  int to_match = 0;
  for (MapPoint* point : local_points_) {
    if (point->last_frame_seen == frame.id || point->isBad()) continue;
    if (isInFrustum(point, frame)) {
      if (!localization_only_) point->increaseVisible();
      ++to_match;
    }
  }
  if (to_match > 0) {
    const bool just_relocalised = last_relocalisation_frame_id_ >= 0 && frame.id < last_relocalisation_frame_id_ + 2;
    searchLocalPoints(frame, local_points_, just_relocalised ? 5.0 : 1.0);
  }
  local_map_matches_ = static_cast<int>(std::count_if(frame.map_points.begin(), frame.map_points.end(),
                                                      [](const MapPoint* point) { return point != nullptr; }));
  optimisePose(frame);
  if (frame.labels.size() == frame.size() && checkMovingObjects(frame)) optimisePose(frame);

  if (!localization_only_)
    for (size_t i = 0; i < frame.size(); ++i)
      if (frame.map_points[i] && !frame.outlier[i]) frame.map_points[i]->increaseFound();
  matches_inliers_ = mapInliers(frame, false);
  return matches_inliers_ >= inliersNeeded(frame);
}

int Tracking::inliersNeeded(const Frame& frame) const {
  const bool recently_relocalised =
      last_relocalisation_frame_id_ >= 0 &&
      frame.id < last_relocalisation_frame_id_ + config_.tracking.max_frames_between_keyframes;
  return recently_relocalised ? 50 : config_.tracking.min_inliers;
}

bool Tracking::checkMovingObjects(Frame& frame) {
  bool any_parked = false;
  std::vector<bool> consistent;
  std::vector<ObjectMotionVerdict> verdicts = checkObjectMotion(frame, &consistent);
  // A verdict that would leave the frame too few matches to stay tracked is
  // not trusted: the pose it rests on came from too little of the view (an
  // object filling the frame, as fr3_teddy's bear). The boxes stay undecided
  // and their points are kept.
  if (mapInliers(frame, true) < inliersNeeded(frame)) {
    for (ObjectMotionVerdict& verdict : verdicts)
      if (verdict.motion == ObjectMotion::Moving) verdict.motion = ObjectMotion::Unchecked;
    for (FeatureLabel& label : frame.labels)
      if (label.motion == ObjectMotion::Moving) label.motion = ObjectMotion::Unchecked;
  }
  for (const ObjectMotionVerdict& verdict : verdicts) {
    ++moving_object_stats_.boxes_checked;
    if (verdict.motion == ObjectMotion::Parked) {
      ++moving_object_stats_.parked;
      any_parked = true;
    } else if (verdict.motion == ObjectMotion::Moving) {
      ++moving_object_stats_.moving;
    } else {
      ++moving_object_stats_.undecided;
    }
  }
  // A moving instance's map points were made while it stood still (or on an
  // earlier, wrong verdict): the object has moved on, so they are retired.
  // Matches that agree with the pose (the static scene seen past the object)
  // are only let go.
  for (size_t i = 0; i < frame.size(); ++i) {
    MapPoint* point = frame.map_points[i];
    if (!point || !onMovingObject(frame.labels[i])) continue;
    frame.map_points[i] = nullptr;
    frame.outlier[i] = false;
    if (!consistent[i] && !point->isBad() && point->observationCount() > 0) {
      point->setBad();
      ++moving_object_stats_.points_retired;
    }
  }
  return any_parked;  // its points join the pose
}

bool Tracking::needNewKeyFrame(const Frame& frame) const {
  if (!reference_keyframe_) return false;
  const TrackingParams& params = config_.tracking;
  const int keyframes_in_map = static_cast<int>(map_.keyframeCount());
  if (!keyFrameAllowedAfterRelocalisation(frame.id, last_relocalisation_frame_id_, params.max_frames_between_keyframes,
                                          static_cast<size_t>(keyframes_in_map)))
    return false;
  const int min_observations = keyframes_in_map <= 2 ? 2 : 3;
  const int reference_points = reference_keyframe_->trackedMapPoints(min_observations);
  const long frames_since = frame.id - last_keyframe_frame_id_;

  // The paper's rule: at least 20 frames since the last keyframe or fewer than
  // 100 tracked points, and fewer than 90 % of the reference keyframe's points tracked.
  // RGB-D adds ORB-SLAM2's two RGB-D conditions: few close points tracked
  // while many close ones could be added (the map thins where depth is best),
  // or fewer than a quarter of the reference keyframe's points tracked (the
  // camera is leaving its map faster than 20 frames; on fr3_teddy this takes
  // keyframe ATE from 1.1-1.3 to 0.7-0.85 cm, docs/BENCHMARKS.md).
  const bool rgbd = config_.sensor == SensorMode::RgbD;
  const bool need_close_points = needCloseKeyFrame(frame);
  const bool leaving_map = rgbd && matches_inliers_ < kRgbdLeavingMapRatio * reference_points;
  const bool enough_time_or_weak = frames_since >= params.max_frames_between_keyframes ||
                                   matches_inliers_ < params.min_tracked_points || need_close_points || leaving_map;
  const bool new_content =
      (matches_inliers_ < params.ref_ratio * reference_points || need_close_points) && matches_inliers_ > 15;
  if (!(enough_time_or_weak && new_content)) return false;
  // Local Mapping must be ready to take it; otherwise ask it to wrap up its BA.
  if (local_mapping_.acceptsKeyFrames()) return true;
  if (insertion_ != KeyFrameInsertion::DropWhenBusy) return true;  // inserted once the mapper has caught up
  if (local_mapping_.paused()) return false;  // a loop is being corrected: no keyframe, as ORB-SLAM
  local_mapping_.interruptBundleAdjustment();
  // Weak tracking cannot wait for an idle mapper (fast forward motion loses the
  // map within a few frames): queue one keyframe behind the one in work.
  return matches_inliers_ < params.min_tracked_points && local_mapping_.queuedKeyFrames() < 1;
}

bool Tracking::needCloseKeyFrame(const Frame& frame) const {
  if (config_.sensor != SensorMode::RgbD || !frame.hasDepthImage()) return false;
  const double close_depth = frame.camera->closeDepth();
  int tracked_close = 0, untracked_close = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    if (!frame.hasDepth(i) || frame.depth[i] >= close_depth) continue;
    if (frame.map_points[i] && !frame.outlier[i])
      ++tracked_close;
    else
      ++untracked_close;
  }
  return tracked_close < kCloseTrackedFew && untracked_close > kCloseUntrackedMany;
}

void Tracking::addCloseDepthPoints(KeyFrame* keyframe, Frame& frame) {
  // ORB-SLAM2: the keypoints with depth, nearest first; every one without a
  // point becomes one, until past the close depth with at least 100 points
  // counted (tracked ones included).
  std::vector<std::pair<float, size_t>> by_depth;
  // Not on objects that may move: a box judged parked from the static scene
  // behind it still holds the walking person's own pixels, and a point made
  // from depth is trusted at once. Parked objects get their points by
  // triangulation, which needs them to hold still between keyframes.
  const bool has_labels = keyframe->labels.size() == keyframe->size();
  for (size_t i = 0; i < keyframe->size(); ++i)
    if (keyframe->hasDepth(i) && !(has_labels && keyframe->labels[i].motion != ObjectMotion::NotMovable))
      by_depth.emplace_back(keyframe->depth[i], i);
  std::sort(by_depth.begin(), by_depth.end());
  const double close_depth = keyframe->camera().closeDepth();
  int counted = 0, created = 0;
  for (const auto& [depth, i] : by_depth) {
    MapPoint* existing = keyframe->mapPoint(i);
    if (!existing || existing->isBad()) {
      // The frame tracks it too, so the next frame's motion model finds it.
      frame.map_points[i] = createPointFromDepth(keyframe, i);
      frame.outlier[i] = false;
      ++created;
    }
    ++counted;
    if (depth > close_depth && counted > kNewKeyFrameMinDepthPoints) break;
  }
  spdlog::debug("keyframe {}: {} points from depth", keyframe->id(), created);
}

void Tracking::createKeyFrame(Frame& frame) {
  last_keyframe_was_weak_ = matches_inliers_ < config_.tracking.min_tracked_points;
  KeyFrame* keyframe = map_.createKeyFrame(frame);
  keyframe->setFallbackParent(reference_keyframe_);
  if (config_.sensor == SensorMode::RgbD && frame.hasDepthImage())
    addCloseDepthPoints(keyframe, frame);
  reference_keyframe_ = keyframe;
  last_keyframe_ = keyframe;
  last_keyframe_frame_id_ = frame.id;
  ++keyframes_created_;
  spdlog::debug("keyframe {} from frame {}: {} points tracked{}", keyframe->id(), frame.index, matches_inliers_,
                last_keyframe_was_weak_ ? " (weak)" : "");
  local_mapping_.insertKeyFrame(keyframe);
}

void Tracking::recordMatches(const Frame& frame, FrameRecord& record) const {
  // The matches the tracked pose rests on, by the same rule.
  const std::vector<bool> for_pose = matchesForPose(frame);
  for (size_t i = 0; i < frame.size(); ++i) {
    if (!for_pose[i] || frame.outlier[i]) continue;
    // Localisation's odometry points belong to no keyframe and are freed a frame later.
    if (localization_only_ && frame.map_points[i]->observationCount() == 0) continue;
    record.matches.push_back({frame.map_points[i], frame.point(i).cast<float>(),
                              static_cast<float>(frame.pyramid->inv_sigma2[frame.keypoints[i].octave]),
                              static_cast<float>(frame.rightCoordinate(i))});
  }
}

// One frame: its matches' points as the map now holds them (fused points
// followed to the point that took their observations, culled ones left out),
// and the pose optimisation Tracking uses, from the frame's current pose.
// With a rolling shutter (camera.readout_s > 0) each match is corrected for
// its row's time at the camera's `velocity`, twice (the correction is exact
// at the pose it is computed from). A frame left with fewer than 30 matches
// or inliers keeps its pose and is not counted in `refinement`.
static void refineFramePose(const PinholeCamera& camera, const CameraVelocity& velocity, FrameRecord& record,
                            Tracking::FrameRefinement& refinement) {
  constexpr size_t kMinMatches = 30;
  std::vector<FrameRecord::Match> matches;
  matches.swap(record.matches);  // the record's are freed whatever happens below
  if (!record.tracked || !record.reference || matches.size() < kMinMatches) return;
  // A live keyframe's frame keeps the keyframe's pose, which the final BA set.
  if (record.made_keyframe && !record.reference->isBad()) return;
  std::vector<Vec3> points_w;
  std::vector<Observation2D> observations;
  for (const FrameRecord::Match& match : matches) {
    MapPoint* point = match.point;
    // A few hops at most; the bound only guards against a cycle.
    for (int hop = 0; hop < 16 && point->replacement(); ++hop) point = point->replacement();
    if (point->isBad()) continue;
    // A NaN u_right (monocular) stays NaN, kNoRightCoordinate, as a double.
    observations.push_back(
        {static_cast<int>(points_w.size()), match.pixel.cast<double>(), match.inv_sigma2, double(match.u_right)});
    points_w.push_back(point->position());
  }
  if (observations.size() < kMinMatches) return;
  KeyFrame* live = nullptr;
  PoseOptimizationResult result;
  result.T_cw = poseThroughReference(record.reference, record.T_c_ref, &live);
  const int passes = camera.readout_s > 0 ? 2 : 1;
  std::vector<Vec3> seen_w = points_w;
  for (int pass = 0; pass < passes; ++pass) {
    // The undistorted row stands in for the sensor row (they differ by a few
    // pixels but near the corners).
    if (camera.readout_s > 0)
      for (const Observation2D& observation : observations)
        seen_w[observation.point] = pointSeenAtRowTime(result.T_cw, points_w[observation.point], velocity,
                                                       rowTime(observation.pixel.y(), camera.height, camera.readout_s));
    result = optimizePose(camera, camera.bf, result.T_cw, seen_w, observations);
  }
  if (result.n_inliers < static_cast<int>(kMinMatches)) return;
  const ProjectionModel model(camera, camera.bf);
  for (size_t o = 0; o < observations.size(); ++o) {
    if (!result.inlier[o]) continue;
    const Observation2D& observation = observations[o];
    refinement.chi2 += checkReprojection(model, result.T_cw, seen_w[observation.point], observation.pixel,
                                         observation.u_right, observation.inv_sigma2)
                           .chi2;
    ++refinement.inlier_matches;
  }
  ++refinement.frames;
  record.reference = live;
  record.T_c_ref = result.T_cw * live->pose().inverse();
}

std::vector<CameraVelocity> Tracking::frameVelocities() const {
  std::vector<std::optional<SE3>> poses(records_.size());
  for (size_t k = 0; k < records_.size(); ++k)
    if (records_[k].tracked && records_[k].reference)
      poses[k] = poseThroughReference(records_[k].reference, records_[k].T_c_ref);
  std::vector<CameraVelocity> velocities(records_.size());
  for (size_t k = 0; k < records_.size(); ++k) {
    const size_t before = k > 0 && poses[k - 1] ? k - 1 : k;
    const size_t after = k + 1 < records_.size() && poses[k + 1] ? k + 1 : k;
    const double dt = records_[after].timestamp - records_[before].timestamp;
    if (poses[before] && poses[after] && dt > 0) velocities[k] = velocityBetween(*poses[before], *poses[after], dt);
  }
  return velocities;
}

Tracking::FrameRefinement Tracking::refineFramePoses(const PinholeCamera& camera) {
  // The other threads have stopped and the caller holds the map lock, so the
  // map is only read here: the frames are split between this thread and one
  // more (map.hpp).
  // A rolling shutter needs each frame's velocity: from its neighbours' poses
  // as the final map places them, before any is changed here.
  const std::vector<CameraVelocity> velocities =
      camera.readout_s > 0 ? frameVelocities() : std::vector<CameraVelocity>(records_.size());
  auto refineRange = [&](size_t begin, size_t end) {
    FrameRefinement refinement;
    for (size_t k = begin; k < end; ++k) refineFramePose(camera, velocities[k], records_[k], refinement);
    return refinement;
  };
  const size_t half = records_.size() / 2;
  // std::async: an exception on either half reaches the caller (the future
  // waits for its thread), instead of terminating the process.
  std::future<FrameRefinement> second_half = std::async(std::launch::async, refineRange, half, records_.size());
  FrameRefinement total = refineRange(0, half);
  total += second_half.get();
  return total;
}

void Tracking::resetMap() {
  // Stop the other threads' work on the old map first: nothing may hold its
  // pointers or ids (queued keyframes, consistency groups, a running full BA).
  local_mapping_.reset();
  if (loop_closing_) loop_closing_->reset();
  std::lock_guard<std::mutex> lock(map_.mutex());
  // Keyframes of the failed map no longer exist as references for the trajectory.
  for (FrameRecord& record : records_) {
    record.tracked = false;
    record.reference = nullptr;
    record.matches.clear();
  }
  local_keyframes_.clear();
  local_points_.clear();
  reference_keyframe_ = nullptr;
  last_keyframe_ = nullptr;
  last_frame_.reset();
  velocity_.reset();
  keyframes_created_ = 0;
  initialised_at_index_ = -1;
  state_ = TrackingState::NotInitialized;
  ++map_resets_;
  map_.clear();
}

}  // namespace vslam
