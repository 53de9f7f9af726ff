#include "run_slam.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"

#include "vslam/eval/ate.hpp"
#include "vslam/eval/kitti_odometry_metric.hpp"
#include "vslam/eval/rpe.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/render/run_renders.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"

namespace vslam::app {
namespace {

namespace fs = std::filesystem;

struct LoadedFrame {
  size_t position = 0;
  cv::Mat image;
  cv::Mat depth;
  std::string error;
};

// Reads images on a separate thread, a few frames ahead, so Tracking never
// waits on JPEG decoding (the run goes as fast as frames can be processed).
class FramePrefetcher {
 public:
  FramePrefetcher(const Sequence& sequence, size_t begin, size_t end, bool with_depth)
      : sequence_(sequence), next_(begin), end_(end), with_depth_(with_depth) {
    thread_ = std::thread([this] { run(); });
  }
  ~FramePrefetcher() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  bool next(LoadedFrame& out) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return !queue_.empty() || done_; });
    if (queue_.empty()) return false;
    out = std::move(queue_.front());
    queue_.pop_front();
    cv_.notify_all();
    return true;
  }

 private:
  void run() {
    for (size_t i = next_; i < end_; ++i) {
      LoadedFrame frame;
      frame.position = i;
      try {
        frame.image = sequence_.loadColor(i);
        // A frame without a paired depth image is tracked from colour alone.
        if (with_depth_ && !sequence_.frames[i].depth_path.empty())
          frame.depth = sequence_.loadDepthMeters(i, frame.image.size());
      } catch (const std::exception& e) {
        frame.error = e.what();
      }
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return queue_.size() < kAhead || stop_; });
      if (stop_) break;
      const bool failed = !frame.error.empty();
      queue_.push_back(std::move(frame));
      cv_.notify_all();
      if (failed) break;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
    cv_.notify_all();
  }

  static constexpr size_t kAhead = 4;
  const Sequence& sequence_;
  size_t next_, end_;
  bool with_depth_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<LoadedFrame> queue_;
  bool stop_ = false, done_ = false;
  std::thread thread_;
};

double peakRssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

std::string defaultOutDir(const std::string& sequence_name) {
  std::string name = sequence_name;
  for (char& c : name)
    if (c == '/' || c == ' ') c = '_';
  while (!name.empty() && name.front() == '_') name.erase(name.begin());
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%d-%H%M%S", std::localtime(&now));
  return "runs/" + name + "-" + stamp;
}

// A monocular map has no scale of its own: it is aligned by Sim(3), never SE(3).
// An RGB-D map is metric and aligned by SE(3); the scale a Sim(3) alignment
// would find is reported beside it, as a check of that metric scale.
nlohmann::json ateJson(const std::vector<StampedPose>& estimate, const Sequence& sequence, bool mono) {
  AteOptions options;
  options.alignment = mono ? Alignment::Sim3 : Alignment::SE3;
  options.association = Association::Timestamp;
  nlohmann::json json = toJson(computeAte(estimate, sequence.groundtruth, options));
  json["alignment"] = toString(options.alignment);
  if (!mono) {
    options.alignment = Alignment::Sim3;
    const AteResult sim3 = computeAte(estimate, sequence.groundtruth, options);
    json["sim3_scale"] = sim3.scale;
    json["sim3_rmse_m"] = sim3.rmse_m;
  }
  return json;
}

// RPE over 1 s intervals (m/s, deg/s) for TUM and KITTI alike: KITTI frames
// carry times.txt's timestamps, and the usual 100 m intervals are longer than
// many runs. A monocular estimate is scaled by its ATE Sim(3) scale.
nlohmann::json rpeJson(const std::vector<StampedPose>& estimate, const Sequence& sequence, double scale) {
  RpeOptions options;
  options.delta = 1.0;
  options.association = Association::Timestamp;
  options.scale = scale;
  nlohmann::json json = toJson(computeRpe(estimate, sequence.groundtruth, options));
  json["delta_s"] = options.delta;
  return json;
}

// The ground truth over the run's time span (with a little margin), in TUM
// format, so that the run folder is evaluated and rendered on its own.
void writeRunGroundTruth(const std::string& path, const Sequence& sequence, double first_t, double last_t) {
  constexpr double kMargin = 0.05;  // s
  std::vector<StampedPose> span;
  for (const StampedPose& pose : sequence.groundtruth)
    if (pose.timestamp >= first_t - kMargin && pose.timestamp <= last_t + kMargin) span.push_back(pose);
  writeTumTrajectory(path, span);
}

