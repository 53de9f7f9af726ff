#include "vslam/slam/loop_closing.hpp"

#include <algorithm>
#include <limits>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include "vslam/feature/matcher.hpp"
#include "vslam/geometry/sim3_solver.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
#include "vslam/optimize/pose_graph.hpp"
#include "vslam/slam/local_mapping.hpp"
#include "vslam/slam/map_matching.hpp"
#include "vslam/slam/place_candidates.hpp"

namespace vslam {
namespace {

constexpr long kMinKeyFramesSinceLoop = 10;   // no detection right after a map start or a loop
constexpr int kMinBowMatches = 20;            // to try a Sim(3)
constexpr int kRansacIterations = 300;
constexpr int kMinRansacInliers = 20;
constexpr int kMinLoopInliers = 40;           // after the projection search (ORB-SLAM's value)
constexpr double kSim3SearchRadius = 7.5;     // px at level 0, guided search after RANSAC (ORB-SLAM's value)
constexpr int kEssentialCovisibilityWeight = 100;
constexpr int kPoseGraphIterations = 20;
constexpr int kLoopFullBaIterations = 10;

Sim3 toSim3(const SE3& T) { return Sim3(T); }

// Writes a solved full BA back into the map (under its lock).
void mergeFullBundleAdjustment(Map& map, const std::vector<KeyFrame*>& keyframes, const std::vector<MapPoint*>& points,
                               const BundleProblem& problem);

// Projects `points` (not yet matched) with the similarity S_cw into the
// current keyframe and matches them by descriptor: more support for a loop.
int searchLoopByProjection(const KeyFrame& current, const Sim3& S_cw, const std::vector<MapPoint*>& points,
                           std::vector<MapPoint*>& matched, double radius_px) {
  const ScalePyramid& pyramid = current.pyramid();
  std::unordered_set<const MapPoint*> already(matched.begin(), matched.end());
  // The camera centre in world coordinates under S_cw, for distance and viewing-angle checks.
  const Vec3 centre = -(S_cw.R.transpose() * S_cw.t) / S_cw.s;
  int added = 0;
  for (MapPoint* point : points) {
    if (!point || point->isBad() || already.count(point)) continue;
    const std::optional<PredictedObservation> seen = predictObservation(*point, current, S_cw, centre);
    if (!seen) continue;
    const Vec2& px = seen->pixel;
    const int level = seen->level;
    const double radius = radius_px * pyramid.scale[level];
    int best_distance = std::numeric_limits<int>::max();
    int best_index = -1;
    for (int j : current.grid.featuresInArea(px.x(), px.y(), radius)) {
      if (matched[j]) continue;
      const int kp_level = current.keypoints[j].octave;
      if (kp_level < level - 1 || kp_level > level) continue;
      const int d = hammingDistance(point->descriptor().ptr<uint8_t>(), current.descriptors.ptr<uint8_t>(j));
      if (d < best_distance) {
        best_distance = d;
        best_index = j;
      }
    }
    if (best_index >= 0 && best_distance <= kHammingThresholdGuided) {
      matched[best_index] = point;
      ++added;
    }
  }
  return added;
}

}  // namespace

std::vector<size_t> updateConsistentGroups(std::vector<ConsistentGroup>& groups,
                                           const std::vector<std::set<long>>& candidate_groups, int threshold) {
  std::vector<size_t> accepted;
  std::vector<ConsistentGroup> next_groups;
  for (size_t c = 0; c < candidate_groups.size(); ++c) {
    ConsistentGroup group{candidate_groups[c], 0};
    for (const ConsistentGroup& previous : groups) {
      const bool overlaps = std::any_of(group.keyframe_ids.begin(), group.keyframe_ids.end(),
                                        [&](long id) { return previous.keyframe_ids.count(id) > 0; });
      if (overlaps) group.consistency = std::max(group.consistency, previous.consistency + 1);
    }
    if (group.consistency >= threshold) accepted.push_back(c);
    next_groups.push_back(std::move(group));
  }
  groups = std::move(next_groups);
  return accepted;
}

bool loopLinkEntersEssentialGraph(int covisibility_weight, bool is_the_loop_link, int min_weight) {
  return is_the_loop_link || covisibility_weight >= min_weight;
}

bool loopAccepted(double scale, int inliers, const LoopScaleRule& rule) {
  if (!(scale > 0)) return false;
  const bool plausible = scale >= rule.min_plausible_scale && scale <= rule.max_plausible_scale;
  return inliers >= (plausible ? rule.min_inliers : rule.min_inliers_implausible);
}

// ---------------------------------------------------------------------------
// Full bundle adjustment.

FullBundleAdjustmentResult runFullBundleAdjustment(Map& map, int iterations,
                                                   const FullBundleAdjustmentControl& control,
                                                   const KeyFrameMap<CameraVelocity>* velocities) {
  FullBundleAdjustmentResult summary;
  BundleProblem problem;
  std::vector<KeyFrame*> keyframes;
  std::vector<MapPoint*> points;
  const PinholeCamera* camera = nullptr;
  {
    std::lock_guard<std::mutex> lock(map.mutex());
    keyframes = map.keyframes();
    if (keyframes.size() < 2) return summary;
    camera = &keyframes.front()->camera();
    KeyFrameMap<int> slot;
    for (KeyFrame* kf : keyframes) {
      slot[kf] = static_cast<int>(problem.keyframes.size());
      // The first keyframe anchors the gauge (and, with the map's scale, the scale).
      problem.keyframes.push_back({kf->id(), kf->pose(), kf == keyframes.front()});
      if (velocities) {
        const auto velocity = velocities->find(kf);
        if (velocity != velocities->end()) problem.keyframes.back().velocity = velocity->second;
      }
    }
    if (velocities) problem.readout_s = camera->readout_s;
    for (MapPoint* point : map.mapPoints()) {
      const size_t first_observation = problem.observations.size();
      int weight = 0;
      for (const auto& [kf, index] : point->observations()) {
        auto it = slot.find(kf);
        if (it == slot.end()) continue;
        problem.observations.push_back({it->second, static_cast<int>(points.size()), kf->point(index),
                                        kf->pyramid().inv_sigma2[kf->keypoints[index].octave],
                                        kf->rightCoordinate(index)});
        weight += kf->observationWeight(index);
      }
      // Points seen only once without depth would be unconstrained along their ray.
      if (weight < 2) {
        problem.observations.resize(first_observation);
        continue;
      }
      problem.points.push_back({point->id(), point->position(), false});
      points.push_back(point);
    }
  }
  BundleOptions options;
  options.iterations_first = iterations;
  options.iterations_second = 0;
  options.remove_outliers = false;
  options.abort_flag = control.abort;
  const BundleResult result = bundleAdjust(*camera, camera->bf, problem, options);
  summary.keyframes = static_cast<int>(keyframes.size());
  summary.points = static_cast<int>(points.size());
  summary.initial_cost = result.initial_cost;
  summary.final_cost = result.final_cost;
  if (control.abort && control.abort->load()) return summary;

  if (control.local_mapping) control.local_mapping->pause();
  mergeFullBundleAdjustment(map, keyframes, points, problem);
  if (control.local_mapping) control.local_mapping->resume();
  summary.merged = true;
  return summary;
}

namespace {

void mergeFullBundleAdjustment(Map& map, const std::vector<KeyFrame*>& keyframes, const std::vector<MapPoint*>& points,
                               const BundleProblem& problem) {
  std::lock_guard<std::mutex> lock(map.mutex());
  // Corrections T_new^-1 * T_old per optimised keyframe, to carry over to what was not optimised.
  KeyFrameMap<SE3> before, after;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    KeyFrame* kf = keyframes[k];
    if (kf->isBad()) continue;
    before[kf] = kf->pose();
    after[kf] = problem.keyframes[k].T_cw;
    kf->setPose(problem.keyframes[k].T_cw);
  }
  // Keyframes created during the BA: follow the parent's correction down the spanning tree.
  std::vector<KeyFrame*> stack;
  if (KeyFrame* root = map.firstKeyFrame()) stack.push_back(root);
  while (!stack.empty()) {
    KeyFrame* parent = stack.back();
    stack.pop_back();
    for (KeyFrame* child : parent->children()) {
      if (child->isBad()) continue;
      if (!after.count(child) && after.count(parent)) {
        const SE3 T_child_parent = child->pose() * before[parent].inverse();
        before[child] = child->pose();
        after[child] = T_child_parent * after[parent];
        child->setPose(after[child]);
      }
      stack.push_back(child);
    }
  }
  std::unordered_set<const MapPoint*> optimised(points.begin(), points.end());
  for (size_t p = 0; p < points.size(); ++p)
    if (!points[p]->isBad()) points[p]->setPosition(problem.points[p].position_w);
  for (MapPoint* point : map.mapPoints()) {
    if (optimised.count(point)) continue;
    KeyFrame* reference = point->reference();
    if (!reference || !after.count(reference)) continue;
    point->setPosition(after[reference].inverse() * (before[reference] * point->position()));
  }
  for (MapPoint* point : map.mapPoints()) {
    KeyFrame* reference = point->reference();
    if (reference && !reference->isBad()) point->updateNormalAndDepth(reference->pyramid());
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Thread plumbing.

LoopClosing::LoopClosing(const Config& config, Map& map, const Vocabulary& vocabulary, KeyframeDatabase& database,
                         LocalMapping& local_mapping, StageTimer* timer)
    : config_(config),
      map_(map),
      vocabulary_(vocabulary),
      database_(database),
      local_mapping_(local_mapping),
      timer_(timer) {}

LoopClosing::~LoopClosing() { finish(); }

void LoopClosing::insertKeyFrame(KeyFrame* keyframe) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(keyframe->id());
  }
  cv_.notify_all();
}

void LoopClosing::processQueued() {
  while (true) {
    long id;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (queue_.empty()) return;
      id = queue_.front();
      queue_.pop_front();
    }
    process(id);
  }
}

