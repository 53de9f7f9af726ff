#pragma once
// Tracking: runs on the caller's thread for every frame. Initialises the map
// from two views, then tracks with a constant-velocity model (falling back to
// the reference keyframe), refines against the local map, and decides when a
// new keyframe is needed (the paper's rules).
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/map/map.hpp"

namespace vslam {

class LocalMapping;
class LoopClosing;
class Vocabulary;
class KeyframeDatabase;

enum class TrackingState { NotInitialized, Ok, Lost };

// What Tracking does with a keyframe it needs while Local Mapping is busy.
enum class KeyFrameInsertion {
  // Deterministic mode: Local Mapping runs on Tracking's thread after each frame.
  Synchronous,
  // Offline threaded runs (images from disk, the default): never drop a
  // keyframe; wait, without the map lock, until Local Mapping has finished the
  // keyframe in hand, then insert. Tracking is never more than one keyframe
  // ahead of the map, so the result does not depend on the machine's speed.
  WaitForMapping,
  // Live (--realtime): as ORB-SLAM, skip the keyframe while Local Mapping is
  // busy (asking it to stop its BA), unless tracking is weak and nothing is queued.
  DropWhenBusy,
};

// ORB-SLAM2's rules after a relocalisation, by frame id (`last_relocalisation`
// < 0: none yet). The frame right after one is tracked from its reference
// keyframe: a velocity measured across a relocalisation means nothing.
bool motionModelAllowed(long frame_id, long last_relocalisation);
// No keyframe for `max_frames` frames after a relocalisation while the map
// holds more than `max_frames` keyframes: the relocalised pose must hold
// before the map grows from it (a small map may still need keyframes).
bool keyFrameAllowedAfterRelocalisation(long frame_id, long last_relocalisation, int max_frames,
                                        size_t keyframes_in_map);

// The monocular start's matches as the two-view initialiser takes them: the
// points (undistorted pixels) and each one's pixel variance at its pyramid
// level, sigma_px^2 * scale^(2 * level). The window search may match above
// level 0 (initializer.window_max_level); scored as level 0, such matches
// would fail the H/F and triangulation gates too often.
struct InitialisationMatches {
  std::vector<Vec2> pts_ref, pts_cur;
  std::vector<double> sigma2_ref, sigma2_cur;
  std::vector<std::pair<int, int>> pairs;  // (reference keypoint, current keypoint)
};
InitialisationMatches initialisationMatches(const Frame& reference, const Frame& current,
                                            const std::vector<int>& matches_ref_cur, double sigma_px);

// What became of one frame, kept for the trajectory: its pose relative to its
// reference keyframe, so later keyframe corrections carry over.
struct FrameRecord {
  long frame_id = -1;
  int index = -1;
  double timestamp = 0;
  bool tracked = false;
  KeyFrame* reference = nullptr;
  SE3 T_c_ref;  // frame camera <- reference keyframe camera
  // --localize with depth: tracked by visual odometry alone (under 10 map
  // points matched), not localised against the map.
  bool by_odometry = false;
  // The frame became a keyframe: `reference`. While that keyframe lives the
  // frame's pose is its; once culled, the frame is posed again from its matches.
  bool made_keyframe = false;
  // The frame's inlier matches, kept until the run ends (loop.refine_frames):
  // 24 bytes each, about 5 KB a frame on TUM sequences.
  struct Match {
    MapPoint* point = nullptr;
    Eigen::Vector2f pixel = Eigen::Vector2f::Zero();  // undistorted
    float inv_sigma2 = 1.0f;
    float u_right = std::numeric_limits<float>::quiet_NaN();  // NaN: monocular
  };
  std::vector<Match> matches;
};

class Tracking {
 public:
  Tracking(const Config& config, Map& map, LocalMapping& local_mapping, StageTimer* timer,
           KeyFrameInsertion insertion);

