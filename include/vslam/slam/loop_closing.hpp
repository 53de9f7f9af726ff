#pragma once
// The Loop Closing thread: takes each keyframe Local Mapping has finished,
// looks for a place seen before (bag-of-words candidates consistent over
// consecutive keyframes), verifies it with a Sim(3) between the two keyframes,
// and corrects the drift: the loop's map points are fused, the essential graph
// is optimised as a Sim(3) pose graph, then the whole map by bundle
// adjustment. See docs/LOOP_CLOSING.md.
//
// Threads: in threaded mode it runs on its own thread; in deterministic mode
// System calls processQueued() after every frame. Local Mapping is paused
// while a loop is corrected (map.hpp's locking note).
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/geometry/rolling_shutter.hpp"
#include "vslam/map/id_order.hpp"
#include "vslam/map/map.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {

class LocalMapping;

struct LoopRecord {
  long current_keyframe = -1;
  long matched_keyframe = -1;
  double scale = 1.0;  // of the Sim(3) from the matched keyframe's camera to the current one's
  int inliers = 0;     // map point matches supporting it after the projection search
};

struct FullBundleAdjustmentResult {
  int keyframes = 0;
  int points = 0;
  double initial_cost = 0;
  double final_cost = 0;
  bool merged = false;  // false when aborted (or nothing to optimise): the map was left as it was
};

// How a full BA shares the map with the other threads.
struct FullBundleAdjustmentControl {
  // Set by another thread to stop the solver after its current iteration; the
  // result is then discarded (a newer loop correction made it stale).
  const std::atomic<bool>* abort = nullptr;
  // Paused while the result is merged, so that a local BA solved against the
  // old poses cannot write them back afterwards.
  LocalMapping* local_mapping = nullptr;
};

// Bundle adjustment of every live keyframe and map point, the first keyframe
// fixed: the problem is copied under the map lock, solved without it, and
// merged back under it. Keyframes created meanwhile follow their spanning-tree
// parent's correction; points not in the problem follow their reference
// keyframe. Used after a loop correction (on its own thread) and as the final
// BA of a run. With `velocities` (the camera's velocity at each keyframe,
// from Tracking's frames; a keyframe without one is taken as standing still)
// and a camera with a rolling shutter (camera.readout_s > 0), each observation
// is taken at its row's time and the keyframes are posed at their middle rows
// (rolling_shutter.hpp).
FullBundleAdjustmentResult runFullBundleAdjustment(Map& map, int iterations,
                                                   const FullBundleAdjustmentControl& control = {},
                                                   const KeyFrameMap<CameraVelocity>* velocities = nullptr);

// Plausibility of a loop's Sim(3) scale correction. Monocular scale drifts by
// a few per cent over a loop; a correction outside [0.5, 2] more often means a
// wrong or degenerate match (far or planar points, a repeated texture) than
// real drift, and closing it would warp the whole map. Such a loop is closed
// only when the geometry verifies it strongly: at least 3x the usual inliers
// (after the projection search). Within [0.5, 2] the usual minimum applies.
struct LoopScaleRule {
  double min_plausible_scale = 0.5;
  double max_plausible_scale = 2.0;
  int min_inliers = 40;            // ORB-SLAM's value
  int min_inliers_implausible = 120;
};
bool loopAccepted(double scale, int inliers, const LoopScaleRule& rule = {});

// ORB-SLAM2's covisibility consistency. Each loop candidate of a keyframe
// comes with its group (itself and its covisible keyframes). A group that
// overlaps no group of the previous keyframe's candidates starts at
// consistency 0; one that overlaps takes the highest overlapping consistency
// plus 1. A candidate is accepted once its consistency reaches `threshold`
// (3): 3 consistent detections after the first, so 4 consecutive keyframes.
struct ConsistentGroup {
  std::set<long> keyframe_ids;
  int consistency = 0;
};
// Replaces `groups` (the previous keyframe's) by the candidates' groups and
// returns the indices of the accepted candidates.
std::vector<size_t> updateConsistentGroups(std::vector<ConsistentGroup>& groups,
                                           const std::vector<std::set<long>>& candidate_groups, int threshold);

