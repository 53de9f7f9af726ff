#include "vslam/slam/system.hpp"

#include <filesystem>
#include <optional>
#include <utility>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "vslam/detect/detection_stage.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"
#include "vslam/slam/extraction_ahead.hpp"
#include "vslam/slam/frame_builder.hpp"
#include "vslam/slam/local_mapping.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/tracking.hpp"

namespace vslam {

System::System(const Config& config, const SystemOptions& options)
    : config_(config),
      options_(options),
      map_(std::make_unique<Map>()),
      detection_(makeDetectionStage(config.detector, &timer_, options.deterministic)),
      frame_builder_(std::make_unique<FrameBuilder>(
          config, config.camera, detection_ ? detection_->dynamicClassIds() : std::vector<int>(),
          detection_ ? detection_->movingClassIds() : std::vector<int>())),
      local_mapping_(std::make_unique<LocalMapping>(config, *map_, &timer_)),
      tracking_(std::make_unique<Tracking>(config, *map_, *local_mapping_, &timer_,
                                           options.deterministic ? KeyFrameInsertion::Synchronous
                                           : options.realtime    ? KeyFrameInsertion::DropWhenBusy
                                                                 : KeyFrameInsertion::WaitForMapping)) {
  if (!options.deterministic) extraction_ahead_ = std::make_unique<ExtractionAhead>(*frame_builder_, &timer_);
  if (options_.after_keyframe_mapped) local_mapping_->setAfterKeyFrameHook(options_.after_keyframe_mapped);
  // An empty vocabulary path switches place recognition off; a bad file is an input error.
  if (!config_.loop.vocabulary.empty()) {
    vocabulary_path_ = resolveVocabularyPath(config_.loop.vocabulary);
    vocabulary_ = std::make_unique<Vocabulary>(Vocabulary::load(vocabulary_path_));
    if (config_.loop.vocabulary == LoopParams::kDefaultVocabulary &&
        std::filesystem::path(vocabulary_path_).filename() != std::filesystem::path(LoopParams::kDefaultVocabulary).filename())
      spdlog::info("vocabulary: {} (k = {}, L = {}); the default {} is not built here (vocab/README.md)",
                   vocabulary_path_, vocabulary_->branching(), vocabulary_->depth(), LoopParams::kDefaultVocabulary);
    database_ = std::make_unique<KeyframeDatabase>();
    if (config_.loop.enabled)
      loop_closing_ =
          std::make_unique<LoopClosing>(config_, *map_, *vocabulary_, *database_, *local_mapping_, &timer_);
    local_mapping_->setPlaceRecognition(vocabulary_.get(), database_.get(), loop_closing_.get());
    tracking_->setPlaceRecognition(vocabulary_.get(), database_.get());
    tracking_->setLoopClosing(loop_closing_.get());
  } else {
    spdlog::warn("no vocabulary: relocalisation only retries the last keyframe and loop closing is off");
  }
  if (!options_.deterministic) {
    local_mapping_->start();
    if (loop_closing_) loop_closing_->start();
  }
}

System::~System() {
  try {
    finish();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());  // a destructor must not throw; finish() reported it to callers that asked
  }
}

void System::rethrowWorkerFailure() const {
  auto rethrow = [](const std::exception_ptr& failure, const char* thread) {
    if (!failure) return;
    try {
      std::rethrow_exception(failure);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(thread) + " thread failed: " + e.what());
    } catch (...) {
      throw std::runtime_error(std::string(thread) + " thread failed");
    }
  };
  rethrow(local_mapping_->failure(), "local mapping");
  if (loop_closing_) rethrow(loop_closing_->failure(), "loop closing");
}

LoopClosingState System::loopClosingState() const {
  return loop_closing_ ? loop_closing_->state() : LoopClosingState{};
}

int System::featuresToExtract() const {
  // Monocular initialisation matches only the finest level: extract twice the
  // features until the map exists, as ORB-SLAM does (RGB-D needs one frame).
  const bool initialising =
      tracking_->state() == TrackingState::NotInitialized && config_.sensor == SensorMode::Monocular;
  return initialising ? 2 * config_.orb.n_features : -1;
}

