#include "vslam/slam/local_mapping.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <string>

#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"
#include "vslam/geometry/triangulation.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
#include "vslam/optimize/reprojection.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/map_matching.hpp"

namespace vslam {
namespace {

constexpr size_t kTriangulationNeighbours = 20;       // monocular, as ORB-SLAM
constexpr size_t kTriangulationNeighboursDepth = 10;  // RGB-D, as ORB-SLAM2
// ORB-SLAM2 fuses with 10 in RGB-D; that was no faster here and no more
// accurate (docs/BENCHMARKS.md), so both modes use 20.
constexpr size_t kFuseNeighbours = 20;
constexpr size_t kFuseSecondNeighbours = 5;

}  // namespace

LocalMapping::LocalMapping(const Config& config, Map& map, StageTimer* timer)
    : config_(config), map_(map), timer_(timer) {
  if (const char* path = std::getenv("VSLAM_RECORD_BA")) record_ba_path_ = path;
  if (const char* count = std::getenv("VSLAM_RECORD_BA_MIN_KEYFRAMES")) {
    const int parsed = std::atoi(count);
    if (parsed <= 0) throw InputError("VSLAM_RECORD_BA_MIN_KEYFRAMES must be a positive integer, not '" +
                                      std::string(count) + "'");
    record_ba_min_keyframes_ = static_cast<size_t>(parsed);
  }
}

// Saves one problem, then switches itself off (the path is cleared).
void LocalMapping::maybeRecordBundleProblem(const PinholeCamera& camera, const BundleProblem& problem) {
  size_t free_keyframes = 0;
  for (const auto& keyframe : problem.keyframes)
    if (!keyframe.fixed) ++free_keyframes;
  if (free_keyframes < record_ba_min_keyframes_) return;
  try {
    saveBundleProblem(record_ba_path_, camera, camera.bf, problem);
    spdlog::info("recorded a local BA problem ({} keyframes, {} free, {} points, {} observations) in {}",
                 problem.keyframes.size(), free_keyframes, problem.points.size(), problem.observations.size(),
                 record_ba_path_);
  } catch (const std::exception& e) {
    spdlog::warn("VSLAM_RECORD_BA: {}", e.what());  // a debugging aid: never stops the run
  }
  record_ba_path_.clear();
}

LocalMapping::~LocalMapping() { finish(); }

void LocalMapping::insertKeyFrame(KeyFrame* keyframe) {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    queue_.push_back(keyframe);
    ++inserted_count_;
    accepting_.store(false);
  }
  abort_ba_.store(true);
  queue_cv_.notify_all();
}

void LocalMapping::waitUntilIdle() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  queue_cv_.wait(lock, [this] {
    return (queue_.empty() && !processing_ && !paused_ && !pause_requested_) || failure_ || !thread_.joinable() ||
           finish_requested_;
  });
}

void LocalMapping::waitUntilLinked() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  queue_cv_.wait(lock, [this] {
    return linked_count_ >= inserted_count_ || failure_ || !thread_.joinable() || finish_requested_;
  });
}

void LocalMapping::markLinked() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    // Every keyframe taken from the queue so far (the one in hand included) is linked.
    linked_count_ = inserted_count_ - static_cast<long>(queue_.size());
  }
  queue_cv_.notify_all();
}

std::exception_ptr LocalMapping::failure() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return failure_;
}

size_t LocalMapping::queuedKeyFrames() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return queue_.size();
}

void LocalMapping::reset() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  queue_.clear();
  queue_cv_.wait(lock, [this] { return !processing_; });
  linked_count_ = inserted_count_;
  recent_points_.clear();
  if (database_) database_->clear();  // keyframe ids restart with the new map
  accepting_.store(true);
}

void LocalMapping::processQueued() {
  while (true) {
    KeyFrame* keyframe = nullptr;
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      if (queue_.empty()) {
        accepting_.store(true);
        return;
      }
      keyframe = queue_.front();
      queue_.pop_front();
    }
    abort_ba_.store(false);
    processKeyFrame(keyframe);
  }
}

