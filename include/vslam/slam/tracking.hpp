#pragma once
// Tracking: runs on the caller's thread for every frame. Initialises the map
// from two views, then tracks with a constant-velocity model (falling back to
// the reference keyframe), refines against the local map, and decides when a
// new keyframe is needed (the paper's rules).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/map/map.hpp"

namespace vslam {

class LocalMapping;
class Vocabulary;
class KeyframeDatabase;

enum class TrackingState { NotInitialized, Ok, Lost };

// What became of one frame, kept for the trajectory: its pose relative to its
// reference keyframe, so later keyframe corrections carry over.
struct FrameRecord {
  long frame_id = -1;
  int index = -1;
  double timestamp = 0;
  bool tracked = false;
  KeyFrame* reference = nullptr;
  SE3 T_c_ref;  // frame camera <- reference keyframe camera
};

class Tracking {
 public:
  Tracking(const Config& config, Map& map, LocalMapping& local_mapping, StageTimer* timer, bool deterministic);

  // Relocalisation needs both; without them a lost frame only retries the reference keyframe.
  void setPlaceRecognition(const Vocabulary* vocabulary, const KeyframeDatabase* database) {
    vocabulary_ = vocabulary;
    database_ = database;
  }
  int relocalisations() const { return relocalisations_; }

  // Tracks one frame; returns true when its pose is known.
  bool track(Frame& frame);

  TrackingState state() const { return state_; }
  const std::vector<FrameRecord>& records() const { return records_; }
  int initialisedAtIndex() const { return initialised_at_index_; }
  int keyframesCreated() const { return keyframes_created_; }
  int lastTrackedPoints() const { return last_tracked_points_; }

 private:
  void initialise(Frame& frame);
  bool trackWithMotionModel(Frame& frame);
  bool trackReferenceKeyFrame(Frame& frame);
  bool trackLocalMap(Frame& frame);
  bool relocalise(Frame& frame);
  int optimisePose(Frame& frame);  // returns inliers, removes outlier matches' effects
  void updateLocalMap(Frame& frame);
  bool needNewKeyFrame(const Frame& frame) const;
  void createKeyFrame(Frame& frame);
  void resetMap();

  Config config_;
  Map& map_;
  LocalMapping& local_mapping_;
  StageTimer* timer_;
  bool deterministic_;

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
  int initialised_at_index_ = -1;
  int keyframes_created_ = 0;
  std::vector<FrameRecord> records_;
  const Vocabulary* vocabulary_ = nullptr;
  const KeyframeDatabase* database_ = nullptr;
  int relocalisations_ = 0;
  int seen_big_change_ = 0;
};

}  // namespace vslam