void System::submitAhead(int index, const cv::Mat& image) {
  // The count is the current state's guess: a frame that starts the map makes
  // the next frame's job the wrong count, and that frame is extracted again.
  if (extraction_ahead_) extraction_ahead_->submit(index, image, featuresToExtract());
  if (detection_) detection_->submitAhead(index, image);
}

bool System::processFrame(int index, double timestamp, const cv::Mat& image, const cv::Mat& depth_m) {
  ScopedStage total(&timer_, "frame");
  BoxSource boxes;
  if (detection_)
    boxes = [&](const FeatureSnapshot& own) {
      ScopedStage wait(&timer_, "detect_wait");
      return detection_->boxesFor(own, image);
    };
  Frame frame;
  FrameFilterResult filter;
  FeatureSnapshot own_features;
  {
    // Tracking's time on the frame's features: waiting for those extracted
    // ahead (or extracting them now), the keypoint filter, undistortion, depth.
    ScopedStage stage(&timer_, "extract");
    const int n_features = featuresToExtract();
    std::optional<ExtractedFeatures> features;
    if (extraction_ahead_) features = extraction_ahead_->take(index, n_features);
    if (!features) features = frame_builder_->extractFeatures(image, n_features);
    frame = frame_builder_->build(next_frame_id_++, index, timestamp, image, depth_m, std::move(*features), boxes,
                                  &filter, detection_ ? &own_features : nullptr);
  }
  if (detection_) {
    timer_.record("filter", filter.ms);
    keypoints_reused_.push_back(filter.frame_keypoints_reused);
    duplicates_dropped_.push_back(filter.stats.duplicates_dropped);
    keypoints_added_.push_back(filter.stats.keypoints_added);
    keypoints_removed_.push_back(filter.stats.keypoints_removed_dynamic);
    boxes_used_.push_back(filter.stats.boxes_used);
  }
  if (config_.sensor == SensorMode::RgbD && !frame.hasDepthImage()) ++frames_without_depth_;
  bool tracked;
  const int keyframes_before = tracking_->keyframesCreated();
  {
    ScopedStage stage(&timer_, "track");
    tracked = tracking_->track(frame);
  }
  if (detection_) detection_->afterTrack(own_features, image, tracking_->keyframesCreated() > keyframes_before);
  // Deterministic mode: loop closing runs synchronously after each frame's mapping.
  if (options_.deterministic && loop_closing_) loop_closing_->processQueued();
  rethrowWorkerFailure();
  return tracked;
}

bool System::finish(const FinishOptions& finish_options) {
  if (finished_) return false;
  finished_ = true;
  if (options_.deterministic) {
    local_mapping_->processQueued();
    if (loop_closing_) loop_closing_->processQueued();
  } else {
    local_mapping_->finish();
    if (loop_closing_) loop_closing_->finish();
  }
  rethrowWorkerFailure();
  const bool merged = runFinalBundleAdjustment(finish_options);
  // Frames were posed against the map as it stood when they were tracked;
  // since then bundle adjustments have moved it (a young monocular map's scale
  // most of all), so each is posed again against its matched points. Only
  // after a final BA that was merged: a run stopped early ends quickly. In
  // localisation mode the map has not moved, and frames are posed again only
  // for a rolling shutter's correction (docs/GEOMETRY.md).
  const bool stopped = finish_options.abort_final_ba && finish_options.abort_final_ba->load();
  const bool localised_rolling_shutter = localize_ && config_.camera.readout_s > 0 && !stopped;
  if ((merged || localised_rolling_shutter) && config_.loop.refine_frames) {
    ScopedStage stage(&timer_, "refine_frames");
    std::lock_guard<std::mutex> lock(map_->mutex());
    const Tracking::FrameRefinement refinement = tracking_->refineFramePoses(config_.camera);
    frames_posed_again_ = refinement.frames;
    refined_inlier_matches_ = refinement.inlier_matches;
    refined_chi2_ = refinement.chi2;
    spdlog::info("frames posed again in the final map: {}", refinement.frames);
  }
  return merged;
}