void LocalMapping::pause() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  pause_requested_ = true;
  accepting_.store(false);
  abort_ba_.store(true);
  // In deterministic mode (no thread) the caller has already processed the queue.
  queue_cv_.wait(lock, [this] { return (queue_.empty() && !processing_) || failure_ || !thread_.joinable(); });
  paused_ = true;
  pause_requested_ = false;
}

void LocalMapping::resume() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    paused_ = false;
    accepting_.store(queue_.empty() && !processing_);
  }
  queue_cv_.notify_all();
}

bool LocalMapping::paused() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return paused_ || pause_requested_;
}

void LocalMapping::start() {
  finish_requested_ = false;
  thread_ = std::thread([this] { run(); });
}

void LocalMapping::finish() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    finish_requested_ = true;
  }
  queue_cv_.notify_all();
  thread_.join();
}

void LocalMapping::run() {
  while (true) {
    KeyFrame* keyframe = nullptr;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      if (queue_.empty() && !paused_ && !pause_requested_) accepting_.store(true);
      queue_cv_.wait(lock, [this] { return !paused_ && (!queue_.empty() || finish_requested_); });
      if (queue_.empty()) return;  // finish requested and nothing left
      keyframe = queue_.front();
      queue_.pop_front();
      processing_ = true;
      accepting_.store(false);
    }
    abort_ba_.store(false);
    std::exception_ptr failure;
    try {
      processKeyFrame(keyframe);
    } catch (...) {
      failure = std::current_exception();  // reaches the caller through failure()
    }
    {
      std::lock_guard<std::mutex> lock(queue_mutex_);
      processing_ = false;
      if (failure) {
        failure_ = failure;
        queue_.clear();
      }
      linked_count_ = inserted_count_ - static_cast<long>(queue_.size());  // as markLinked(): done, linked or not
      // Idle from here: say so before waiters of waitUntilIdle() wake up.
      if (queue_.empty() && !paused_ && !pause_requested_) accepting_.store(true);
    }
    queue_cv_.notify_all();
    if (failure) return;
  }
}

bool LocalMapping::queueEmpty() const {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return queue_.empty();
}

void LocalMapping::processKeyFrame(KeyFrame* keyframe) {
  ScopedStage stage(timer_, "local_mapping");
  if (vocabulary_ && !keyframe->hasBow()) {
    // Without the map lock: a keyframe's descriptors never change, and no other
    // thread reads its bag of words before it enters the database below.
    ScopedStage bow_stage(timer_, "bow");
    vocabulary_->transform(keyframe->descriptors, keyframe->bow, keyframe->bow_features);
  }
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    if (keyframe->isBad()) return;
    linkKeyFrame(keyframe);
    cullRecentMapPoints(keyframe);
    triangulateNewPoints(keyframe);
    if (queueEmpty()) fuseDuplicates(keyframe);
  }
  markLinked();  // Tracking may go on with this keyframe's points while the local BA runs
  bool enough_keyframes;
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    enough_keyframes = map_.keyframeCount() > 2;
  }
  if (queueEmpty() && enough_keyframes) {
    localBundleAdjustment(keyframe);
    std::lock_guard<std::mutex> lock(map_.mutex());
    for (KeyFrame* culled : cullRedundantKeyFrames(keyframe, config_.mapping.redundant_keyframe_ratio,
                                                            config_.sensor == SensorMode::RgbD)) {
      if (database_) database_->erase(culled->id());
      ++culled_keyframes_;
    }
  }
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    if (keyframe->isBad()) return;
    if (database_ && keyframe->hasBow()) database_->add(keyframe->id(), keyframe->bow);
  }
  if (loop_closing_) loop_closing_->insertKeyFrame(keyframe);
  if (after_keyframe_) after_keyframe_(keyframe->id());
}