  // Relocalisation needs both; without them a lost frame only retries the reference keyframe.
  void setPlaceRecognition(const Vocabulary* vocabulary, const KeyframeDatabase* database) {
    vocabulary_ = vocabulary;
    database_ = database;
  }
  int relocalisations() const { return relocalisations_; }
  // What the motion check of --moving-classes boxes found, over the run.
  struct MovingObjectStats {
    int boxes_checked = 0;  // box-frames judged or left undecided
    int moving = 0;
    int parked = 0;
    int undecided = 0;       // too few matched points to judge
    int points_retired = 0;  // map points on instances found moving
  };
  const MovingObjectStats& movingObjectStats() const { return moving_object_stats_; }
  // A map reset (lost right after initialisation) also resets Loop Closing.
  void setLoopClosing(LoopClosing* loop_closing) { loop_closing_ = loop_closing; }
  int mapResets() const { return map_resets_; }
  int keyframeWaits() const { return keyframe_waits_; }  // keyframes that waited for Local Mapping
  // Frames the constant-velocity model failed to track (the reference keyframe was tried instead).
  int motionModelMisses() const { return motion_model_misses_; }
  int atRestAttempts() const { return at_rest_attempts_; }  // calls of trackFromLastFrameAtRest, tracked or not
  bool localizingByOdometry() const { return odometry_only_; }

  // A map loaded from a file (System::loadMap): the first frame relocalises
  // in it instead of initialising a new one, and the map is never reset.
  // `localization_only` is ORB-SLAM2's localisation mode: no keyframe is made
  // and nothing in the map changes (not even its points' found/visible
  // counts); tracking relocalises whenever it is lost and otherwise tracks
  // frame to frame (motion model) and against the local map. With depth, as
  // in ORB-SLAM2, the motion model also matches temporary points made from
  // the last frame's depth, so that a camera leaving the mapped area is
  // carried by visual odometry while every frame tries to relocalise.
  void startInLoadedMap(bool localization_only);
  bool localizationOnly() const { return localization_only_; }

  // Tracks one frame; returns true when its pose is known.
  bool track(Frame& frame);

  TrackingState state() const { return state_; }
  // After the final BA (the map lock held, the other threads stopped): poses
  // each tracked frame again against the points it matched, where the map now
  // holds them. Says how many frames were moved, and the reprojection error
  // of their inlier matches at the new poses (what calibrates
  // camera.readout_s: docs/GEOMETRY.md, "Rolling shutter").
  struct FrameRefinement {
    int frames = 0;
    long inlier_matches = 0;
    double chi2 = 0;  // summed over those matches
    FrameRefinement& operator+=(const FrameRefinement& other) {
      frames += other.frames;
      inlier_matches += other.inlier_matches;
      chi2 += other.chi2;
      return *this;
    }
  };
  FrameRefinement refineFramePoses(const PinholeCamera& camera);
  // The camera's velocity at each record (records()), from its neighbours'
  // poses as the map now places them: central where both are tracked, else
  // one-sided, else standing still. The caller holds the map lock.
  std::vector<CameraVelocity> frameVelocities() const;
  const std::vector<FrameRecord>& records() const { return records_; }
  int initialisedAtIndex() const { return initialised_at_index_; }
  // Why the last attempt to start a map failed ("frame 15 against frame 0:
  // 612 matches, insufficient parallax ..."); empty before any attempt. A run
  // that never starts a map reports it.
  const std::string& lastStartFailure() const { return start_failure_; }
  int keyframesCreated() const { return keyframes_created_; }
  // Relocalisation's step after PnP (ORB-SLAM2's): optimises `frame`'s pose on
  // its matches; while fewer than 50 hold, adds the candidate keyframe's other
  // points by projection (10 px, then 3 px) and optimises again. Returns the
  // inliers kept; relocalisation succeeds at 50.
  int refineRelocalisedPose(Frame& frame, const KeyFrame& candidate);
  // The frame right after a relocalisation, when its reference keyframe gives
  // too few matches: the last (relocalised) frame's points are searched by
  // projection at the last frame's pose, a camera at rest, and the pose is
  // optimised (ours; ORB-SLAM2 is lost again and relocalises the next frame).
  // True with 10 inliers, as the motion model.
  bool trackFromLastFrameAtRest(Frame& frame);
  int lastTrackedPoints() const { return last_tracked_points_; }
  // Map points matched in the last frame's local-map search, before the pose
  // optimisation rejected outliers (0 when it was not tracked).
  int lastMatchedPoints() const { return last_matched_points_; }

