#include "run_slam.hpp"

#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "stop_signal.hpp"
#include "vslam/core/error.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/eval/kitti_odometry_metric.hpp"
#include "vslam/eval/rpe.hpp"
#include "vslam/io/atomic_file.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/render/run_renders.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"

namespace vslam::app {
namespace {

namespace fs = std::filesystem;

// A frame left out because one of its files could not be read.
struct SkippedFrame {
  int index = 0;
  std::string file;
  std::string reason;  // the one-line error, naming the file
};

struct LoadedFrame {
  size_t position = 0;
  cv::Mat image;
  cv::Mat depth;
  std::string error;  // the run cannot go on (e.g. an image of the wrong size)
  bool unreadable = false;
  SkippedFrame skipped;  // when unreadable
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
      LoadedFrame frame = load(i);
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

  LoadedFrame load(size_t i) const {
    LoadedFrame frame;
    frame.position = i;
    const FrameEntry& entry = sequence_.frames[i];
    std::string file = entry.image_path;
    try {
      frame.image = sequence_.loadColor(i);
      // A frame without a paired depth image is tracked from colour alone.
      file = entry.depth_path;
      if (with_depth_ && !entry.depth_path.empty()) frame.depth = sequence_.loadDepthMeters(i, frame.image.size());
    } catch (const FrameUnreadable& e) {
      frame.unreadable = true;
      frame.skipped = {entry.index, file, e.what()};
    } catch (const std::exception& e) {
      frame.error = e.what();
    }
    return frame;
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

// Writes `text` to `path` atomically; a write error (a full disk) names the file.
void writeTextFile(const std::string& path, const std::string& text) {
  writeFileAtomically(path, [&](const std::string& temporary) {
    std::ofstream out(temporary);
    out << text;
    out.close();
    if (!out) throw InputError(path, 0, "write error (is the disk full?)");
  });
}

void writeTrajectoryFile(const std::string& path, const std::vector<StampedPose>& poses) {
  writeFileAtomically(path, [&](const std::string& temporary) { writeTumTrajectory(temporary, poses); });
}

// The ground truth over the run's time span (with a little margin), in TUM
// format, so that the run folder is evaluated and rendered on its own.
void writeRunGroundTruth(const std::string& path, const Sequence& sequence, double first_t, double last_t) {
  constexpr double kMargin = 0.05;  // s
  std::vector<StampedPose> span;
  for (const StampedPose& pose : sequence.groundtruth)
    if (pose.timestamp >= first_t - kMargin && pose.timestamp <= last_t + kMargin) span.push_back(pose);
  writeTrajectoryFile(path, span);
}

// KITTI outputs beside the TUM files: trajectory_kitti.txt (12 numbers a line,
// what the KITTI devkit and `evo_ape kitti` read), trajectory_kitti_frames.txt
// (the frame of each line: lost frames have no line, none is invented), and
// groundtruth_kitti.txt (+ _frames) holding the ground truth of exactly those
// frames, line for line. Returns the report's "kitti_trajectory".
nlohmann::json writeKittiOutputs(const std::string& out_dir, const Sequence& sequence,
                                 const std::vector<StampedPose>& trajectory, const std::vector<int>& frames,
                                 size_t begin, size_t end) {
  auto writeKitti = [](const std::string& path, const std::vector<StampedPose>& poses) {
    writeFileAtomically(path, [&](const std::string& temporary) { writeKittiTrajectory(temporary, poses); });
  };
  auto writeFrames = [](const std::string& path, const std::vector<int>& frame_indices) {
    writeFileAtomically(path, [&](const std::string& temporary) { writeFrameIndexFile(temporary, frame_indices); });
  };
  writeKitti(out_dir + "/trajectory_kitti.txt", trajectory);
  writeFrames(out_dir + "/trajectory_kitti_frames.txt", frames);
  nlohmann::json json = {{"file", "trajectory_kitti.txt"},
                         {"frames_file", "trajectory_kitti_frames.txt"},
                         {"poses", trajectory.size()},
                         {"frames_in_run", end - begin},
                         {"frames_without_pose", (end - begin) - trajectory.size()}};
  if (sequence.hasGroundTruth()) {
    std::vector<StampedPose> groundtruth;
    for (int frame : frames) groundtruth.push_back(sequence.groundtruth[frame]);
    writeKitti(out_dir + "/groundtruth_kitti.txt", groundtruth);
    writeFrames(out_dir + "/groundtruth_kitti_frames.txt", frames);
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
                    {"keyframes", object.keyframe_ids},
                    {"points_rejected", static_cast<int>(object.rejected_point_ids.size())},
                    {"merged_classes", object.merged_classes}});
  writeTextFile(path, list.dump(2) + "\n");
}

nlohmann::json detectorJson(const DetectionSummary& summary) {
  if (!summary.enabled) return {{"model", "none"}};
  nlohmann::json json = {{"model", summary.model},
                         {"cfg", summary.cfg},
                         {"input_size", summary.input_size},
                         {"input_height", summary.input_height},
                         {"placeholder_weights", summary.placeholder_weights},
                         {"median_ms", summary.median_ms},
                         {"wait_median_ms", summary.wait_median_ms},
                         {"keypoints_added_per_frame", summary.keypoints_added_per_frame},
                         {"keypoints_added_total", summary.keypoints_added_total},
                         {"keypoints_removed_per_frame", summary.keypoints_removed_per_frame},
                         {"boxes_used_per_frame", summary.boxes_used_per_frame},
                         {"frames", summary.frames},
                         {"detect_every", summary.detect_every},
                         {"box_filter", summary.box_filter},
                         {"network_frames", summary.network_frames},
                         {"fresh_frames", summary.fresh_frames},
                         {"carried_frames", summary.carried_frames},
                         {"box_age_median", summary.box_age_median},
                         {"carried_iou_median",
                          summary.carried_iou_median < 0 ? nlohmann::json() : nlohmann::json(summary.carried_iou_median)},
                         {"boxes_expired", summary.boxes_expired},
                         {"boxes_unmoved", summary.boxes_unmoved},
                         {"frame_keypoints_reused_total", summary.frame_keypoints_reused_total},
                         {"duplicates_dropped_total", summary.duplicates_dropped_total}};
  if (summary.carried_iou_median < 0)
    json["carried_iou_unavailable"] = "measured only with --detect-every N, N > 1, on the frames the network sees";
  return json;
}

enum class RunStatus { Completed, Interrupted, Failed };

const char* toString(RunStatus status) {
  switch (status) {
    case RunStatus::Completed: return "completed";
    case RunStatus::Interrupted: return "interrupted";
    case RunStatus::Failed: return "failed";
  }
  return "";
}

// What the frame loop and the end of the run leave behind, whatever stopped them.
struct RunOutcome {
  RunStatus status = RunStatus::Completed;
  std::string error;                  // Failed: the first error, one line
  int stop_signal = 0;                // Interrupted: SIGINT or SIGTERM
  int frames_dropped = 0;             // --realtime: arrived while Tracking was busy
  std::vector<SkippedFrame> skipped;  // unreadable frames, left out
  std::vector<double> tracked_points;  // map points tracked in each tracked frame
  std::vector<double> inlier_ratios;   // of those, tracked / matched before outlier rejection
  bool final_ba = false;              // a final BA result was merged
  double wall_s = 0;