void LocalMapping::linkKeyFrame(KeyFrame* keyframe) {
  const ScalePyramid& pyramid = keyframe->pyramid();
  for (size_t i = 0; i < keyframe->size(); ++i) {
    MapPoint* point = keyframe->mapPoint(i);
    if (!point) continue;
    if (point->isBad()) {
      keyframe->setMapPoint(i, nullptr);
      continue;
    }
    if (point->keypointIn(keyframe) < 0) {
      point->addObservation(keyframe, static_cast<int>(i));
      point->updateNormalAndDepth(pyramid);
      point->updateDescriptor();
      point->updateClass();
    } else if (point->firstKeyframeId() == keyframe->id() || point->observationCount() == 2) {
      // Created together with this keyframe (map initialisation): watch it like a new point.
      if (std::find(recent_points_.begin(), recent_points_.end(), point) == recent_points_.end())
        recent_points_.push_back(point);
    }
  }
  keyframe->updateConnections();
}

void LocalMapping::cullRecentMapPoints(KeyFrame* keyframe) {
  const int min_observations = config_.mapping.min_observations;
  for (auto it = recent_points_.begin(); it != recent_points_.end();) {
    MapPoint* point = *it;
    const long age = keyframe->id() - point->firstKeyframeId();
    if (point->isBad()) {
      it = recent_points_.erase(it);
    } else if (point->foundRatio() < config_.mapping.min_found_ratio) {
      point->setBad();
      it = recent_points_.erase(it);
    } else if (age >= 2 && point->observationWeight() < min_observations) {
      // The paper's rule: a point must be seen in at least 3 keyframes.
      point->setBad();
      it = recent_points_.erase(it);
    } else if (age >= 3) {
      point->confirm(min_observations);  // survived its probation: the rule now holds for good
      it = recent_points_.erase(it);
    } else {
      ++it;
    }
  }
}

// A keypoint its frame's motion check put on a moving object makes no map point.
static bool onMovingObjectAt(const KeyFrame& keyframe, int index) {
  return keyframe.labels.size() == keyframe.size() && onMovingObject(keyframe.labels[index]);
}

static bool mayMoveAt(const KeyFrame& keyframe, int index) {
  return keyframe.labels.size() == keyframe.size() && keyframe.labels[index].motion != ObjectMotion::NotMovable;
}