bool System::runFinalBundleAdjustment(const FinishOptions& finish_options) {
  if (!config_.loop.final_ba || !finish_options.final_ba || tracking_->state() == TrackingState::NotInitialized ||
      localize_)
    return false;
  frames_before_final_ba_ = frameTrajectory();
  keyframes_before_final_ba_ = keyframeTrajectory();
  ScopedStage stage(&timer_, "final_ba");
  const KeyFrameMap<CameraVelocity> velocities = keyframeVelocities();
  const FullBundleAdjustmentResult result =
      runFullBundleAdjustment(*map_, config_.loop.final_ba_iterations, {finish_options.abort_final_ba, nullptr},
                              config_.camera.readout_s > 0 ? &velocities : nullptr);
  if (!result.merged) {
    if (finish_options.abort_final_ba && finish_options.abort_final_ba->load())
      spdlog::warn("final bundle adjustment stopped; the map is kept as it was before it");
    frames_before_final_ba_.clear();
    keyframes_before_final_ba_.clear();
    return false;
  }
  spdlog::info("final bundle adjustment: {} keyframes, {} points, cost {:.1f} -> {:.1f}", result.keyframes,
               result.points, result.initial_cost, result.final_cost);
  return true;
}

KeyFrameMap<CameraVelocity> System::keyframeVelocities() const {
  KeyFrameMap<CameraVelocity> velocities;
  if (config_.camera.readout_s <= 0) return velocities;
  // A monocular map is corrected for the camera's rotation only: a
  // correction's translation is in the map's units as they stand, so it breaks
  // the map's free scale and the BA trades scale for it (fr1_xyz's map shrank
  // to 0.66 of its size; to 0.95 with the second keyframe's distance held). A
  // rotation is the same at every scale.
  const bool rotation_only = config_.sensor == SensorMode::Monocular;
  std::lock_guard<std::mutex> lock(map_->mutex());
  const std::vector<FrameRecord>& records = tracking_->records();
  const std::vector<CameraVelocity> frame_velocities = tracking_->frameVelocities();
  // A keyframe is the frame of its index and timestamp (a loaded map's
  // keyframes come from another run's frames).
  std::map<std::pair<int, double>, size_t> record_of_frame;
  for (size_t k = 0; k < records.size(); ++k) record_of_frame[{records[k].index, records[k].timestamp}] = k;
  for (KeyFrame* keyframe : map_->keyframes()) {
    const auto it = record_of_frame.find({keyframe->frameIndex(), keyframe->timestamp()});
    if (it == record_of_frame.end()) continue;
    CameraVelocity& velocity = velocities[keyframe] = frame_velocities[it->second];
    if (rotation_only) velocity.linear.setZero();
  }
  return velocities;
}

std::vector<LoopRecord> System::loops() const {
  return loop_closing_ ? loop_closing_->loops() : std::vector<LoopRecord>{};
}

std::vector<StampedPose> System::frameTrajectory() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<StampedPose> trajectory;
  for (const FrameRecord& record : tracking_->records()) {
    if (!record.tracked || !record.reference) continue;
    const SE3 T_cw = poseThroughReference(record.reference, record.T_c_ref);
    trajectory.push_back({record.timestamp, T_cw.inverse()});
  }
  return trajectory;
}

std::vector<StampedPose> System::keyframeTrajectory() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<StampedPose> trajectory;
  for (KeyFrame* keyframe : map_->keyframes()) trajectory.push_back({keyframe->timestamp(), keyframe->pose().inverse()});
  std::sort(trajectory.begin(), trajectory.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  return trajectory;
}

std::vector<int> System::lostFrameIndices() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<int> lost;
  for (const FrameRecord& record : tracking_->records())
    if (!record.tracked) lost.push_back(record.index);
  return lost;
}

std::vector<ExportedMapPoint> System::mapPoints() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<ExportedMapPoint> points;
  for (MapPoint* point : map_->mapPoints())
    points.push_back({point->id(), point->position(), point->colour(), point->classId(), point->observationCount()});
  return points;
}

std::vector<ExportedKeyFrame> System::keyFrames() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  std::vector<ExportedKeyFrame> keyframes;
  for (KeyFrame* keyframe : map_->keyframes())
    keyframes.push_back({keyframe->id(), keyframe->frameIndex(), keyframe->timestamp(), keyframe->pose().inverse()});
  return keyframes;
}

