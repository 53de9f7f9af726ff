#pragma once
// Runs detection on its own thread, a frame ahead of Tracking:
//
//   async.submit(0, image0);
//   for (i = 0; i < n; ++i) {
//     if (i + 1 < n) async.submit(i + 1, image[i + 1]);  // detection of i+1 starts now...
//     auto detections = async.wait(i);                     // ...while Tracking works on frame i
//     ...
//   }
//
// so that Tracking waits only for what detection takes beyond Tracking's own
// work on the previous frame.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <utility>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/detect/detector.hpp"

namespace vslam {

class AsyncDetector {
 public:
  using DetectFunction = std::function<std::vector<Detection>(const cv::Mat& bgr)>;

  // `detect` runs on the detection thread only (e.g. a YoloDetector's
  // detect(), whose cv::dnn::Net then stays on that thread).
  explicit AsyncDetector(DetectFunction detect);
  // Stops the thread: finishes the frame in progress, drops those not started.
  ~AsyncDetector();
  AsyncDetector(const AsyncDetector&) = delete;
  AsyncDetector& operator=(const AsyncDetector&) = delete;

  // Queues a frame (the image is copied, so the caller may reuse its buffer).
  // Throws std::logic_error when that frame index is already queued or done.
  void submit(int frame_index, const cv::Mat& bgr);

  // Blocks (without spinning) until that frame's detections are ready and
  // returns them; rethrows what the detect function threw for that frame.
  // Throws std::logic_error for a frame that was never submitted.
  std::vector<Detection> wait(int frame_index);

  // Without blocking: the newest finished frame's detections, dropping older
  // finished ones (their frames are past); nullopt when none has finished.
  // Rethrows what the detect function threw for that frame.
  std::optional<std::pair<int, std::vector<Detection>>> takeNewest();
  // Whether the frame was submitted and not yet taken (queued, running or finished).
  bool pending(int frame_index) const;
  // Nothing queued and nothing running.
  bool idle() const;
  // Wall time of the last finished detection and when it finished (the
  // epoch when none has), for pacing how often to detect.
  double lastRunMs() const;
  std::chrono::steady_clock::time_point lastFinish() const;

  double lastWaitMs() const { return last_wait_ms_; }    // time the last wait() blocked
  double totalWaitMs() const { return total_wait_ms_; }  // over every wait()

 private:
  struct Job {
    int frame_index;
    cv::Mat image;
  };
  struct Result {
    std::vector<Detection> detections;
    std::exception_ptr error;
  };

  void run();

  DetectFunction detect_;
  mutable std::mutex mutex_;
  std::condition_variable job_ready_;     // the worker waits on it
  std::condition_variable result_ready_;  // wait() waits on it
  std::deque<Job> jobs_;
  std::map<int, Result> results_;
  int in_progress_ = -1;  // frame the worker is detecting, -1 for none
  double last_run_ms_ = 0.0;
  std::chrono::steady_clock::time_point last_finish_;
  bool stopping_ = false;
  double last_wait_ms_ = 0.0, total_wait_ms_ = 0.0;
  std::thread worker_;  // last: starts after everything it uses exists
};

}  // namespace vslam