void LocalMapping::triangulateNewPoints(KeyFrame* keyframe) {
  const PinholeCamera& camera = keyframe->camera();
  const ScalePyramid& pyramid = keyframe->pyramid();
  const Mat3 K_inv = camera.Keigen().inverse();
  const SE3& T1 = keyframe->pose();
  const Vec3 C1 = keyframe->cameraCentre();
  const double ratio_factor = 1.5 * pyramid.scale_factor;
  int created = 0;

  const bool rgbd = config_.sensor == SensorMode::RgbD;
  const double min_parallax_cos = std::cos(config_.mapping.min_parallax_deg * M_PI / 180.0);
  const ProjectionModel model(camera, camera.bf);
  const double baseline = camera.baseline();
  // ORB-SLAM2 triangulates with 10 neighbours when depth is measured, 20 when not.
  const size_t neighbours = rgbd ? kTriangulationNeighboursDepth : kTriangulationNeighbours;
  const std::vector<KeyFrame*> neighbour_keyframes =
      triangulationNeighbours(keyframe, neighbours, config_.mapping.min_triangulation_neighbours);
  for (KeyFrame* neighbour : neighbour_keyframes) {
    const Vec3 C2 = neighbour->cameraCentre();
    // Too short a baseline for the scene depth gives unreliable depth; with
    // depth, a motion shorter than the virtual stereo baseline adds nothing.
    if (rgbd ? (C2 - C1).norm() < baseline : (C2 - C1).norm() / neighbour->medianSceneDepth() < 0.01) continue;
    const std::vector<std::pair<int, int>> matches = searchForTriangulation(*keyframe, *neighbour);
    const SE3& T2 = neighbour->pose();
    Eigen::Matrix<double, 3, 4> P1, P2;
    P1 << T1.R, T1.t;
    P2 << T2.R, T2.t;
    for (const auto& [i1, i2] : matches) {
      if (onMovingObjectAt(*keyframe, i1) || onMovingObjectAt(*neighbour, i2)) continue;
      const cv::KeyPoint& kp1 = keyframe->keypoints[i1];
      const cv::KeyPoint& kp2 = neighbour->keypoints[i2];
      const Vec3 xn1 = K_inv * keyframe->point(i1).homogeneous();
      const Vec3 xn2 = K_inv * neighbour->point(i2).homogeneous();
      const Vec3 ray1 = T1.R.transpose() * xn1;
      const Vec3 ray2 = T2.R.transpose() * xn2;
      const double parallax_cos = ray1.dot(ray2) / (ray1.norm() * ray2.norm());
      // The parallax a keypoint's depth gives on its own: the angle its
      // virtual stereo pair subtends (cos 2 > any ray parallax: no depth).
      // On an object that may move, depth alone would make a point of a walking
      // person at once: there only the two views' parallax may place a point.
      const bool movable = mayMoveAt(*keyframe, i1) || mayMoveAt(*neighbour, i2);
      const bool depth1 = !movable && keyframe->hasDepth(i1), depth2 = !movable && neighbour->hasDepth(i2);
      const double stereo_cos1 = depth1 ? std::cos(2 * std::atan2(baseline / 2, keyframe->depth[i1])) : 2.0;
      const double stereo_cos2 = depth2 ? std::cos(2 * std::atan2(baseline / 2, neighbour->depth[i2])) : 2.0;
      const double stereo_cos = std::min(stereo_cos1, stereo_cos2);
      Vec3 X;
      if (parallax_cos > 0 && parallax_cos < stereo_cos && (depth1 || depth2 || parallax_cos < min_parallax_cos)) {
        // The two rays see the point from further apart than any depth reading does.
        if (!triangulateDlt(P1, P2, xn1.head<2>(), xn2.head<2>(), X)) continue;
      } else if (depth1 && stereo_cos1 < stereo_cos2) {
        X = keyframe->unprojectToWorld(i1);
      } else if (depth2 && stereo_cos2 < stereo_cos1) {
        X = neighbour->unprojectToWorld(i2);
      } else {
        continue;  // no parallax
      }
      const Vec3 p1 = T1 * X, p2 = T2 * X;
      if (p1.z() <= 0 || p2.z() <= 0) continue;
      // Reprojection within the 95 % chi-square bound at each keypoint's scale
      // (with the right coordinate where the keypoint has depth).
      auto reprojects = [&](const KeyFrame& kf, int i) {
        const double u_right = kf.rightCoordinate(i);
        return checkReprojection(model, kf.pose(), X, kf.point(i), u_right, pyramid.inv_sigma2[kf.keypoints[i].octave])
                   .chi2 <= chi2Bound95(u_right);
      };
      if (!reprojects(*keyframe, i1) || !reprojects(*neighbour, i2)) continue;
      // The distance ratio must agree with the pyramid levels the point was seen at.
      const double dist1 = (X - C1).norm(), dist2 = (X - C2).norm();
      if (dist1 <= 0 || dist2 <= 0) continue;
      const double ratio_dist = dist2 / dist1;
      const double ratio_octave = pyramid.scale[kp1.octave] / pyramid.scale[kp2.octave];
      if (ratio_dist * ratio_factor < ratio_octave || ratio_dist > ratio_octave * ratio_factor) continue;

      MapPoint* point = map_.createMapPoint(X, keyframe);
      point->addObservation(keyframe, i1);
      point->addObservation(neighbour, i2);
      keyframe->setMapPoint(i1, point);
      neighbour->setMapPoint(i2, point);
      point->setColour(keyframe->colours[i1]);
      point->updateDescriptor();
      point->updateNormalAndDepth(pyramid);
      point->updateClass();
      recent_points_.push_back(point);
      ++created;
    }
  }
  spdlog::debug("keyframe {}: {} new map points from {} neighbour keyframes", keyframe->id(), created,
                neighbour_keyframes.size());
}

