#pragma once
// ORB extraction of the next frame on a thread of its own, while Tracking
// works on the current one. Extraction needs the image alone and is about two
// thirds of Tracking's time per frame; on 2 cores the rest of the pipeline
// leaves room for it beside Tracking (docs/BENCHMARKS.md, "Extraction ahead").
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include <opencv2/core.hpp>

#include "vslam/core/stage_timer.hpp"
#include "vslam/slam/frame_builder.hpp"

namespace vslam {

// Jobs are worked in the order submitted; at most kMaxJobs wait, since a
// caller submits the frame after the one it is about to take. submit() and
// take() are called from one thread (the one that calls System::processFrame);
// the worker only reads the image and the const FrameBuilder, and hands back
// features bit-identical to an extraction on the caller's thread.
class ExtractionAhead {
 public:
  // `builder` and `timer` (may be null) must outlive this object.
  ExtractionAhead(const FrameBuilder& builder, StageTimer* timer);
  ~ExtractionAhead();
  ExtractionAhead(const ExtractionAhead&) = delete;
  ExtractionAhead& operator=(const ExtractionAhead&) = delete;

  // Queues frame `index` with `n_features` (< 0: the configured number); the
  // oldest job is dropped when kMaxJobs are queued. `image` must not change
  // while it is worked on (cv::Mat shares its pixels).
  void submit(int index, const cv::Mat& image, int n_features);
  // The features of frame `index`, waiting for them if they are in work, when
  // they were submitted with the same feature count. Otherwise (not submitted,
  // another count, or an extraction that failed) nothing, and the caller
  // extracts on its own thread. When it was submitted, its job and those
  // before it are gone afterwards.
  std::optional<ExtractedFeatures> take(int index, int n_features);

  int jobsTaken() const { return jobs_taken_; }      // caller's thread only
  int jobsDropped() const { return jobs_dropped_; }  // submitted but never taken, or with another count

  static constexpr size_t kMaxJobs = 2;

 private:
  struct Job {
    long generation = 0;
    int index = -1;
    int n_features = 0;
    cv::Mat image;
    bool started = false, done = false;
    std::optional<ExtractedFeatures> features;
  };
  void run();

  const FrameBuilder& builder_;
  StageTimer* timer_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> jobs_;  // guarded by mutex_; in submission order
  long next_generation_ = 0;
  bool stop_ = false;
  int jobs_taken_ = 0, jobs_dropped_ = 0;
  std::thread thread_;  // last: started once everything above exists
};

}  // namespace vslam