// KITTI outputs beside the TUM files: trajectory_kitti.txt (12 numbers a line,
// what the KITTI devkit and `evo_ape kitti` read), trajectory_kitti_frames.txt
// (the frame of each line: lost frames have no line, none is invented), and
// groundtruth_kitti.txt (+ _frames) holding the ground truth of exactly those
// frames, line for line. Returns the report's "kitti_trajectory".
nlohmann::json writeKittiOutputs(const std::string& out_dir, const Sequence& sequence,
                                 const std::vector<StampedPose>& trajectory, const std::vector<int>& frames,
                                 size_t begin, size_t end) {
  writeKittiTrajectory(out_dir + "/trajectory_kitti.txt", trajectory);
  writeFrameIndexFile(out_dir + "/trajectory_kitti_frames.txt", frames);
  nlohmann::json json = {{"file", "trajectory_kitti.txt"},
                         {"frames_file", "trajectory_kitti_frames.txt"},
                         {"poses", trajectory.size()},
                         {"frames_in_run", end - begin},
                         {"frames_without_pose", (end - begin) - trajectory.size()}};
  if (sequence.hasGroundTruth()) {
    std::vector<StampedPose> groundtruth;
    for (int frame : frames) groundtruth.push_back(sequence.groundtruth[frame]);
    writeKittiTrajectory(out_dir + "/groundtruth_kitti.txt", groundtruth);
    writeFrameIndexFile(out_dir + "/groundtruth_kitti_frames.txt", frames);
    json["groundtruth_file"] = "groundtruth_kitti.txt";
  }
  return json;
}

// The KITTI odometry benchmark's error over the run's frames [begin, end), the
// estimate scaled by `scale` (a monocular run's ATE Sim(3) scale).
nlohmann::json kittiOdometryJson(const Sequence& sequence, const std::vector<StampedPose>& trajectory,
                                 const std::vector<int>& frames, size_t begin, size_t end, bool mono, double scale) {
  std::vector<SE3> groundtruth;
  for (size_t k = begin; k < end; ++k) groundtruth.push_back(sequence.groundtruth[k].T_wc);
  std::vector<std::optional<SE3>> estimate(groundtruth.size());
  for (size_t i = 0; i < trajectory.size(); ++i) estimate[frames[i] - begin] = trajectory[i].T_wc;
  KittiOdometryOptions options;
  options.scale = scale;
  nlohmann::json json = toJson(computeKittiOdometryError(groundtruth, estimate, options));
  json["alignment"] = mono ? "sim3" : "none";
  json["scale"] = scale;
  json["first_frame"] = begin;
  return json;
}

// A failure here is a warning: the run's other outputs are already written.
void renderRun(const std::string& out_dir) {
  try {
    for (const std::string& path : renderRunFolder(out_dir, out_dir)) spdlog::info("render: wrote {}", path);
  } catch (const std::exception& e) {
    spdlog::warn("render failed ({}); the run's other outputs are complete; retry with `vslam render {}`", e.what(),
                 out_dir);
  }
}

// The object landmarks in the layout render/run_renders.hpp reads.
void writeObjectsJson(const std::string& path, const std::vector<ObjectLandmark>& objects) {
  auto vec3 = [](const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  nlohmann::json list = nlohmann::json::array();
  for (const ObjectLandmark& object : objects)
    list.push_back({{"class", object.class_name},
                    {"class_id", object.class_id},
                    {"confidence", object.confidence},
                    {"centroid", vec3(object.centroid)},
                    {"box_min", vec3(object.box_min)},
                    {"box_max", vec3(object.box_max)},
                    {"points", static_cast<int>(object.point_ids.size())},
                    {"keyframes", object.keyframe_ids}});
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot write the object map");
  out << list.dump(2) << "\n";
}

nlohmann::json detectorJson(const DetectionSummary& summary) {
  if (!summary.enabled) return {{"model", "none"}};
  return {{"model", summary.model},
          {"cfg", summary.cfg},
          {"input_size", summary.input_size},
          {"median_ms", summary.median_ms},
          {"wait_median_ms", summary.wait_median_ms},
          {"keypoints_added_per_frame", summary.keypoints_added_per_frame},
          {"keypoints_added_total", summary.keypoints_added_total},
          {"keypoints_removed_per_frame", summary.keypoints_removed_per_frame},
          {"boxes_used_per_frame", summary.boxes_used_per_frame},
          {"frames", summary.frames}};
}

}  // namespace