// The essential graph takes a link that loop fusion created only when the two
// keyframes share at least `min_weight` map points (ORB-SLAM2's 100, as for
// covisibility edges): a weak new link measures little and would pull the
// corrected side with the weight of a strong one. The link between the
// current and the matched keyframe, the loop itself, always enters.
bool loopLinkEntersEssentialGraph(int covisibility_weight, bool is_the_loop_link, int min_weight = 100);

// What Loop Closing holds between keyframes (for tests and reports).
struct LoopClosingState {
  size_t queued = 0;
  size_t consistent_groups = 0;
  long last_loop_keyframe_id = -1;
  bool full_ba_running = false;
};

class LoopClosing {
 public:
  LoopClosing(const Config& config, Map& map, const Vocabulary& vocabulary, KeyframeDatabase& database,
              LocalMapping& local_mapping, StageTimer* timer);
  ~LoopClosing();

  // Called by Local Mapping when a keyframe is processed and in the database.
  void insertKeyFrame(KeyFrame* keyframe);

  void processQueued();  // deterministic mode: on the caller's thread
  void start();          // threaded mode
  // Processes what is queued, stops the thread, then waits for a running full BA to merge.
  void finish();
  // Map reset: drops queued keyframes and consistency groups, waits for the
  // keyframe in hand, and stops a running full BA without merging it.
  void reset();
  LoopClosingState state() const;
  // The first exception that stopped the thread (or its full BA), or null.
  std::exception_ptr failure() const;
  // Loops rejected by loopAccepted() although their inliers passed the usual minimum.
  int implausibleLoopsRejected() const { return implausible_rejected_.load(); }

  std::vector<LoopRecord> loops() const;

 private:
  struct LoopCandidate {
    KeyFrame* matched = nullptr;
    Sim3 S_cw;                            // corrected similarity of the current keyframe
    std::vector<MapPoint*> matched_points;  // per keypoint of the current keyframe
    std::vector<MapPoint*> loop_points;     // the matched keyframe's and its neighbours' points
    double scale = 1.0;
    int inliers = 0;
  };

  void run();
  void process(long keyframe_id);
  // Caller holds the map lock for these two.
  std::vector<KeyFrame*> detectCandidates(KeyFrame* current);
  bool computeSim3(KeyFrame* current, const std::vector<KeyFrame*>& candidates, LoopCandidate& loop);
  // False (and nothing changed) when a keyframe of the loop went bad meanwhile.
  bool correctLoop(KeyFrame* current, LoopCandidate& loop);
  // The full BA after a correction: on its own thread in threaded mode, so that
  // the next keyframes are checked for loops meanwhile; inline in deterministic mode.
  void startFullBundleAdjustment();
  // Stops a running full BA without merging it (its poses predate a new correction).
  void abortFullBundleAdjustment();

  Config config_;
  Map& map_;
  const Vocabulary& vocabulary_;
  KeyframeDatabase& database_;
  LocalMapping& local_mapping_;
  StageTimer* timer_;

  std::vector<ConsistentGroup> consistent_groups_;
  long last_loop_keyframe_id_ = -1;

  mutable std::mutex mutex_;  // guards queue_, finish_requested_, processing_, failure_, loops_
  mutable std::condition_variable cv_;
  std::deque<long> queue_;  // keyframe ids: a map reset may free queued keyframes
  bool finish_requested_ = false;
  bool processing_ = false;
  std::exception_ptr failure_;
  std::atomic<int> implausible_rejected_{0};
  std::vector<LoopRecord> loops_;
  std::thread thread_;

  std::thread full_ba_thread_;  // started and joined by the Loop Closing thread (or finish())
  std::atomic<bool> full_ba_abort_{false};
};

}  // namespace vslam