void LoopClosing::start() { thread_ = std::thread([this] { run(); }); }

void LoopClosing::finish() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finish_requested_ = true;
  }
  cv_.notify_all();
  thread_.join();
  // The last loop's full BA is kept: it is the map's best state until the final BA.
  if (full_ba_thread_.joinable()) full_ba_thread_.join();
}

void LoopClosing::run() {
  while (true) {
    long id;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return !queue_.empty() || finish_requested_; });
      if (queue_.empty()) return;
      id = queue_.front();
      queue_.pop_front();
      processing_ = true;
    }
    std::exception_ptr failure;
    try {
      process(id);
    } catch (...) {
      failure = std::current_exception();  // reaches the caller through failure()
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      processing_ = false;
      if (failure && !failure_) failure_ = failure;
    }
    cv_.notify_all();
    if (failure) return;
  }
}

void LoopClosing::reset() {
  {
    std::unique_lock<std::mutex> lock(mutex_);
    queue_.clear();
    cv_.wait(lock, [this] { return !processing_; });
    consistent_groups_.clear();
    last_loop_keyframe_id_ = -1;
  }
  abortFullBundleAdjustment();
}

LoopClosingState LoopClosing::state() const {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !processing_; });
  LoopClosingState state;
  state.queued = queue_.size();
  state.consistent_groups = consistent_groups_.size();
  state.last_loop_keyframe_id = last_loop_keyframe_id_;
  state.full_ba_running = full_ba_thread_.joinable();
  return state;
}