int runSlam(const Sequence& sequence, const RunOptions& options) {
  const bool mono = options.mode == "mono";
  const std::string out_dir = options.out_dir.empty() ? defaultOutDir(sequence.name) : options.out_dir;
  std::error_code error;
  fs::create_directories(out_dir, error);
  if (error) throw InputError(out_dir, 0, "cannot create the output folder: " + error.message());

  const size_t begin = std::min<size_t>(options.start_frame, sequence.frames.size());
  size_t end = sequence.frames.size();
  if (options.max_frames > 0) end = std::min(end, begin + options.max_frames);

  if (options.deterministic && options.realtime)
    throw InputError("--realtime and --deterministic exclude each other: a live camera does not wait");
  if ((sequence.config.sensor == SensorMode::RgbD) == mono)
    throw std::logic_error("runSlam: --mode and the config's sensor disagree");
  SystemOptions system_options;
  system_options.deterministic = options.deterministic;
  system_options.realtime = options.realtime;
  System system(sequence.config, system_options);

  spdlog::info("running {} ({} frames, {}, {}) into {}", sequence.name, end - begin, options.mode,
               options.deterministic ? "deterministic" : options.realtime ? "threaded, real time" : "threaded",
               out_dir);
  const auto start = std::chrono::steady_clock::now();
  std::vector<double> tracked_points;  // map points tracked in each tracked frame
  int frames_dropped = 0;              // --realtime: arrived while Tracking was busy
  {
    FramePrefetcher prefetcher(sequence, begin, end, !mono);
    LoadedFrame loaded, ahead;
    size_t processed = 0;
    bool have_loaded = prefetcher.next(loaded);
    const double first_timestamp = begin < end ? sequence.frames[begin].timestamp : 0.0;
    // When a frame reaches a live camera's driver: its timestamp on the run's clock.
    auto arrival = [&](size_t position) {
      return start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double>(sequence.frames[position].timestamp - first_timestamp));
    };
    bool have_ahead = have_loaded && prefetcher.next(ahead);
    while (have_loaded) {
      if (options.realtime) {
        std::this_thread::sleep_until(arrival(loaded.position));
        // Only the newest frame that has arrived is tracked; the ones before it are dropped.
        while (have_ahead && arrival(ahead.position) <= std::chrono::steady_clock::now()) {
          ++frames_dropped;
          loaded = std::move(ahead);
          have_ahead = prefetcher.next(ahead);
        }
      }
      if (!loaded.error.empty()) throw InputError(loaded.error);
      // Detection of the next frame runs on its own thread while this one is tracked
      // (not in real time: which frame comes next is not known yet).
      if (!options.realtime && have_ahead && ahead.error.empty())
        system.submitAhead(sequence.frames[ahead.position].index, ahead.image);
      const FrameEntry& entry = sequence.frames[loaded.position];
      if (system.processFrame(entry.index, entry.timestamp, loaded.image, loaded.depth))
        tracked_points.push_back(system.lastTrackedPoints());
      loaded = std::move(ahead);
      have_loaded = have_ahead;
      have_ahead = have_loaded && prefetcher.next(ahead);
      ++processed;
      if (processed % 50 == 0 || !have_loaded) {
        const SystemStats stats = system.stats();
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        spdlog::info("frame {}/{}: tracked {}, keyframes {}, map points {}, {:.1f} fps", processed, end - begin,
                     stats.frames_tracked, stats.keyframes, stats.map_points, processed / elapsed);
      }
    }
  }
  system.finish();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const std::vector<StampedPose> trajectory = system.frameTrajectory();
  const std::vector<StampedPose> keyframes = system.keyframeTrajectory();
  writeTumTrajectory(out_dir + "/trajectory.txt", trajectory);
  writeTumTrajectory(out_dir + "/keyframes.txt", keyframes);
  const bool kitti = sequence.kind == SequenceKind::Kitti;
  std::vector<int> trajectory_frames;  // KITTI: the frame of each pose, by its timestamp (times.txt increases)
  if (kitti) {
    std::map<double, int> frame_at;
    for (size_t k = begin; k < end; ++k) frame_at[sequence.frames[k].timestamp] = sequence.frames[k].index;
    for (const StampedPose& pose : trajectory) trajectory_frames.push_back(frame_at.at(pose.timestamp));
  }

  std::vector<PlyPoint> cloud;
  for (const ExportedMapPoint& point : system.mapPoints()) cloud.push_back({point.position, point.bgr, point.class_id});
  writeMapPly(out_dir + "/map.ply", cloud);
  const std::vector<ObjectLandmark> objects = system.objectMap();
  writeObjectsJson(out_dir + "/objects.json", objects);

  const SystemStats stats = system.stats();
  const std::vector<int> lost = system.lostFrameIndices();
  nlohmann::json report;
  report["sequence"] = sequence.name;
  report["sequence_root"] = sequence.root;
  report["mode"] = options.mode;
  report["deterministic"] = options.deterministic;
  report["realtime"] = options.realtime;
  report["frames_dropped"] = frames_dropped;
  report["camera"] = sequence.config.camera.name;
  report["frames_total"] = stats.frames;
  report["frames_tracked"] = static_cast<int>(trajectory.size());
  report["frames_lost"] = lost;
  report["initialised_at_frame"] = stats.initialised_at_index;
  report["keyframes"] = stats.keyframes;
  report["map_points"] = stats.map_points;
  report["local_bundle_adjustments"] = stats.local_bundle_adjustments;
  report["culled_keyframes"] = stats.culled_keyframes;
  report["keyframe_waits"] = stats.keyframe_waits;
  report["map_resets"] = stats.map_resets;
  report["implausible_loops_rejected"] = stats.implausible_loops_rejected;
  if (!mono) report["frames_without_depth"] = stats.frames_without_depth;
  report["groundtruth_file"] = sequence.groundtruth_path;
  if (sequence.hasGroundTruth() && end > begin) {
    writeRunGroundTruth(out_dir + "/groundtruth.txt", sequence, sequence.frames[begin].timestamp,
                        sequence.frames[end - 1].timestamp);
    report["groundtruth_source"] = sequence.groundtruth_path;
    report["groundtruth_file"] = "groundtruth.txt";  // in the run folder
  }
  report["ate"] = nullptr;
  report["rpe"] = nullptr;
  // A run that tracked too little (fewer than 3 poses matched to the ground
  // truth, or all in one place) has no ATE; that is a result, not an error.
  if (sequence.hasGroundTruth() && !keyframes.empty()) {
    try {
      nlohmann::json ate, rpe;
      ate["keyframes"] = ateJson(keyframes, sequence, mono);
      ate["frames"] = ateJson(trajectory, sequence, mono);
      rpe["frames"] = rpeJson(trajectory, sequence, ate["frames"]["scale"].get<double>());
      report["ate"] = ate;
      report["rpe"] = rpe;
    } catch (const InputError& error) {
      report["ate_unavailable"] = error.what();
      spdlog::warn("no ATE for this run: {}", error.what());
    }
  }
  const std::vector<StampedPose>& keyframes_before_ba = system.keyframeTrajectoryBeforeFinalBa();
  if (report["ate"].is_object() && !keyframes_before_ba.empty()) {
    try {
      nlohmann::json before;
      before["keyframes"] = ateJson(keyframes_before_ba, sequence, mono);
      before["frames"] = ateJson(system.frameTrajectoryBeforeFinalBa(), sequence, mono);
      report["ate_before_final_ba"] = before;
    } catch (const InputError& error) {
      spdlog::warn("no ATE before the final BA: {}", error.what());
    }
  }
  if (kitti) {
    report["kitti_trajectory"] = writeKittiOutputs(out_dir, sequence, trajectory, trajectory_frames, begin, end);
    report["kitti_odometry"] = nullptr;
    if (!sequence.hasGroundTruth())
      report["kitti_odometry_unavailable"] = "the sequence has no ground truth";
    else if (mono && !report["ate"].is_object())
      report["kitti_odometry_unavailable"] = "no Sim(3) alignment for this monocular run (no ATE)";
    else
      report["kitti_odometry"] =
          kittiOdometryJson(sequence, trajectory, trajectory_frames, begin, end, mono,
                            mono ? report["ate"]["frames"]["scale"].get<double>() : 1.0);
  }
  report["final_ba"] = sequence.config.loop.final_ba;
  report["relocalisations"] = stats.relocalisations;
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopRecord& loop : system.loops())
    loops.push_back({{"current_keyframe", loop.current_keyframe},
                     {"matched_keyframe", loop.matched_keyframe},
                     {"scale", loop.scale},
                     {"inliers", loop.inliers}});
  report["loops"] = loops;
  nlohmann::json stage_ms;
  for (const auto& [stage, s] : system.timer().summary())
    stage_ms[stage] = {{"median", s.median_ms}, {"p95", s.p95_ms}, {"mean", s.mean_ms}, {"count", s.count}};
  report["stage_ms"] = stage_ms;
  report["detector"] = detectorJson(system.detectionSummary());
  report["objects"] = static_cast<int>(objects.size());
  report["tracked_points_per_frame"] = percentile(tracked_points, 0.5);  // median over tracked frames
  report["wall_s"] = wall_s;
  report["fps"] = wall_s > 0 ? stats.frames / wall_s : 0.0;
  report["peak_rss_mb"] = peakRssMb();
  std::ofstream(out_dir + "/report.json") << report.dump(2) << "\n";
  if (!options.no_render) renderRun(out_dir);

  // Summary on stdout.
  std::cout << "sequence: " << sequence.name << " (" << options.mode << ")\n";
  std::cout << "frames tracked: " << trajectory.size() << " / " << stats.frames;
  if (stats.initialised_at_index >= 0) std::cout << " (initialised at frame " << stats.initialised_at_index << ")";
  std::cout << "\nkeyframes: " << stats.keyframes << ", map points: " << stats.map_points << "\n";
  if (report["ate"].is_object()) {
    const nlohmann::json& kf = report["ate"]["keyframes"];
    if (mono)
      std::printf("ATE RMSE keyframes: %.4f m (%d pairs, Sim(3) alignment, scale %.4f)\n", kf["rmse_m"].get<double>(),
                  kf["pairs"].get<int>(), kf["scale"].get<double>());
    else
      std::printf("ATE RMSE keyframes: %.4f m (%d pairs, SE(3) alignment; Sim(3) would scale by %.4f)\n",
                  kf["rmse_m"].get<double>(), kf["pairs"].get<int>(), kf["sim3_scale"].get<double>());
    std::printf("ATE RMSE frames:    %.4f m (%d pairs)\n", report["ate"]["frames"]["rmse_m"].get<double>(),
                report["ate"]["frames"]["pairs"].get<int>());
  }
  if (report.contains("ate_unavailable"))
    std::cout << "ATE: none (" << report["ate_unavailable"].get<std::string>() << ")\n";
  if (report.contains("ate_before_final_ba"))
    std::printf("ATE RMSE before final BA: keyframes %.4f m, frames %.4f m\n",
                report["ate_before_final_ba"]["keyframes"]["rmse_m"].get<double>(),
                report["ate_before_final_ba"]["frames"]["rmse_m"].get<double>());
  if (report.contains("kitti_odometry")) {
    const nlohmann::json& metric = report["kitti_odometry"];
    if (metric.is_object() && metric["available"].get<bool>())
      std::printf("KITTI odometry:     translation %.4f %%, rotation %.4f deg/100m (%d subsequences of 100-800 m "
                  "scored, %d with an untracked end%s)\n",
                  metric["translation_error_pct"].get<double>(), metric["rotation_error_deg_per_100m"].get<double>(),
                  metric["subsequences"].get<int>(), metric["subsequences_without_estimate"].get<int>(),
                  mono ? "; Sim(3) scale" : "");
    else
      std::cout << "KITTI odometry:     none ("
                << (metric.is_object() ? metric["reason"].get<std::string>()
                                       : report["kitti_odometry_unavailable"].get<std::string>())
                << ")\n";
  }
  std::cout << "loops closed: " << loops.size() << ", relocalisations: " << stats.relocalisations << "\n";
  const auto summary = system.timer().summary();
  // "Tracking" per frame includes feature extraction, as ORB-SLAM reports it.
  if (summary.count("frame"))
    std::printf("tracking: median %.1f ms, p95 %.1f ms per frame; wall %.1f s (%.1f fps), peak %.0f MB\n",
                summary.at("frame").median_ms, summary.at("frame").p95_ms, wall_s, stats.frames / wall_s, peakRssMb());
  for (const char* stage : {"local_mapping", "loop_detection", "loop_correction", "full_ba", "final_ba"})
    if (summary.count(stage))
      std::printf("%s: median %.1f ms, p95 %.1f ms, %zu times\n", stage, summary.at(stage).median_ms,
                  summary.at(stage).p95_ms, summary.at(stage).count);
  const DetectionSummary detection = system.detectionSummary();
  if (detection.enabled)
    std::printf("detector: %s at %d, median %.1f ms per frame (Tracking waited %.1f), %.0f keypoints added per "
                "frame; %zu objects\n",
                detection.model.c_str(), detection.input_size, detection.median_ms, detection.wait_median_ms,
                detection.keypoints_added_per_frame, objects.size());
  std::cout << "output: " << out_dir << "\n";
  std::fflush(stdout);
  return 0;
}

}  // namespace vslam::app
