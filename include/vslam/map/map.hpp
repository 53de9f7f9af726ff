#pragma once
// The map database: every keyframe and map point of a run. It is the only
// state the SLAM threads share.
//
// Locking rule (the one place it is written down): keyframes, map points and
// their graph links are read or written only while holding `Map::mutex()`.
// Tracking holds it while it matches against and updates the map for a frame
// (not during feature extraction or detection; the next frame's extraction
// and detection run on threads of their own that never touch the map,
// slam/extraction_ahead.hpp and detect/detection_stage.hpp); Local Mapping and Loop Closing
// hold it for each step that reads or changes the map, and release it while
// Ceres solves (they copy values into plain optimisation problems and copy the
// results back under the lock). System::saveMap holds it once for the whole
// save, grouping the object landmarks and writing the file, so that the file
// is one state of the map (System::objectMap holds it only while it reads the
// points). Objects are never freed during a run — a culled keyframe or point
// is only flagged bad — so a pointer taken under the lock stays valid after it
// is released, though its contents may then change.
//
// Loop closing adds three rules. (1) Loop Closing pauses Local Mapping
// (LocalMapping::pause/resume) and holds the lock for the whole correction
// (propagation, fusion, essential-graph optimisation, write-back), so no
// keyframe is linked half-way through it; Tracking waits for that one step.
// (2) The full BA after a loop (and the final BA) solves without the lock and
// merges under it; whatever changed meanwhile follows the spanning tree. (3) A
// keyframe's bag of words is written once, by Local Mapping without the lock,
// before the keyframe enters the KeyframeDatabase; nobody reads it earlier.
// (4) Between verifying a loop and correcting it Loop Closing releases the
// lock; it holds both loop keyframes (KeyFrame::holdFromErase) so that Local
// Mapping cannot cull them meanwhile, and re-checks them under the lock.
// Tracking re-derives its last frame's pose from its reference keyframe every
// frame, so local BA and loop corrections reach the motion model.
// (5) At the end of a run, after the final BA, System::finish holds the lock
// while Tracking poses its frames again on two threads (refineFramePoses);
// the other threads have stopped, both only read the map, and each writes
// its own frames' records.
//
// Back-pressure (offline runs, Tracking::KeyFrameInsertion::WaitForMapping):
// Tracking never holds the lock while it waits for Local Mapping. It inserts
// a keyframe only when Local Mapping is idle (waiting for the keyframe in
// hand), and before tracking a frame it waits until the last keyframe's new
// points are linked into the map (LocalMapping::waitUntilLinked), so no
// keyframe is dropped and the map Tracking sees does not depend on the
// machine's speed. A map reset (lost right after initialisation) first
// drains Local Mapping and Loop Closing (queued ids, consistency groups, a
// running full BA), then clears the map under the lock.
//
// Counters read across threads (statistics) are atomics or guarded by their
// owner's queue mutex; an exception on a worker thread stops that thread and
// is rethrown on the caller's by System.
#include <memory>
#include <mutex>
#include <vector>

#include "vslam/map/keyframe.hpp"
#include "vslam/map/map_point.hpp"

namespace vslam {

class Map {
 public:
  std::mutex& mutex() const { return mutex_; }

  KeyFrame* createKeyFrame(const Frame& frame);
  MapPoint* createMapPoint(const Vec3& position_w, KeyFrame* reference);

  // A saved map coming back (map_io/): objects with the ids they were saved
  // with, in increasing id order; ids made later continue after the largest.
  // Throws std::logic_error for an id not above every id already in the map.
  KeyFrame* restoreKeyFrame(long id, const Frame& frame);
  MapPoint* restoreMapPoint(long id, const Vec3& position_w, KeyFrame* reference, long first_keyframe_id);

  // Live (not bad) objects, in creation order.
  std::vector<KeyFrame*> keyframes() const;
  std::vector<MapPoint*> mapPoints() const;
  size_t keyframeCount() const;
  size_t mapPointCount() const;
  KeyFrame* firstKeyFrame() const { return keyframes_.empty() ? nullptr : keyframes_.front().get(); }
  // Every keyframe ever created, bad ones included (trajectory output follows culled keyframes' children).
  const std::vector<std::unique_ptr<KeyFrame>>& allKeyFrames() const { return keyframes_; }
  // The keyframe with this id (bad ones included), or nullptr.
  KeyFrame* keyFrameById(long id) const;
  long maxKeyFrameId() const { return next_keyframe_id_ - 1; }

  // Destroys everything (a failed initialisation) and restarts the ids at 0.
  // Only when no thread holds pointers or ids of the old map.
  void clear();

 private:
  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<KeyFrame>> keyframes_;
  std::vector<std::unique_ptr<MapPoint>> map_points_;
  long next_keyframe_id_ = 0;
  long next_map_point_id_ = 0;
};

}  // namespace vslam