SystemStats System::stats() const {
  std::lock_guard<std::mutex> lock(map_->mutex());
  SystemStats stats;
  for (const FrameRecord& record : tracking_->records()) {
    ++stats.frames;
    if (record.tracked) ++stats.frames_tracked;
  }
  stats.keyframes = static_cast<int>(map_->keyframeCount());
  stats.map_points = static_cast<int>(map_->mapPointCount());
  stats.initialised_at_index = tracking_->initialisedAtIndex();
  if (stats.initialised_at_index < 0) stats.start_failure = tracking_->lastStartFailure();
  stats.local_bundle_adjustments = local_mapping_->localBundleAdjustments();
  stats.culled_keyframes = local_mapping_->culledKeyFrames();
  stats.relocalisations = tracking_->relocalisations();
  stats.map_resets = tracking_->mapResets();
  stats.keyframe_waits = tracking_->keyframeWaits();
  stats.frames_without_depth = frames_without_depth_;
  stats.frames_extracted_ahead = extraction_ahead_ ? extraction_ahead_->jobsTaken() : 0;
  const Tracking::MovingObjectStats& moving = tracking_->movingObjectStats();
  stats.moving_boxes_checked = moving.boxes_checked;
  stats.moving_boxes_moving = moving.moving;
  stats.moving_boxes_parked = moving.parked;
  stats.moving_boxes_undecided = moving.undecided;
  stats.moving_points_retired = moving.points_retired;
  stats.frames_posed_again = frames_posed_again_;
  stats.refined_inlier_matches = refined_inlier_matches_;
  stats.refined_mean_chi2 = refined_inlier_matches_ > 0 ? refined_chi2_ / refined_inlier_matches_ : 0.0;
  if (loop_closing_) stats.implausible_loops_rejected = loop_closing_->implausibleLoopsRejected();
  if (loaded_max_keyframe_id_ >= 0) {
    stats.frames_in_loaded_map = 0;
    for (const FrameRecord& record : tracking_->records())
      if (record.tracked && record.reference && record.reference->id() <= loaded_max_keyframe_id_ &&
          !record.by_odometry)
        ++stats.frames_in_loaded_map;
  }
  for (const FrameRecord& record : tracking_->records()) stats.frames_by_odometry += record.by_odometry;
  return stats;
}

DetectionSummary System::detectionSummary() const {
  DetectionSummary summary;
  if (!detection_) return summary;
  auto median = [](const std::vector<int>& values) {
    return percentile(std::vector<double>(values.begin(), values.end()), 0.5);
  };
  summary.enabled = true;
  summary.model = detection_->files().name;
  summary.cfg = detection_->files().cfg;
  summary.input_size = detection_->inputSize().width;
  summary.input_height = detection_->inputSize().height;
  summary.placeholder_weights = detection_->placeholderWeights();
  summary.frames = static_cast<int>(keypoints_added_.size());
  summary.median_ms = percentile(timer_.samples("detect"), 0.5);
  summary.wait_median_ms = percentile(timer_.samples("detect_wait"), 0.5);
  summary.detect_every = toString(detection_->detectEvery());
  summary.box_filter = detection_->params().box_filter;
  const DetectionScheduleStats schedule = detection_->scheduleStats();
  summary.network_frames = schedule.network_frames;
  summary.fresh_frames = schedule.fresh_frames;
  summary.carried_frames = schedule.carried_frames;
  summary.box_age_median = percentile(std::vector<double>(schedule.ages.begin(), schedule.ages.end()), 0.5);
  if (!schedule.carried_iou.empty()) summary.carried_iou_median = percentile(schedule.carried_iou, 0.5);
  summary.boxes_expired = schedule.expired;
  summary.boxes_unmoved = schedule.unmoved;
  for (int reused : keypoints_reused_) summary.frame_keypoints_reused_total += reused;
  for (int dropped : duplicates_dropped_) summary.duplicates_dropped_total += dropped;
  summary.keypoints_added_per_frame = median(keypoints_added_);
  summary.keypoints_removed_per_frame = median(keypoints_removed_);
  summary.boxes_used_per_frame = median(boxes_used_);
  for (int added : keypoints_added_) summary.keypoints_added_total += added;
  return summary;
}