 private:
  void recordMatches(const Frame& frame, FrameRecord& record) const;
  void initialise(Frame& frame);
  void initialiseFromDepth(Frame& frame);  // RGB-D: one frame, metric map
  // After either initialisation: `frame` is the last frame, the last of
  // `keyframes` its reference, and the keyframes and points the local map.
  void startTracking(const Frame& frame, std::vector<KeyFrame*> keyframes, std::vector<MapPoint*> points);
  // A map point at keypoint `keypoint`'s depth, observed by `keyframe` (map lock held).
  MapPoint* createPointFromDepth(KeyFrame* keyframe, size_t keypoint);
  bool needCloseKeyFrame(const Frame& frame) const;
  void addCloseDepthPoints(KeyFrame* keyframe, Frame& frame);
  bool trackWithMotionModel(Frame& frame);
  // Localisation mode after a frame tracked by odometry alone: the motion
  // model and relocalisation both, the relocalised pose preferred.
  bool trackByOdometryOrRelocalise(Frame& frame);
  // Localisation mode with depth: the last frame's close keypoints without a
  // map point get temporary points, never put into the map.
  void addOdometryPoints(Frame& last);
  // Unlinks the temporary points from `frame` and the last frame, and frees them.
  void dropOdometryPoints(Frame& frame);
  bool trackReferenceKeyFrame(Frame& frame);
  bool trackLocalMap(Frame& frame);
  bool relocalise(Frame& frame);
  int optimisePose(Frame& frame);  // returns inliers, removes outlier matches' effects
  void updateLocalMap(Frame& frame);
  bool needNewKeyFrame(const Frame& frame) const;
  // Judges the frame's movable-class boxes under its pose, drops and retires
  // what is on moving ones; true when a parked one's points should join the pose.
  bool checkMovingObjects(Frame& frame);
  int inliersNeeded(const Frame& frame) const;  // matches a frame needs to count as tracked
  void createKeyFrame(Frame& frame);
  void resetMap();
  // The last frame's pose again from its reference keyframe (following culled
  // ones up the spanning tree), so that local BA and loop corrections reach the
  // motion model's prediction.
  void refreshLastFramePose();

  Config config_;
  Map& map_;
  LocalMapping& local_mapping_;
  StageTimer* timer_;
  KeyFrameInsertion insertion_;
  LoopClosing* loop_closing_ = nullptr;

  TrackingState state_ = TrackingState::NotInitialized;
  std::unique_ptr<Frame> init_reference_;   // first frame of a two-view initialisation attempt
  std::vector<cv::Point2f> init_prev_matched_;
  std::optional<Frame> last_frame_;
  std::optional<SE3> velocity_;  // T_cur_last
  KeyFrame* reference_keyframe_ = nullptr;
  KeyFrame* last_keyframe_ = nullptr;
  long last_keyframe_frame_id_ = -1;
  long last_relocalisation_frame_id_ = -1;
  std::vector<KeyFrame*> local_keyframes_;
  std::vector<MapPoint*> local_points_;
  int matches_inliers_ = 0;
  int last_tracked_points_ = 0;
  int local_map_matches_ = 0;  // matches the last trackLocalMap optimised the pose on
  int last_matched_points_ = 0;
  int initialised_at_index_ = -1;
  std::string start_failure_;
  int keyframes_created_ = 0;
  std::vector<FrameRecord> records_;
  const Vocabulary* vocabulary_ = nullptr;
  const KeyframeDatabase* database_ = nullptr;
  int relocalisations_ = 0;
  MovingObjectStats moving_object_stats_;
  int map_resets_ = 0;
  int keyframe_waits_ = 0;
  int motion_model_misses_ = 0;
  int at_rest_attempts_ = 0;
  bool last_keyframe_was_weak_ = false;  // made with fewer than min_tracked_points tracked
  bool map_loaded_ = false;          // started in a loaded map: never reset it
  bool localization_only_ = false;   // --localize: the map is read, never changed
  bool odometry_only_ = false;       // --localize: the last frame matched under 10 map points
  std::vector<std::unique_ptr<MapPoint>> odometry_points_;  // the last frame's temporary points
};

}  // namespace vslam