  // The first failure is the one reported: later ones usually follow from it.
  void fail(const std::string& message) {
    if (status == RunStatus::Failed) return;
    status = RunStatus::Failed;
    error = message;
    spdlog::error("{}", message);
  }
};

// Feeds frames [begin, end) to the system until they run out, a stop signal
// comes, or something fails. An unreadable frame is skipped (an error with --strict).
void runFrameLoop(System& system, const Sequence& sequence, size_t begin, size_t end, const RunOptions& options,
                  const StopRequest& stop, RunOutcome& outcome) {
  const auto start = std::chrono::steady_clock::now();
  FramePrefetcher prefetcher(sequence, begin, end, options.mode == "rgbd");
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
  while (have_loaded && stop.signal == 0) {
    if (options.realtime) {
      std::this_thread::sleep_until(arrival(loaded.position));
      // Only the newest frame that has arrived is tracked; the ones before it are dropped.
      while (have_ahead && arrival(ahead.position) <= std::chrono::steady_clock::now()) {
        ++outcome.frames_dropped;
        loaded = std::move(ahead);
        have_ahead = prefetcher.next(ahead);
      }
    }
    if (!loaded.error.empty()) throw InputError(loaded.error);
    if (loaded.unreadable) {
      if (options.strict) throw InputError(loaded.skipped.reason + " (--strict: no frame is skipped)");
      spdlog::warn("skipping frame {}: {}", loaded.skipped.index, loaded.skipped.reason);
      outcome.skipped.push_back(loaded.skipped);
    } else {
      // Detection of the next frame runs on its own thread while this one is tracked
      // (not in real time: which frame comes next is not known yet).
      if (!options.realtime && have_ahead && !ahead.unreadable && ahead.error.empty())
        system.submitAhead(sequence.frames[ahead.position].index, ahead.image);
      const FrameEntry& entry = sequence.frames[loaded.position];
      if (system.processFrame(entry.index, entry.timestamp, loaded.image, loaded.depth)) {
        outcome.tracked_points.push_back(system.lastTrackedPoints());
        if (system.lastMatchedPoints() > 0)
          outcome.inlier_ratios.push_back(static_cast<double>(system.lastTrackedPoints()) / system.lastMatchedPoints());
      }
    }
    loaded = std::move(ahead);
    have_loaded = have_ahead;
    have_ahead = have_loaded && prefetcher.next(ahead);
    ++processed;
    if (processed % 50 == 0 || !have_loaded) {
      const SystemStats stats = system.stats();
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      spdlog::info("frame {}/{}: tracked {}, keyframes {}, map points {}, {:.1f} fps", processed, end - begin,
                   stats.frames_tracked, stats.keyframes, stats.map_points, processed / elapsed);
    }
  }
}

// An interrupted run keeps the final BA only when it is quick: a map this small
// takes about a second (a second signal stops it anyway).
constexpr int kQuickFinalBaKeyframes = 100;

// Lets Local Mapping and Loop Closing finish their queues (Tracking waits for
// Local Mapping whenever its queue is full, so what is left is bounded), then
// runs the final BA unless the run was interrupted and the map is large.
void finishRun(System& system, const StopRequest& stop, RunOutcome& outcome) {
  FinishOptions finish;
  finish.abort_final_ba = &stop.skip_final_ba;
  if (outcome.status == RunStatus::Interrupted) {
    const int keyframes = system.stats().keyframes;
    finish.final_ba = keyframes <= kQuickFinalBaKeyframes && !stop.skip_final_ba;
    if (finish.final_ba)
      spdlog::warn("interrupted: finishing Local Mapping and the final BA (Ctrl-C again skips it)");
    else
      spdlog::warn("interrupted: finishing Local Mapping, without the final BA ({} keyframes{})", keyframes,
                   stop.skip_final_ba ? ", a second signal" : ": too many to be quick");
  }
  if (outcome.status == RunStatus::Failed) finish.final_ba = false;
  try {
    outcome.final_ba = system.finish(finish);
  } catch (const std::exception& e) {
    outcome.fail(e.what());
  }
}

// Puts `compute()` under `name`, or null and `<name>_unavailable` with the
// reason: a figure that cannot be computed is never a 0.
void putMetric(nlohmann::json& parent, const std::string& name, const std::function<nlohmann::json()>& compute) {
  try {
    parent[name] = compute();
  } catch (const InputError& error) {
    parent[name] = nullptr;
    parent[name + "_unavailable"] = error.what();
  }
}

// `parent[name]` is null with a reason when none of its parts could be computed.
void putMetricGroup(nlohmann::json& parent, const std::string& name, const nlohmann::json& group,
                    const std::vector<std::string>& parts) {
  for (const std::string& part : parts)
    if (!group[part].is_null()) {
      parent[name] = group;
      return;
    }
  parent[name] = nullptr;
  parent[name + "_unavailable"] = group[parts.front() + "_unavailable"];
}

// ATE of keyframes and frames, each whenever its own poses allow, and RPE of frames.
void putAccuracy(nlohmann::json& report, System& system, const Sequence& sequence, bool mono,
                 const std::vector<StampedPose>& trajectory, const std::vector<StampedPose>& keyframes) {
  if (!sequence.hasGroundTruth()) {
    report["ate"] = report["rpe"] = nullptr;
    report["ate_unavailable"] = report["rpe_unavailable"] = "the sequence has no ground truth";
    return;
  }
  nlohmann::json ate, rpe;
  putMetric(ate, "keyframes", [&] { return ateJson(keyframes, sequence, mono); });
  putMetric(ate, "frames", [&] { return ateJson(trajectory, sequence, mono); });
  putMetric(rpe, "frames", [&] {
    if (mono && ate["frames"].is_null())
      throw InputError("a monocular RPE needs the scale of the frames' ATE, and it has none");
    nlohmann::json json = rpeJson(trajectory, sequence, mono ? ate["frames"]["scale"].get<double>() : 1.0);
    if (json["pairs"] == 0) throw InputError("no two tracked frames are 1 s apart");
    return json;
  });
  putMetricGroup(report, "ate", ate, {"keyframes", "frames"});
  putMetricGroup(report, "rpe", rpe, {"frames"});
  for (const std::string part : {"keyframes", "frames"})
    if (ate[part].is_null()) spdlog::warn("no ATE of the {}: {}", part, ate[part + "_unavailable"].get<std::string>());
  if (report["ate"].is_null() || system.keyframeTrajectoryBeforeFinalBa().empty()) return;
  nlohmann::json before;
  putMetric(before, "keyframes", [&] { return ateJson(system.keyframeTrajectoryBeforeFinalBa(), sequence, mono); });
  putMetric(before, "frames", [&] { return ateJson(system.frameTrajectoryBeforeFinalBa(), sequence, mono); });
  report["ate_before_final_ba"] = before;
}

void printSummary(const nlohmann::json& report, System& system, const Sequence& sequence, const RunOptions& options,
                  const RunOutcome& outcome, const std::string& out_dir) {
  const bool mono = options.mode == "mono";
  const SystemStats stats = system.stats();
  std::cout << "sequence: " << sequence.name << " (" << options.mode << ")\n";
  std::cout << "status: " << toString(outcome.status);
  if (outcome.status == RunStatus::Interrupted)
    std::cout << " (" << (outcome.stop_signal == SIGINT ? "SIGINT" : "SIGTERM") << " after " << stats.frames
              << " frames)";
  std::cout << "\nframes tracked: " << report["frames_tracked"].get<int>() << " / " << stats.frames;
  if (stats.initialised_at_index >= 0) std::cout << " (initialised at frame " << stats.initialised_at_index << ")";
  if (!outcome.skipped.empty()) std::cout << ", " << outcome.skipped.size() << " skipped (unreadable)";
  if (!stats.start_failure.empty()) std::cout << "\nno map was started; the last attempt: " << stats.start_failure;
  std::cout << "\nkeyframes: " << stats.keyframes << ", map points: " << stats.map_points << "\n";
  if (!options.load_map.empty())
    std::cout << "localised in the loaded map (" << options.load_map << (options.localize ? ", localisation only" : "")
              << "): " << stats.frames_in_loaded_map << " / " << stats.frames << " frames"
              << (stats.frames_by_odometry > 0
                      ? ", " + std::to_string(stats.frames_by_odometry) + " more by visual odometry"
                      : std::string())
              << "\n";
  if (report["ate"].is_object()) {
    const nlohmann::json& kf = report["ate"]["keyframes"];
    if (kf.is_null())
      std::cout << "ATE RMSE keyframes: none (" << report["ate"]["keyframes_unavailable"].get<std::string>() << ")\n";
    else if (mono)
      std::printf("ATE RMSE keyframes: %.4f m (%d pairs, Sim(3) alignment, scale %.4f)\n", kf["rmse_m"].get<double>(),
                  kf["pairs"].get<int>(), kf["scale"].get<double>());
    else
      std::printf("ATE RMSE keyframes: %.4f m (%d pairs, SE(3) alignment; Sim(3) would scale by %.4f)\n",
                  kf["rmse_m"].get<double>(), kf["pairs"].get<int>(), kf["sim3_scale"].get<double>());
    const nlohmann::json& frames = report["ate"]["frames"];
    if (frames.is_null())
      std::cout << "ATE RMSE frames:    none (" << report["ate"]["frames_unavailable"].get<std::string>() << ")\n";
    else
      std::printf("ATE RMSE frames:    %.4f m (%d pairs)\n", frames["rmse_m"].get<double>(), frames["pairs"].get<int>());
  }
  if (report.contains("ate_unavailable"))
    std::cout << "ATE: none (" << report["ate_unavailable"].get<std::string>() << ")\n";
  if (report.contains("ate_before_final_ba")) {
    auto rmse = [&](const char* part) {
      const nlohmann::json& ate = report["ate_before_final_ba"][part];
      return ate.is_null() ? std::string("none") : fmt::format("{:.4f} m", ate["rmse_m"].get<double>());
    };
    std::cout << "ATE RMSE before final BA: keyframes " << rmse("keyframes") << ", frames " << rmse("frames") << "\n";
  }
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
  std::cout << "loops closed: " << report["loops"].size() << ", relocalisations: " << stats.relocalisations << "\n";
  const auto summary = system.timer().summary();
  // "Tracking" per frame includes feature extraction, as ORB-SLAM reports it.
  if (summary.count("frame"))
    std::printf("tracking: median %.1f ms, p95 %.1f ms per frame; wall %.1f s (%.1f fps), peak %.0f MB\n",
                summary.at("frame").median_ms, summary.at("frame").p95_ms, outcome.wall_s,
                stats.frames / outcome.wall_s, peakRssMb());
  for (const char* stage : {"local_mapping", "loop_detection", "loop_correction", "full_ba", "final_ba"})
    if (summary.count(stage))
      std::printf("%s: median %.1f ms, p95 %.1f ms, %zu times\n", stage, summary.at(stage).median_ms,
                  summary.at(stage).p95_ms, summary.at(stage).count);
  const DetectionSummary detection = system.detectionSummary();
  if (detection.enabled) {
    std::printf("detector: %s at %dx%d, median %.1f ms per frame (Tracking waited %.1f), %.0f keypoints added per "
                "frame; %d objects\n",
                detection.model.c_str(), detection.input_size, detection.input_height, detection.median_ms,
                detection.wait_median_ms, detection.keypoints_added_per_frame, report["objects"].get<int>());
    std::printf("detect every %s: network on %d frames, %d frames with fresh boxes, %d with carried ones only "
                "(median box age %.0f)\n",
                detection.detect_every.c_str(), detection.network_frames, detection.fresh_frames,
                detection.carried_frames, detection.box_age_median);
  }
  std::cout << "output: " << out_dir << "\n";
  std::fflush(stdout);
}

}  // namespace

int runSlam(const Sequence& sequence, const RunOptions& options) {
  const bool mono = options.mode == "mono";
  const std::string out_dir = options.out_dir.empty() ? defaultOutDir(sequence.name) : options.out_dir;
  const size_t begin = std::min<size_t>(options.start_frame, sequence.frames.size());
  size_t end = sequence.frames.size();
  if (options.max_frames > 0) end = std::min(end, begin + options.max_frames);

  if (options.deterministic && options.realtime)
    throw InputError("--realtime and --deterministic exclude each other: a live camera does not wait");
  if ((sequence.config.sensor == SensorMode::RgbD) == mono)
    throw std::logic_error("runSlam: --mode and the config's sensor disagree");
  // Every listed file is there before any work starts: a missing one fails now, not at frame 40.
  sequence.checkFilesPresent(begin, end, !mono);
  SystemOptions system_options;
  system_options.deterministic = options.deterministic;
  system_options.realtime = options.realtime;
  if (options.localize && options.load_map.empty())
    throw InputError("--localize needs --load-map: localisation is in a map saved by an earlier run");
  if (options.localize && !options.save_map.empty())
    throw InputError("--localize does not change the map, so --save-map would only copy it: drop one of them");
  System system(sequence.config, system_options);
  std::pair<int, int> loaded{0, 0};  // keyframes and points of the loaded map
  if (!options.load_map.empty()) {
    const auto load_start = std::chrono::steady_clock::now();
    loaded = system.loadMap(options.load_map, options.localize);
    system.timer().record("load_map",
                          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start).count());
  }
  std::error_code error;
  fs::create_directories(out_dir, error);
  if (error) throw InputError(out_dir, 0, "cannot create the output folder: " + error.message());