void LocalMapping::fuseDuplicates(KeyFrame* keyframe) {
  std::vector<KeyFrame*> targets;
  for (KeyFrame* neighbour : keyframe->bestCovisibles(kFuseNeighbours)) {
    if (neighbour->fuse_target_for_kf == keyframe->id()) continue;
    neighbour->fuse_target_for_kf = keyframe->id();
    targets.push_back(neighbour);
  }
  const size_t first_ring = targets.size();
  for (size_t k = 0; k < first_ring; ++k)
    for (KeyFrame* second : targets[k]->bestCovisibles(kFuseSecondNeighbours)) {
      if (second->fuse_target_for_kf == keyframe->id() || second == keyframe) continue;
      second->fuse_target_for_kf = keyframe->id();
      targets.push_back(second);
    }

  // This keyframe's points into its neighbours...
  std::vector<MapPoint*> own_points;
  for (MapPoint* point : keyframe->mapPoints())
    if (point && !point->isBad()) own_points.push_back(point);
  for (KeyFrame* target : targets) fuse(target, own_points);

  // ...and the neighbours' points into this keyframe.
  std::vector<MapPoint*> candidates;
  for (KeyFrame* target : targets)
    for (MapPoint* point : target->mapPoints()) {
      if (!point || point->isBad() || point->fuse_candidate_for_kf == keyframe->id()) continue;
      point->fuse_candidate_for_kf = keyframe->id();
      candidates.push_back(point);
    }
  fuse(keyframe, candidates);

  for (MapPoint* point : keyframe->mapPoints())
    if (point && !point->isBad()) {
      point->updateDescriptor();
      point->updateNormalAndDepth(keyframe->pyramid());
      point->updateClass();
    }
  keyframe->updateConnections();
}

void LocalMapping::localBundleAdjustment(KeyFrame* keyframe) {
  ScopedStage stage(timer_, "local_ba");
  BundleProblem problem;
  std::vector<KeyFrame*> keyframes;
  std::vector<MapPoint*> points;
  // Points seen by one keyframe alone, with their coordinates in its camera.
  struct CarriedPoint {
    MapPoint* point;
    KeyFrame* keyframe;
    Vec3 p_c;
  };
  std::vector<CarriedPoint> carried;
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    if (keyframe->isBad()) return;
    // Free: the keyframe and its covisible neighbours.
    std::vector<KeyFrame*> local = {keyframe};
    keyframe->ba_local_for_kf = keyframe->id();
    for (KeyFrame* neighbour : keyframe->orderedCovisibles()) {
      if (neighbour->isBad()) continue;
      neighbour->ba_local_for_kf = keyframe->id();
      local.push_back(neighbour);
    }
    for (KeyFrame* kf : local)
      for (MapPoint* point : kf->mapPoints()) {
        if (!point || point->isBad() || point->ba_local_for_kf == keyframe->id()) continue;
        point->ba_local_for_kf = keyframe->id();
        // A point one keyframe alone sees tells nothing about that keyframe's
        // pose: its 3 coordinates absorb its one observation (2 or 3 rows), so
        // it adds nothing to the reduced camera system. It is left out of the
        // problem and carried along with its keyframe afterwards.
        if (point->observationCount() == 1)
          carried.push_back({point, kf, kf->pose() * point->position()});
        else
          points.push_back(point);
      }
    // Fixed: every other keyframe that sees those points.
    std::vector<KeyFrame*> fixed;
    for (MapPoint* point : points)
      for (const auto& [kf, index] : point->observations()) {
        if (kf->isBad() || kf->ba_local_for_kf == keyframe->id() || kf->ba_fixed_for_kf == keyframe->id()) continue;
        kf->ba_fixed_for_kf = keyframe->id();
        fixed.push_back(kf);
      }
    KeyFrameMap<int> slot;
    for (KeyFrame* kf : local) {
      slot[kf] = static_cast<int>(problem.keyframes.size());
      // The first keyframe anchors the gauge.
      problem.keyframes.push_back({kf->id(), kf->pose(), kf->id() == 0});
      keyframes.push_back(kf);
    }
    for (KeyFrame* kf : fixed) {
      slot[kf] = static_cast<int>(problem.keyframes.size());
      problem.keyframes.push_back({kf->id(), kf->pose(), true});
      keyframes.push_back(kf);
    }
    const ScalePyramid& pyramid = keyframe->pyramid();
    for (size_t p = 0; p < points.size(); ++p) {
      problem.points.push_back({points[p]->id(), points[p]->position(), false});
      for (const auto& [kf, index] : points[p]->observations()) {
        auto it = slot.find(kf);
        if (it == slot.end()) continue;
        problem.observations.push_back({it->second, static_cast<int>(p), kf->point(index),
                                        pyramid.inv_sigma2[kf->keypoints[index].octave],
                                        kf->rightCoordinate(index)});
      }
    }
  }

  BundleOptions options;
  options.iterations_first = 5;
  options.iterations_second = config_.mapping.local_ba_iterations;
  options.abort_flag = &abort_ba_;
  if (!record_ba_path_.empty()) maybeRecordBundleProblem(keyframe->camera(), problem);
  const BundleResult result = bundleAdjust(keyframe->camera(), keyframe->camera().bf, problem, options);
  ++local_ba_count_;

  std::lock_guard<std::mutex> lock(map_.mutex());
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    if (!result.outlier[o]) continue;
    KeyFrame* kf = keyframes[problem.observations[o].keyframe];
    MapPoint* point = points[problem.observations[o].point];
    if (point->isBad() || kf->isBad()) continue;
    kf->eraseMapPoint(point);
    point->eraseObservation(kf);
  }
  for (size_t k = 0; k < keyframes.size(); ++k)
    if (!problem.keyframes[k].fixed && !keyframes[k]->isBad()) keyframes[k]->setPose(problem.keyframes[k].T_cw);
  for (size_t p = 0; p < points.size(); ++p) {
    if (points[p]->isBad()) continue;
    points[p]->setPosition(problem.points[p].position_w);
    points[p]->updateNormalAndDepth(keyframe->pyramid());
  }
  for (const CarriedPoint& carried_point : carried) {
    if (carried_point.point->isBad() || carried_point.keyframe->isBad()) continue;
    carried_point.point->setPosition(carried_point.keyframe->pose().inverse() * carried_point.p_c);
    carried_point.point->updateNormalAndDepth(keyframe->pyramid());
  }
}