std::exception_ptr LoopClosing::failure() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return failure_;
}

std::vector<LoopRecord> LoopClosing::loops() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return loops_;
}

void LoopClosing::process(long keyframe_id) {
  KeyFrame* current = nullptr;
  LoopCandidate loop;
  bool found = false;
  {
    ScopedStage stage(timer_, "loop_detection");
    std::lock_guard<std::mutex> lock(map_.mutex());
    current = map_.keyFrameById(keyframe_id);
    if (!current || current->isBad() || !current->hasBow()) return;
    const std::vector<KeyFrame*> candidates = detectCandidates(current);
    if (!candidates.empty()) found = computeSim3(current, candidates, loop);
    if (!found) return;
    // The map lock is released before the correction: hold both keyframes so
    // that Local Mapping cannot cull them in between.
    current->holdFromErase();
    loop.matched->holdFromErase();
  }
  // A full BA still running from an earlier loop would merge poses from before this correction.
  abortFullBundleAdjustment();
  bool corrected = false;
  {
    ScopedStage stage(timer_, "loop_correction");
    local_mapping_.pause();
    {
      std::lock_guard<std::mutex> lock(map_.mutex());
      corrected = correctLoop(current, loop);
      current->releaseErase();
      loop.matched->releaseErase();
    }
    local_mapping_.resume();
  }
  if (!corrected) {
    spdlog::warn("loop between keyframes {} and {} abandoned: a keyframe of it was culled", current->id(),
                 loop.matched->id());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    loops_.push_back({current->id(), loop.matched->id(), loop.scale, loop.inliers});
  }
  spdlog::info("loop closed: keyframe {} with keyframe {} ({} matches, scale {:.3f})", current->id(),
               loop.matched->id(), loop.inliers, loop.scale);
  startFullBundleAdjustment();
}

