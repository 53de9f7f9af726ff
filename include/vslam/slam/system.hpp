#pragma once
// The System facade: owns the map, runs Tracking on the caller's thread and
// Local Mapping on its own (or synchronously in deterministic mode), and gives
// back trajectories and the map for export.
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/core/stage_timer.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

class Map;
class LocalMapping;
class Tracking;
class FrameBuilder;
class Vocabulary;
class KeyframeDatabase;
class LoopClosing;
struct LoopRecord;

struct SystemOptions {
  bool deterministic = false;  // Local Mapping runs synchronously after each keyframe
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
  int local_bundle_adjustments = 0;
  int culled_keyframes = 0;
  int relocalisations = 0;
};

class System {
 public:
  System(const Config& config, const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // Tracks one image (BGR or grey); `depth_m` CV_32F metres or empty. Returns true when tracked.
  bool processFrame(int index, double timestamp, const cv::Mat& image, const cv::Mat& depth_m = cv::Mat());
  // Lets Local Mapping and Loop Closing finish their queues, stops the
  // threads, then runs the final full bundle adjustment (config.loop.final_ba).
  void finish();

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
  int lastTrackedPoints() const;
  StageTimer& timer() { return timer_; }

 private:
  Config config_;
  SystemOptions options_;
  StageTimer timer_;
  std::unique_ptr<Map> map_;
  std::unique_ptr<Vocabulary> vocabulary_;  // null: no relocalisation by BoW, no loop closing
  std::unique_ptr<KeyframeDatabase> database_;
  std::unique_ptr<FrameBuilder> frame_builder_;
  std::unique_ptr<LocalMapping> local_mapping_;
  std::unique_ptr<Tracking> tracking_;
  std::unique_ptr<LoopClosing> loop_closing_;
  std::vector<StampedPose> frames_before_final_ba_, keyframes_before_final_ba_;
  long next_frame_id_ = 0;
  bool finished_ = false;
};

}  // namespace vslam