std::vector<KeyFrame*> triangulationNeighbours(KeyFrame* keyframe, size_t covisible_count, int min_neighbours) {
  std::vector<KeyFrame*> neighbours = keyframe->bestCovisibles(covisible_count);
  const size_t wanted = static_cast<size_t>(std::max(min_neighbours, 0));
  KeyFrame* before = keyframe->parent();
  for (size_t steps = 0; before && steps < wanted && neighbours.size() < wanted; ++steps) {
    if (!before->isBad() && std::find(neighbours.begin(), neighbours.end(), before) == neighbours.end())
      neighbours.push_back(before);
    before = before->parent();
  }
  return neighbours;
}

std::vector<KeyFrame*> cullRedundantKeyFrames(KeyFrame* keyframe, double redundant_ratio, bool close_points_only) {
  constexpr int kObserversNeeded = 3;
  std::vector<KeyFrame*> culled;
  // A copy: culling a neighbour erases it from this keyframe's covisibility list.
  const std::vector<KeyFrame*> candidates = keyframe->orderedCovisibles();
  for (KeyFrame* candidate : candidates) {
    if (candidate->isBad() || !candidate->erasable()) continue;
    int with_points = 0, redundant = 0;
    for (size_t i = 0; i < candidate->size(); ++i) {
      MapPoint* point = candidate->mapPoint(i);
      if (!point || point->isBad()) continue;
      // RGB-D, as ORB-SLAM2: a keyframe is judged by its close points, the ones its depth fixes.
      if (close_points_only &&
          (!candidate->hasDepth(i) || candidate->depth[i] > candidate->camera().closeDepth()))
        continue;
      ++with_points;
      if (point->observationCount() <= kObserversNeeded) continue;
      const int level = candidate->keypoints[i].octave;
      int observers = 0;
      for (const auto& [other, index] : point->observations()) {
        if (other == candidate) continue;
        if (other->keypoints[index].octave <= level + 1 && ++observers >= kObserversNeeded) break;
      }
      if (observers >= kObserversNeeded) ++redundant;
    }
    if (with_points > 0 && redundant > redundant_ratio * with_points) {
      candidate->setBad();
      if (candidate->isBad()) culled.push_back(candidate);
    }
  }
  return culled;
}

}  // namespace vslam