void LoopClosing::startFullBundleAdjustment() {
  full_ba_abort_.store(false);
  auto solve = [this] {
    ScopedStage stage(timer_, "full_ba");
    const FullBundleAdjustmentResult result =
        runFullBundleAdjustment(map_, kLoopFullBaIterations, {&full_ba_abort_, &local_mapping_});
    spdlog::debug("full BA after loop: {} keyframes, {} points, cost {:.1f} -> {:.1f}{}", result.keyframes,
                  result.points, result.initial_cost, result.final_cost, result.merged ? "" : " (aborted)");
  };
  if (!thread_.joinable()) {
    solve();  // deterministic mode
    return;
  }
  full_ba_thread_ = std::thread([this, solve] {
    try {
      solve();
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!failure_) failure_ = std::current_exception();
    }
  });
}

void LoopClosing::abortFullBundleAdjustment() {
  if (!full_ba_thread_.joinable()) return;
  full_ba_abort_.store(true);
  full_ba_thread_.join();
}

// ---------------------------------------------------------------------------
// Detection.

std::vector<KeyFrame*> LoopClosing::detectCandidates(KeyFrame* current) {
  std::vector<KeyFrame*> result;
  if (current->id() < last_loop_keyframe_id_ + kMinKeyFramesSinceLoop || map_.keyframeCount() <= kMinKeyFramesSinceLoop) {
    consistent_groups_.clear();
    return result;
  }
  // The weakest score among covisible neighbours: a loop candidate must look at least as similar.
  const std::vector<KeyFrame*>& neighbours = current->orderedCovisibles();
  double min_score = 1.0;
  for (KeyFrame* neighbour : neighbours)
    if (!neighbour->isBad() && neighbour->hasBow())
      min_score = std::min(min_score, vocabulary_.score(current->bow, neighbour->bow));
  std::unordered_set<long> exclude = {current->id()};
  for (KeyFrame* neighbour : neighbours) exclude.insert(neighbour->id());

  // Candidates: enough shared words, a score above the minimum, the best covisibility groups.
  const std::vector<KeyFrame*> accepted = selectPlaceCandidates(database_, map_, current->bow, exclude, min_score);

  // Consistency: a candidate's group must overlap groups of the previous keyframes' candidates.
  std::vector<std::set<long>> candidate_groups;
  for (KeyFrame* candidate : accepted) {
    std::set<long> group = {candidate->id()};
    for (KeyFrame* neighbour : candidate->orderedCovisibles()) group.insert(neighbour->id());
    candidate_groups.push_back(std::move(group));
  }
  for (size_t index : updateConsistentGroups(consistent_groups_, candidate_groups, config_.loop.consistency))
    result.push_back(accepted[index]);
  spdlog::debug("loop detection, keyframe {}: {} covisible (excluded), min score {:.3f}, {} candidates, {} consistent",
                current->id(), neighbours.size(), min_score, accepted.size(), result.size());
  return result;
}

// ---------------------------------------------------------------------------
// Sim(3) verification.