  spdlog::info("running {} ({} frames, {}, {}) into {}", sequence.name, end - begin, options.mode,
               options.deterministic ? "deterministic" : options.realtime ? "threaded, real time" : "threaded",
               out_dir);
  // Ctrl-C from here until the outputs are written stops the run and keeps what it has.
  auto stop_signals = std::make_unique<StopSignals>();
  const StopRequest& stop = stop_signals->request();
  const auto start = std::chrono::steady_clock::now();
  RunOutcome outcome;
  try {
    runFrameLoop(system, sequence, begin, end, options, stop, outcome);
  } catch (const std::exception& e) {
    outcome.fail(e.what());
  }
  auto noteInterruption = [&] {
    if (stop.signal == 0 || outcome.status != RunStatus::Completed) return;
    outcome.status = RunStatus::Interrupted;
    outcome.stop_signal = stop.signal;
  };
  noteInterruption();
  finishRun(system, stop, outcome);
  noteInterruption();  // a signal during the final BA of a run that had read every frame
  outcome.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Every output that can be written is: one that fails fails the run, not the others.
  auto write = [&](const std::function<void()>& write_one) {
    try {
      write_one();
    } catch (const std::exception& e) {
      outcome.fail(e.what());
    }
  };
  const std::vector<StampedPose> trajectory = system.frameTrajectory();
  const std::vector<StampedPose> keyframes = system.keyframeTrajectory();
  write([&] { writeTrajectoryFile(out_dir + "/trajectory.txt", trajectory); });
  write([&] { writeTrajectoryFile(out_dir + "/keyframes.txt", keyframes); });
  write([&] {
    std::vector<PlyPoint> cloud;
    for (const ExportedMapPoint& point : system.mapPoints()) cloud.push_back({point.position, point.bgr, point.class_id});
    writeFileAtomically(out_dir + "/map.ply", [&](const std::string& temporary) { writeMapPly(temporary, cloud); });
  });
  bool map_saved = false;
  if (!options.save_map.empty())
    write([&] {
      const auto save_start = std::chrono::steady_clock::now();
      system.saveMap(options.save_map, sequence.name);
      const double save_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - save_start).count();
      spdlog::info("map saved to {} in {:.2f} s", options.save_map, save_s);
      system.timer().record("save_map", 1000.0 * save_s);
      map_saved = true;
    });
  const bool kitti = sequence.kind == SequenceKind::Kitti;
  std::vector<int> trajectory_frames;  // KITTI: the frame of each pose, by its timestamp (times.txt increases)
  if (kitti) {
    std::map<double, int> frame_at;
    for (size_t k = begin; k < end; ++k) frame_at[sequence.frames[k].timestamp] = sequence.frames[k].index;
    for (const StampedPose& pose : trajectory) trajectory_frames.push_back(frame_at.at(pose.timestamp));
  }
  const std::vector<ObjectLandmark> objects = system.objectMap();
  write([&] { writeObjectsJson(out_dir + "/objects.json", objects); });