namespace {

// The detector-labelled map points and how far keyframes see points: what
// object landmarks are grouped from.
struct LabelledScene {
  std::vector<LabelledPoint> points;
  std::vector<double> depths;  // keyframe-to-point distances: the scene's scale
};

// The caller holds map.mutex().
LabelledScene labelledSceneOf(const Map& map) {
  LabelledScene scene;
  for (MapPoint* point : map.mapPoints()) {
    LabelledPoint entry{point->id(), point->position(), point->classId(), point->classConfidence(), {}, {}};
    for (const auto& [keyframe, keypoint] : point->observations()) {
      if (keyframe->isBad()) continue;
      const Vec3 ray = point->position() - keyframe->cameraCentre();
      scene.depths.push_back(ray.norm());
      if (ray.norm() > 0.0) entry.viewing_direction += ray.normalized();
      entry.keyframe_ids.push_back(keyframe->id());
      if (entry.class_id < 0 || static_cast<size_t>(keypoint) >= keyframe->labels.size()) continue;
      const FeatureLabel& label = keyframe->labels[keypoint];
      if (label.class_id == entry.class_id && label.detection_id >= 0)
        entry.detections.emplace_back(keyframe->id(), label.detection_id);
    }
    if (entry.viewing_direction.norm() > 0.0) entry.viewing_direction.normalize();
    if (entry.class_id >= 0) scene.points.push_back(std::move(entry));
  }
  return scene;
}

std::vector<ObjectLandmark> objectsOf(LabelledScene scene, const ObjectMapParams& params,
                                      const std::vector<std::string>& class_names) {
  const double link_distance = linkDistanceFor(percentile(std::move(scene.depths), 0.5), params);
  return buildObjectMap(scene.points, link_distance, params, class_names);
}

}  // namespace

std::vector<ObjectLandmark> System::objectMap(const ObjectMapParams& params) const {
  if (!detection_) return {};
  LabelledScene scene;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    scene = labelledSceneOf(*map_);
  }
  return objectsOf(std::move(scene), params, detection_->classNames());
}

void System::saveMap(const std::string& path, const std::string& sequence) const {
  // The vocabulary's checksum is computed when first needed: a run that saves
  // no map does not read the vocabulary twice.
  MapFileHeader header(mapIdentityOf(config_, vocabulary_path_));
  header.vocabulary_file = vocabulary_path_.empty() ? "none" : vocabulary_path_;
  header.sequence = sequence;
  const std::vector<std::string> class_names = detection_ ? detection_->classNames() : std::vector<std::string>();
  // One hold of the lock for grouping and writing: otherwise Local Mapping
  // could cull points between the two, and the objects would describe another map.
  std::lock_guard<std::mutex> lock(map_->mutex());
  const std::vector<ObjectLandmark> objects =
      detection_ ? objectsOf(labelledSceneOf(*map_), ObjectMapParams(), class_names) : std::vector<ObjectLandmark>();
  saveMapDatabase(path, *map_, header, objects, class_names);
}

std::pair<int, int> System::loadMap(const std::string& path, bool localize) {
  if (next_frame_id_ > 0) throw std::logic_error("System::loadMap: only before the first frame");
  const MapFileHeader header = readMapHeader(path);
  checkMapCompatible(path, header, mapIdentityOf(config_, vocabulary_path_));
  std::pair<int, int> loaded;
  {
    std::lock_guard<std::mutex> lock(map_->mutex());
    loadMapDatabase(path, *map_, frame_builder_->camera(), frame_builder_->pyramid());
    // Relocalisation and loop detection find the old keyframes by their bags of words.
    for (KeyFrame* keyframe : map_->keyframes())
      if (database_ && keyframe->hasBow()) database_->add(keyframe->id(), keyframe->bow);
    loaded_max_keyframe_id_ = map_->maxKeyFrameId();
    loaded = {static_cast<int>(map_->keyframeCount()), static_cast<int>(map_->mapPointCount())};
  }
  localize_ = localize;
  tracking_->startInLoadedMap(localize);
  spdlog::info("loaded map {}: {} keyframes, {} map points ({}{})", path, loaded.first, loaded.second,
               header.sequence, localize ? "; localisation only" : "; mapping continues in it");
  return loaded;
}

int System::lastTrackedPoints() const { return tracking_->lastTrackedPoints(); }
int System::lastMatchedPoints() const { return tracking_->lastMatchedPoints(); }

}  // namespace vslam