bool LoopClosing::computeSim3(KeyFrame* current, const std::vector<KeyFrame*>& candidates, LoopCandidate& loop) {
  const PinholeCamera& camera = current->camera();
  const ScalePyramid& pyramid = current->pyramid();
  for (KeyFrame* candidate : candidates) {
    std::vector<MapPoint*> bow_matches;
    if (searchByBoW(*current, *candidate, bow_matches) < kMinBowMatches) continue;
    // A matched pair in each camera's coordinates: the current keyframe's point
    // at keypoint i and the candidate's point `other`.
    auto pairOf = [&](size_t i, MapPoint* other) -> std::optional<Sim3Match> {
      MapPoint* own = current->mapPoint(i);
      if (!own || own->isBad() || !other || other->isBad()) return std::nullopt;
      const int j = other->keypointIn(candidate);
      if (j < 0) return std::nullopt;
      Sim3Match m;
      m.point1_c1 = current->pose() * own->position();
      m.point2_c2 = candidate->pose() * other->position();
      m.pixel1 = current->point(i);
      m.pixel2 = candidate->point(j);
      m.inv_sigma2_1 = pyramid.inv_sigma2[current->keypoints[i].octave];
      m.inv_sigma2_2 = pyramid.inv_sigma2[candidate->keypoints[j].octave];
      return m;
    };
    std::vector<Sim3Match> pairs;
    std::vector<int> keypoint_of;
    for (size_t i = 0; i < bow_matches.size(); ++i)
      if (const std::optional<Sim3Match> m = pairOf(i, bow_matches[i])) {
        pairs.push_back(*m);
        keypoint_of.push_back(static_cast<int>(i));
      }
    if (static_cast<int>(pairs.size()) < kMinBowMatches) continue;

    // RANSAC over minimal sets of three pairs (seeded by the keyframe: deterministic);
    // S12 maps candidate-camera points into the current camera. optimizeSim3 refines it below.
    Sim3Correspondences correspondences;
    for (const Sim3Match& m : pairs) {
      correspondences.points_1.push_back(m.point1_c1);
      correspondences.points_2.push_back(m.point2_c2);
      correspondences.pixels_1.push_back(m.pixel1);
      correspondences.pixels_2.push_back(m.pixel2);
      correspondences.sigma2_1.push_back(1.0 / m.inv_sigma2_1);
      correspondences.sigma2_2.push_back(1.0 / m.inv_sigma2_2);
    }
    Sim3SolverParams ransac_params;
    ransac_params.iterations = kRansacIterations;
    ransac_params.min_inliers = kMinRansacInliers;
    // With depth the map is metric and a loop corrects a rigid motion: SE(3), scale fixed at 1.
    const bool fix_scale = config_.sensor == SensorMode::RgbD;
    ransac_params.fix_scale = fix_scale;
    const Mat3 K = camera.Keigen();
    const Sim3Result ransac =
        solveSim3Ransac(correspondences, K, K, ransac_params, static_cast<uint32_t>(current->id()));
    if (!ransac.success) continue;

    // Guided search with the RANSAC similarity (ORB-SLAM's SearchBySim3): the
    // mutual matches it finds join the inliers, and all are refined together.
    std::vector<MapPoint*> matches12(current->size(), nullptr);
    for (size_t k = 0; k < pairs.size(); ++k)
      if (ransac.inliers[k]) matches12[keypoint_of[k]] = bow_matches[keypoint_of[k]];
    const int guided = searchBySim3(*current, *candidate, ransac.S12, matches12, kSim3SearchRadius);
    std::vector<Sim3Match> refine_pairs;
    std::vector<int> refine_keypoint_of;
    for (size_t i = 0; i < matches12.size(); ++i)
      if (const std::optional<Sim3Match> m = pairOf(i, matches12[i])) {
        refine_pairs.push_back(*m);
        refine_keypoint_of.push_back(static_cast<int>(i));
      }
    Sim3 S12 = ransac.S12;
    Sim3OptimizationOptions refine_options;
    refine_options.fix_scale = fix_scale;
    const Sim3OptimizationResult refined = optimizeSim3(camera, refine_pairs, S12, refine_options);
    if (refined.n_inliers < kMinRansacInliers) continue;

    std::vector<MapPoint*> loop_points;
    {
      KeyFrameSet loop_keyframes = {candidate};
      for (KeyFrame* neighbour : candidate->orderedCovisibles()) loop_keyframes.insert(neighbour);
      std::unordered_set<const MapPoint*> seen;
      for (KeyFrame* kf : loop_keyframes) {
        if (kf->isBad()) continue;
        for (MapPoint* point : kf->mapPoints())
          if (point && !point->isBad() && seen.insert(point).second) loop_points.push_back(point);
      }
    }
    const Sim3 S_cw = S12 * toSim3(candidate->pose());
    std::vector<MapPoint*> matched(current->size(), nullptr);
    for (size_t q = 0; q < refine_pairs.size(); ++q)
      if (refined.inlier[q]) matched[refine_keypoint_of[q]] = matches12[refine_keypoint_of[q]];
    searchLoopByProjection(*current, S_cw, loop_points, matched, 10.0);
    const int total = static_cast<int>(std::count_if(matched.begin(), matched.end(), [](MapPoint* p) { return p; }));
    spdlog::debug("loop candidate {} for keyframe {}: {} BoW, {} RANSAC, {} by Sim(3) search, {} refined, {} total",
                  candidate->id(), current->id(), pairs.size(), ransac.n_inliers, guided, refined.n_inliers, total);
    if (total < kMinLoopInliers) continue;
    if (!loopAccepted(S12.s, total)) {
      ++implausible_rejected_;
      spdlog::info("loop candidate {} for keyframe {} rejected: Sim(3) scale {:.3f} is implausible for {} matches",
                   candidate->id(), current->id(), S12.s, total);
      continue;
    }
    loop.matched = candidate;
    loop.S_cw = S_cw;
    loop.matched_points = std::move(matched);
    loop.loop_points = std::move(loop_points);
    loop.scale = S12.s;
    loop.inliers = total;
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------
// Correction.

bool LoopClosing::correctLoop(KeyFrame* current, LoopCandidate& loop) {
  if (current->isBad() || !loop.matched || loop.matched->isBad()) return false;
  current->updateConnections();
  // The current keyframe and its neighbours move with the loop's similarity.
  std::vector<KeyFrame*> connected = {current};
  for (KeyFrame* neighbour : current->orderedCovisibles())
    if (!neighbour->isBad()) connected.push_back(neighbour);
  std::sort(connected.begin(), connected.end(), [](KeyFrame* a, KeyFrame* b) { return a->id() < b->id(); });

  KeyFrameMap<Sim3> corrected, uncorrected;
  const SE3 T_wc = current->pose().inverse();
  for (KeyFrame* kf : connected) {
    uncorrected[kf] = toSim3(kf->pose());
    corrected[kf] = kf == current ? loop.S_cw : toSim3(kf->pose() * T_wc) * loop.S_cw;
  }
  // Their map points follow, each once.
  std::unordered_map<const MapPoint*, KeyFrame*> corrected_by;
  for (KeyFrame* kf : connected) {
    const Sim3 correction = corrected[kf].inverse() * uncorrected[kf];
    for (MapPoint* point : kf->mapPoints()) {
      if (!point || point->isBad() || corrected_by.count(point)) continue;
      point->setPosition(correction * point->position());
      corrected_by[point] = kf;
      point->updateNormalAndDepth(kf->pyramid());
    }
  }
  for (KeyFrame* kf : connected) kf->setPose(rigidPoseFromSim3(corrected[kf]));

  // Fuse the loop's points: the matched ones replace the current keyframe's, then
  // every loop point is projected into the corrected neighbours.
  for (size_t i = 0; i < loop.matched_points.size(); ++i) {
    MapPoint* loop_point = loop.matched_points[i];
    if (!loop_point || loop_point->isBad()) continue;
    MapPoint* own = current->mapPoint(i);
    if (own == loop_point) continue;
    if (own && !own->isBad()) {
      own->replaceWith(loop_point);
    } else if (loop_point->keypointIn(current) < 0) {
      current->setMapPoint(i, loop_point);
      loop_point->addObservation(current, static_cast<int>(i));
      loop_point->updateDescriptor();
    }
  }
  for (KeyFrame* kf : connected) fuse(kf, loop.loop_points, 4.0, FuseKeeps::Projected);

  // New links created by the fusion are the loop edges of the essential graph.
  KeyFrameMap<KeyFrameSet> new_links;
  KeyFrameSet connected_set(connected.begin(), connected.end());
  for (KeyFrame* kf : connected) {
    KeyFrameSet before(kf->orderedCovisibles().begin(), kf->orderedCovisibles().end());
    kf->updateConnections();
    for (KeyFrame* other : kf->orderedCovisibles())
      if (!before.count(other) && !connected_set.count(other)) new_links[kf].insert(other);
  }

  // Essential graph: every live keyframe; the matched keyframe is held fixed.
  const std::vector<KeyFrame*> keyframes = map_.keyframes();
  KeyFrameMap<int> slot;
  std::vector<PoseGraphVertex> vertices;
  for (KeyFrame* kf : keyframes) {
    slot[kf] = static_cast<int>(vertices.size());
    const Sim3 initial = corrected.count(kf) ? corrected[kf] : toSim3(kf->pose());
    vertices.push_back({kf->id(), initial, kf == loop.matched});
    if (!uncorrected.count(kf)) uncorrected[kf] = initial;
  }
  // Checked lookups only: operator[] would insert slot 0 (another keyframe's
  // vertex) for a keyframe not in the graph.
  auto slotOf = [&](KeyFrame* kf) {
    auto it = slot.find(kf);
    return it == slot.end() ? -1 : it->second;
  };
  // The matched keyframe fixes the gauge; without it the graph would float.
  if (slotOf(loop.matched) < 0 || slotOf(current) < 0) return false;
  std::vector<PoseGraphEdge> edges;
  std::set<std::pair<long, long>> added;
  auto addEdge = [&](KeyFrame* from, KeyFrame* to, const Sim3& S_to_from, double weight) {
    const int a = slotOf(from), b = slotOf(to);
    if (a < 0 || b < 0 || from == to) return;
    // A pair of values: std::minmax returns references, here to temporaries.
    const std::pair<long, long> key = std::minmax(from->id(), to->id());
    if (!added.insert(key).second) return;
    edges.push_back({a, b, S_to_from, weight});
  };
  // Measurement from the corrected poses (the loop's own links).
  auto correctedRelative = [&](KeyFrame* from, KeyFrame* to) {
    const int a = slotOf(from), b = slotOf(to);
    return a < 0 || b < 0 ? Sim3() : vertices[b].S_cw * vertices[a].S_cw.inverse();
  };
  // The relative measurement before correction (what the map measured), except for
  // the new loop links, which come from the corrected poses.
  auto measured = [&](KeyFrame* from, KeyFrame* to) { return uncorrected[to] * uncorrected[from].inverse(); };
  addEdge(current, loop.matched, correctedRelative(current, loop.matched), 1.0);
  for (const auto& [kf, others] : new_links)
    for (KeyFrame* other : others)
      if (loopLinkEntersEssentialGraph(kf->weight(other), false, kEssentialCovisibilityWeight))
        addEdge(kf, other, correctedRelative(kf, other), 1.0);
  for (KeyFrame* kf : keyframes) {
    if (KeyFrame* parent = kf->parent()) addEdge(kf, parent, measured(kf, parent), 1.0);
    for (KeyFrame* other : kf->loopEdges()) addEdge(kf, other, measured(kf, other), 1.0);
    for (KeyFrame* other : kf->covisiblesWithWeight(kEssentialCovisibilityWeight)) addEdge(kf, other, measured(kf, other), 1.0);
  }
  PoseGraphOptions options;
  options.iterations = kPoseGraphIterations;
  options.fix_scale = config_.sensor == SensorMode::RgbD;  // an SE(3) essential graph for a metric map
  optimizeSim3PoseGraph(vertices, edges, options);

  // Write back: poses, then points through the keyframe that last moved them.
  KeyFrameMap<Sim3> initial;
  for (KeyFrame* kf : keyframes) initial[kf] = corrected.count(kf) ? corrected[kf] : toSim3(kf->pose());
  for (MapPoint* point : map_.mapPoints()) {
    auto it = corrected_by.find(point);
    KeyFrame* by = it != corrected_by.end() ? it->second : point->reference();
    const int by_slot = by ? slotOf(by) : -1;
    if (by_slot < 0) continue;
    point->setPosition(vertices[by_slot].S_cw.inverse() * (initial[by] * point->position()));
  }
  for (size_t k = 0; k < keyframes.size(); ++k) keyframes[k]->setPose(rigidPoseFromSim3(vertices[k].S_cw));
  for (MapPoint* point : map_.mapPoints())
    if (point->reference() && !point->reference()->isBad()) point->updateNormalAndDepth(point->reference()->pyramid());

  current->addLoopEdge(loop.matched);
  loop.matched->addLoopEdge(current);
  // Loop keyframes anchor the essential graph: never culled.
  current->not_erase = true;
  loop.matched->not_erase = true;
  last_loop_keyframe_id_ = current->id();
  consistent_groups_.clear();
  return true;
}

}  // namespace vslam