  const SystemStats stats = system.stats();
  nlohmann::json report;
  report["sequence"] = sequence.name;
  report["sequence_root"] = sequence.root;
  report["mode"] = options.mode;
  report["deterministic"] = options.deterministic;
  report["realtime"] = options.realtime;
  report["frames_dropped"] = outcome.frames_dropped;
  report["camera"] = sequence.config.camera.name;
  report["vocabulary"] = system.vocabularyPath().empty() ? nlohmann::json() : nlohmann::json(system.vocabularyPath());
  report["frames_expected"] = sequence.frames_expected > 0 ? nlohmann::json(sequence.frames_expected) : nullptr;
  report["frames_total"] = stats.frames;
  report["frames_processed"] = stats.frames;
  report["frames_tracked"] = static_cast<int>(trajectory.size());
  report["frames_lost"] = system.lostFrameIndices();
  report["frames_skipped"] = static_cast<int>(outcome.skipped.size());
  report["skipped_frames"] = nlohmann::json::array();
  for (const SkippedFrame& skipped : outcome.skipped)
    report["skipped_frames"].push_back({{"frame", skipped.index}, {"file", skipped.file}, {"reason", skipped.reason}});
  report["initialised_at_frame"] = stats.initialised_at_index;
  // Why no map was started, when none was (null otherwise).
  report["start_failure"] = stats.start_failure.empty() ? nlohmann::json() : nlohmann::json(stats.start_failure);
  report["keyframes"] = stats.keyframes;
  report["map_points"] = stats.map_points;
  report["local_bundle_adjustments"] = stats.local_bundle_adjustments;
  report["culled_keyframes"] = stats.culled_keyframes;
  report["keyframe_waits"] = stats.keyframe_waits;
  report["map_resets"] = stats.map_resets;
  report["implausible_loops_rejected"] = stats.implausible_loops_rejected;
  if (!mono) report["frames_without_depth"] = stats.frames_without_depth;
  report["frames_extracted_ahead"] = stats.frames_extracted_ahead;
  report["groundtruth_file"] = sequence.groundtruth_path;
  if (sequence.hasGroundTruth() && end > begin) {
    write([&] {
      writeRunGroundTruth(out_dir + "/groundtruth.txt", sequence, sequence.frames[begin].timestamp,
                          sequence.frames[end - 1].timestamp);
    });
    report["groundtruth_source"] = sequence.groundtruth_path;
    report["groundtruth_file"] = "groundtruth.txt";  // in the run folder
  }
  // Ground truth of another body (Bonn's markers), scored as the camera's:
  // the [R | t] that took it there, row by row; null when it was the camera's.
  report["groundtruth_camera_in_body"] = nlohmann::json();
  if (const std::optional<SE3>& camera_in_body = sequence.config.evaluation.groundtruth_camera_in_body) {
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) rows.push_back(camera_in_body->R(r, c));
      rows.push_back(camera_in_body->t(r));
    }
    report["groundtruth_camera_in_body"] = rows;
  }
  putAccuracy(report, system, sequence, mono, trajectory, keyframes);
  if (kitti) {
    write([&] {
      report["kitti_trajectory"] = writeKittiOutputs(out_dir, sequence, trajectory, trajectory_frames, begin, end);
    });
    report["kitti_odometry"] = nullptr;
    if (!sequence.hasGroundTruth())
      report["kitti_odometry_unavailable"] = "the sequence has no ground truth";
    else if (mono && !(report["ate"].is_object() && report["ate"]["frames"].is_object()))
      report["kitti_odometry_unavailable"] = "no Sim(3) alignment for this monocular run (no ATE of the frames)";
    else
      try {
        report["kitti_odometry"] =
            kittiOdometryJson(sequence, trajectory, trajectory_frames, begin, end, mono,
                              mono ? report["ate"]["frames"]["scale"].get<double>() : 1.0);
      } catch (const InputError& error) {
        report["kitti_odometry_unavailable"] = error.what();
      }
  }
  report["final_ba"] = outcome.final_ba;
  // A run that started in a saved map: the map, and how many frames were localised against it.
  if (options.load_map.empty()) {
    report["loaded_map"] = nullptr;
  } else {
    report["loaded_map"] = {{"file", options.load_map},
                            {"localize", options.localize},
                            {"keyframes", loaded.first},
                            {"map_points", loaded.second}};
    report["frames_localised_in_loaded_map"] = stats.frames_in_loaded_map;
    report["frames_tracked_by_odometry"] = stats.frames_by_odometry;
  }
  // The saved map (docs/MAPS.md); null when none was asked for or it could not be written (see "error").
  report["map_file"] = map_saved ? nlohmann::json(options.save_map) : nlohmann::json(nullptr);
  report["relocalisations"] = stats.relocalisations;
  // Per frame and box of a --moving-classes class: what the motion check found.
  report["moving_objects"] = {{"classes", sequence.config.detector.moving_classes},
                              {"box_frames_checked", stats.moving_boxes_checked},
                              {"moving", stats.moving_boxes_moving},
                              {"parked", stats.moving_boxes_parked},
                              {"undecided", stats.moving_boxes_undecided},
                              {"map_points_retired", stats.moving_points_retired}};
  // Frames posed again after the final BA (loop.refine_frames), with the mean
  // chi-square reprojection error of their inlier matches: what
  // camera.readout_s is calibrated by (docs/GEOMETRY.md, "Rolling shutter").
  report["frames_posed_again"] = {{"frames", stats.frames_posed_again},
                                  {"inlier_matches", stats.refined_inlier_matches},
                                  {"mean_chi2", stats.refined_mean_chi2},
                                  {"readout_s", sequence.config.camera.readout_s}};
  // Where each loop closed: the two keyframes' timestamps (loop keyframes are never culled).
  std::map<long, double> keyframe_timestamp;
  for (const ExportedKeyFrame& keyframe : system.keyFrames()) keyframe_timestamp[keyframe.id] = keyframe.timestamp;
  auto timestampOf = [&](long id) {
    auto it = keyframe_timestamp.find(id);
    return it == keyframe_timestamp.end() ? nlohmann::json(nullptr) : nlohmann::json(it->second);
  };
  nlohmann::json loops = nlohmann::json::array();
  for (const LoopRecord& loop : system.loops())
    loops.push_back({{"current_keyframe", loop.current_keyframe},
                     {"matched_keyframe", loop.matched_keyframe},
                     {"current_timestamp", timestampOf(loop.current_keyframe)},
                     {"matched_timestamp", timestampOf(loop.matched_keyframe)},
                     {"scale", loop.scale},
                     {"inliers", loop.inliers}});
  report["loops"] = loops;
  nlohmann::json stage_ms;
  for (const auto& [stage, s] : system.timer().summary())
    stage_ms[stage] = {{"median", s.median_ms}, {"p95", s.p95_ms}, {"mean", s.mean_ms}, {"count", s.count}};
  report["stage_ms"] = stage_ms;
  report["detector"] = detectorJson(system.detectionSummary());
  report["objects"] = static_cast<int>(objects.size());
  report["tracked_points_per_frame"] = percentile(outcome.tracked_points, 0.5);  // median over tracked frames
  report["inlier_ratio_per_frame"] = percentile(outcome.inlier_ratios, 0.5);
  report["wall_s"] = outcome.wall_s;
  report["fps"] = outcome.wall_s > 0 ? stats.frames / outcome.wall_s : 0.0;
  report["peak_rss_mb"] = peakRssMb();
  // Last, so that it says whether the other outputs were written.
  report["status"] = toString(outcome.status);
  report["error"] = outcome.status == RunStatus::Failed ? nlohmann::json(outcome.error) : nullptr;
  report["stop_signal"] = outcome.stop_signal == SIGINT ? nlohmann::json("SIGINT")
                          : outcome.stop_signal == SIGTERM ? nlohmann::json("SIGTERM")
                                                           : nullptr;
  try {
    writeTextFile(out_dir + "/report.json", report.dump(2) + "\n");
  } catch (const std::exception& e) {
    outcome.fail(e.what());
  }
  stop_signals.reset();  // the outputs are written: Ctrl-C ends the process again
  if (outcome.status == RunStatus::Completed && !options.no_render) renderRun(out_dir);

  printSummary(report, system, sequence, options, outcome, out_dir);
  switch (outcome.status) {
    case RunStatus::Completed: return 0;
    case RunStatus::Interrupted: return 128 + outcome.stop_signal;  // 130 for SIGINT, 143 for SIGTERM, as a shell does
    case RunStatus::Failed:
      std::cerr << "error: " << outcome.error << " (what was computed is in " << out_dir << ")\n";
      return 2;
  }
  return 2;
}

}  // namespace vslam::app
