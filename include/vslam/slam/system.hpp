#pragma once
// The System facade: owns the map, runs Tracking on the caller's thread and
// Local Mapping on its own (or synchronously in deterministic mode), and gives
// back trajectories and the map for export.
#include <atomic>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/core/types.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/map/id_order.hpp"
#include "vslam/map/object_map.hpp"

namespace vslam {

class Map;
class LocalMapping;
class Tracking;
class FrameBuilder;
class ExtractionAhead;
class Vocabulary;
class KeyframeDatabase;
class LoopClosing;
struct LoopRecord;
struct LoopClosingState;
class DetectionStage;

struct SystemOptions {
  bool deterministic = false;  // Local Mapping runs synchronously after each keyframe
  // Live camera (--realtime): a keyframe needed while Local Mapping is busy is
  // skipped, as ORB-SLAM does, instead of waiting for it (the offline default).
  bool realtime = false;
  // Called on the Local Mapping thread after each keyframe is mapped (its id);
  // may be empty. For observers such as tests; an exception thrown here stops
  // Local Mapping like any other and reaches the caller of processFrame/finish.
  std::function<void(long)> after_keyframe_mapped;
};

// How a run ends (System::finish).
struct FinishOptions {
  bool final_ba = true;  // false: no final BA even when config.loop.final_ba (an interrupted run)
  // Set by another thread (or a signal handler): the final BA stops after its
  // current iteration and its result is dropped, the map left as it was.
  const std::atomic<bool>* abort_final_ba = nullptr;
};

struct ExportedMapPoint {
  long id;
  Vec3 position;
  cv::Vec3b bgr;
  int class_id;
  int observations;
};

struct ExportedKeyFrame {
  long id;
  int frame_index;
  double timestamp;
  SE3 T_wc;
};

struct SystemStats {
  int frames = 0;
  int frames_tracked = 0;
  int keyframes = 0;
  int map_points = 0;
  int initialised_at_index = -1;
  std::string start_failure;  // with no map started: why the last attempt failed (Tracking::lastStartFailure)
  int local_bundle_adjustments = 0;
  int culled_keyframes = 0;
  int relocalisations = 0;
  int map_resets = 0;       // maps thrown away after losing tracking right after initialisation
  int keyframe_waits = 0;   // keyframes that waited for Local Mapping (back-pressure)
  int implausible_loops_rejected = 0;
  int frames_without_depth = 0;  // RGB-D: frames without a paired depth image, tracked as monocular
  int frames_extracted_ahead = 0;  // frames whose ORB features were extracted on the extraction thread
  // With a loaded map (System::loadMap): tracked frames whose reference
  // keyframe came from the file, i.e. localised against the old map; -1 without one.
  int frames_in_loaded_map = -1;
  // --localize with depth: tracked frames carried by visual odometry alone
  // (under 10 map points matched), not counted in frames_in_loaded_map.
  int frames_by_odometry = 0;
  // The motion check of --moving-classes boxes (all 0 without it).
  int moving_boxes_checked = 0, moving_boxes_moving = 0, moving_boxes_parked = 0, moving_boxes_undecided = 0;
  int moving_points_retired = 0;
  // Frames posed again after the final BA (loop.refine_frames), and the mean
  // chi-square reprojection error of their inlier matches there (0 when none).
  int frames_posed_again = 0;
  long refined_inlier_matches = 0;
  double refined_mean_chi2 = 0;
};

// The detector's part of a run, for report.json's "detector".
struct DetectionSummary {
  bool enabled = false;      // false: --detector none (plain ORB-SLAM)
  std::string model;         // model name ("custom" for explicit cfg/weights)
  std::string cfg;           // cfg file used
  int input_size = 0;       // network input width (square networks: the size)
  int input_height = 0;
  bool placeholder_weights = false;  // weights that have seen no training image: timing only
  int frames = 0;            // frames the keypoint filter ran on
  double median_ms = 0.0;    // network time per frame (detection thread)
  double wait_median_ms = 0.0;            // Tracking's time blocked on detection per frame
  double keypoints_added_per_frame = 0.0;   // median, from boxes (Algorithm 1)
  double keypoints_removed_per_frame = 0.0; // median, inside dynamic-class boxes
  double boxes_used_per_frame = 0.0;        // median
  long keypoints_added_total = 0;
  // Issue 15: which frames the network saw and how the others got their boxes.
  std::string detect_every;   // "1", "N", "keyframes" or "auto"
  std::string box_filter;     // "paper", "reuse" or "label"
  int network_frames = 0;     // detections used (one network run each)
  int fresh_frames = 0;       // frames with a box of their own detection
  int carried_frames = 0;     // frames with only carried boxes, or none
  double box_age_median = 0.0;  // frames, over every box handed to the filter
  double carried_iou_median = -1.0;  // every N-th frame, N > 1: carried box against the fresh one (-1: none)
  int boxes_expired = 0;      // carried boxes dropped for age
  int boxes_unmoved = 0;      // carried boxes dropped for too few matches to move them
  long frame_keypoints_reused_total = 0;  // "reuse": box winners that were frame keypoints already
  long duplicates_dropped_total = 0;      // "paper": box keypoints extracted again and dropped as the frame's own
};

class System {
 public:
  System(const Config& config, const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // Tracks one image (BGR or grey); `depth_m` CV_32F metres, registered to it,
  // or empty. Depth is used only when config.sensor is RgbD; a monocular
  // system ignores it. Returns true when tracked.
  // With a detector, the frame's detections come first: those started by
  // submitAhead(), else detection runs now and Tracking waits for all of it.
  bool processFrame(int index, double timestamp, const cv::Mat& image, const cv::Mat& depth_m = cv::Mat());
  // Starts work on a frame processFrame() will get next, on threads of its
  // own while Tracking works on the current frame: its ORB extraction (not
  // with options.deterministic, where one thread works at a time) and its
  // detection (with a detector, unless that frame was already submitted).
  // `image` must not change until that frame has been processed.
  void submitAhead(int index, const cv::Mat& image);
  // Lets Local Mapping and Loop Closing finish their queues, stops the
  // threads, then runs the final full bundle adjustment (config.loop.final_ba
  // and options.final_ba) and poses every tracked frame again in the final
  // map (config.loop.refine_frames). Returns true when a final BA result was merged.
  bool finish(const FinishOptions& options = FinishOptions());

  std::vector<StampedPose> frameTrajectory() const;     // every tracked frame, T_wc
  std::vector<StampedPose> keyframeTrajectory() const;  // live keyframes, T_wc
  std::vector<int> lostFrameIndices() const;
  std::vector<ExportedMapPoint> mapPoints() const;
  std::vector<ExportedKeyFrame> keyFrames() const;
  SystemStats stats() const;
  std::vector<LoopRecord> loops() const;  // verified and corrected loops, in order
  // Trajectories as they were before the final full BA; empty when it did not run.
  const std::vector<StampedPose>& frameTrajectoryBeforeFinalBa() const { return frames_before_final_ba_; }
  const std::vector<StampedPose>& keyframeTrajectoryBeforeFinalBa() const { return keyframes_before_final_ba_; }
  DetectionSummary detectionSummary() const;
  // Object landmarks from the map points' classes (empty without a detector);
  // the link distance is relative to the median keyframe-to-point depth.
  std::vector<ObjectLandmark> objectMap(const ObjectMapParams& params = ObjectMapParams()) const;
  int lastTrackedPoints() const;
  // Writes the whole map, its object landmarks and what it was made with to
  // `path` (SQLite, docs/MAPS.md), atomically; `sequence` is recorded for
  // people. The objects are grouped and the map written under one hold of the
  // map lock, so the file is one state of the map even while Local Mapping and
  // Loop Closing run. Throws InputError naming `path` when it cannot be written.
  void saveMap(const std::string& path, const std::string& sequence) const;
  // Loads a saved map before the first frame (throws std::logic_error later):
  // refused with an InputError naming `path` when it is corrupt or was made
  // with another camera, mode, ORB pyramid or vocabulary. Tracking then
  // relocalises in it; with `localize` (ORB-SLAM2's localisation mode) no
  // keyframe is made, nothing in the map changes and no final BA runs,
  // otherwise mapping continues in it. Returns the keyframes and points loaded.
  std::pair<int, int> loadMap(const std::string& path, bool localize);
  int lastMatchedPoints() const;  // before the pose optimisation's outlier rejection
  // The vocabulary file loaded ("" without one), as resolveVocabularyPath found it.
  const std::string& vocabularyPath() const { return vocabulary_path_; }
  StageTimer& timer() { return timer_; }
  // Loop Closing's bookkeeping (empty state without it); waits for the keyframe in hand.
  LoopClosingState loopClosingState() const;

 private:
  bool runFinalBundleAdjustment(const FinishOptions& options);
  // The ORB feature count for the next frame in the present tracking state (-1: the configured one).
  int featuresToExtract() const;
  // With a rolling shutter, the camera's velocity at each keyframe, from the
  // tracked frames beside it (the final BA poses keyframes at their middle
  // rows); a monocular map's without its translation. Empty without one.
  KeyFrameMap<CameraVelocity> keyframeVelocities() const;
  Config config_;
  SystemOptions options_;
  // Rethrows, on the caller's thread, an exception that stopped a worker thread.
  void rethrowWorkerFailure() const;

  StageTimer timer_;
  std::unique_ptr<Map> map_;
  std::unique_ptr<Vocabulary> vocabulary_;  // null: no relocalisation by BoW, no loop closing
  std::string vocabulary_path_;              // "" without a vocabulary
  std::unique_ptr<KeyframeDatabase> database_;
  std::unique_ptr<DetectionStage> detection_;  // nullptr for --detector none; before frame_builder_, which uses its class ids
  std::unique_ptr<FrameBuilder> frame_builder_;
  std::unique_ptr<ExtractionAhead> extraction_ahead_;  // nullptr when deterministic
  std::unique_ptr<LocalMapping> local_mapping_;
  std::unique_ptr<Tracking> tracking_;
  std::unique_ptr<LoopClosing> loop_closing_;
  std::vector<StampedPose> frames_before_final_ba_, keyframes_before_final_ba_;
  long next_frame_id_ = 0;
  long loaded_max_keyframe_id_ = -1;  // keyframes up to this id came from a loaded map
  bool localize_ = false;             // loaded with localize: the map is never changed
  int frames_without_depth_ = 0;
  // What posing the frames again after the final BA found (System::finish).
  int frames_posed_again_ = 0;
  long refined_inlier_matches_ = 0;
  double refined_chi2_ = 0;
  bool finished_ = false;
  // Keypoint filter outcome per frame (Tracking's thread only).
  std::vector<int> keypoints_added_, keypoints_removed_, boxes_used_, keypoints_reused_, duplicates_dropped_;
};

}  // namespace vslam
