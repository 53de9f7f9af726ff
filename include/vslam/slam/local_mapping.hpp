#pragma once
// The Local Mapping thread: takes new keyframes from Tracking, links them into
// the map, culls weak points, triangulates new ones with covisible keyframes,
// fuses duplicates, runs local bundle adjustment and culls redundant keyframes.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <list>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/map/map.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"

namespace vslam {

class Vocabulary;
class KeyframeDatabase;
class LoopClosing;

// Culls the covisible neighbours of `keyframe` that are redundant: more than
// `redundant_ratio` of their points are seen by at least three other keyframes
// at the same scale, a finer one, or one pyramid level coarser (as ORB-SLAM2
// counts them). Returns the keyframes culled (set bad), in the
// order they were examined. Caller holds the map lock.
// `close_points_only` (RGB-D): only keypoints with depth below the close depth count.
std::vector<KeyFrame*> cullRedundantKeyFrames(KeyFrame* keyframe, double redundant_ratio,
                                              bool close_points_only = false);

// The keyframes a new keyframe is triangulated against: its `covisible_count`
// best covisible keyframes, then, while fewer than `min_neighbours`, those of
// the `min_neighbours` keyframes before it along the spanning tree (parent,
// grandparent, ...) that are live and not among them yet, nearest first.
// Caller holds the map lock.
std::vector<KeyFrame*> triangulationNeighbours(KeyFrame* keyframe, size_t covisible_count, int min_neighbours);

class LocalMapping {
 public:
  LocalMapping(const Config& config, Map& map, StageTimer* timer);
  ~LocalMapping();

  // Called by Tracking (or initialisation) with a keyframe not yet linked into the map.
  void insertKeyFrame(KeyFrame* keyframe);
  // True when the queue is empty and no keyframe is being processed.
  bool acceptsKeyFrames() const { return accepting_.load(); }
  size_t queuedKeyFrames() const;
  // Back-pressure for offline runs: blocks until the queue is empty and no
  // keyframe is being processed (or the thread has failed or stopped). The
  // caller must not hold the map lock. The wait is bounded by the mapping of
  // one keyframe (its local BA has a fixed iteration cap).
  void waitUntilIdle();
  // Blocks until every inserted keyframe has been linked into the map with its
  // new points (triangulation and fusion done; its local BA may still run), or
  // the thread has failed or stopped. The caller must not hold the map lock.
  void waitUntilLinked();
  // The first exception that stopped the thread, or null.
  std::exception_ptr failure() const;
  // Asks a running local BA to stop early (a new keyframe is waiting).
  void interruptBundleAdjustment() { abort_ba_.store(true); }

  // Drops queued keyframes and waits until nothing is being processed (map reset).
  void reset();

  // Place recognition: each processed keyframe gets its bag of words, enters
  // the database (culled ones leave it) and goes on to Loop Closing. Any may be null.
  void setPlaceRecognition(const Vocabulary* vocabulary, KeyframeDatabase* database, LoopClosing* loop_closing) {
    vocabulary_ = vocabulary;
    database_ = database;
    loop_closing_ = loop_closing;
  }

  // Called after each keyframe is mapped, on the mapping thread (see SystemOptions).
  void setAfterKeyFrameHook(std::function<void(long)> hook) { after_keyframe_ = std::move(hook); }

  // Loop Closing stops the thread while it corrects a loop or merges a full
  // BA: pause() returns once every queued keyframe is linked and mapped, so
  // that no keyframe sits unlinked (outside the covisibility graph and the
  // spanning tree) while the map is corrected; until resume() no keyframe is
  // taken, Tracking inserts none (waitUntilIdle blocks, acceptsKeyFrames() is
  // false) and paused() is true.
  void pause();
  void resume();
  bool paused() const;

  // Deterministic mode: processes every queued keyframe on the caller's thread.
  void processQueued();
  // Threaded mode.
  void start();
  void finish();  // processes what is queued, then stops the thread

  int localBundleAdjustments() const { return local_ba_count_.load(); }
  int culledKeyFrames() const { return culled_keyframes_.load(); }

 private:
  void run();
  bool queueEmpty() const;
  void processKeyFrame(KeyFrame* keyframe);
  void markLinked();
  void linkKeyFrame(KeyFrame* keyframe);
  void cullRecentMapPoints(KeyFrame* keyframe);
  void triangulateNewPoints(KeyFrame* keyframe);
  void fuseDuplicates(KeyFrame* keyframe);
  void localBundleAdjustment(KeyFrame* keyframe);
  void maybeRecordBundleProblem(const PinholeCamera& camera, const BundleProblem& problem);

  Config config_;
  Map& map_;
  StageTimer* timer_;

  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyFrame*> queue_;
  std::atomic<bool> accepting_{true};
  bool processing_ = false;  // guarded by queue_mutex_
  std::atomic<bool> abort_ba_{false};
  bool finish_requested_ = false;
  bool paused_ = false;  // guarded by queue_mutex_
  bool pause_requested_ = false;  // guarded by queue_mutex_
  std::exception_ptr failure_;  // guarded by queue_mutex_
  long inserted_count_ = 0;     // keyframes inserted; guarded by queue_mutex_
  long linked_count_ = 0;       // of those, linked (or dropped); guarded by queue_mutex_
  std::thread thread_;
  const Vocabulary* vocabulary_ = nullptr;
  KeyframeDatabase* database_ = nullptr;
  LoopClosing* loop_closing_ = nullptr;
  std::function<void(long)> after_keyframe_;

  std::list<MapPoint*> recent_points_;  // touched only by the mapping step
  // Written by the mapping thread, read by the caller's (statistics).
  std::atomic<int> local_ba_count_{0};
  std::atomic<int> culled_keyframes_{0};

  // $VSLAM_RECORD_BA=path: the first local BA problem with at least
  // $VSLAM_RECORD_BA_MIN_KEYFRAMES (default 10) free keyframes is saved there
  // (saveBundleProblem, before optimisation) for bench_optimize; read once at
  // construction, empty = off.
  std::string record_ba_path_;
  size_t record_ba_min_keyframes_ = 10;
};

}  // namespace vslam
