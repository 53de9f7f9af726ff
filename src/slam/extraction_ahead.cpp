#include "vslam/slam/extraction_ahead.hpp"

#include <utility>

namespace vslam {

ExtractionAhead::ExtractionAhead(const FrameBuilder& builder, StageTimer* timer)
    : builder_(builder), timer_(timer), thread_([this] { run(); }) {}

ExtractionAhead::~ExtractionAhead() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void ExtractionAhead::submit(int index, const cv::Mat& image, int n_features) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (jobs_.size() >= kMaxJobs) {  // the worker drops a result whose job is gone
      jobs_.pop_front();
      ++jobs_dropped_;
    }
    Job& job = jobs_.emplace_back();
    job.generation = next_generation_++;
    job.index = index;
    job.n_features = builder_.resolvedFeatureCount(n_features);
    job.image = image;
  }
  cv_.notify_all();
}

std::optional<ExtractedFeatures> ExtractionAhead::take(int index, int n_features) {
  std::unique_lock<std::mutex> lock(mutex_);
  size_t position = 0;
  while (position < jobs_.size() && jobs_[position].index != index) ++position;
  if (position == jobs_.size()) return std::nullopt;  // not submitted: the jobs queued stay
  // Jobs before it are of frames that never came (skipped by the caller).
  for (; position > 0; --position) {
    jobs_.pop_front();
    ++jobs_dropped_;
  }
  if (jobs_.front().n_features != builder_.resolvedFeatureCount(n_features)) {
    jobs_.pop_front();
    ++jobs_dropped_;
    return std::nullopt;
  }
  // Only this thread removes jobs, so the front is still this one when done.
  cv_.wait(lock, [this] { return jobs_.front().done; });
  std::optional<ExtractedFeatures> features = std::move(jobs_.front().features);
  jobs_.pop_front();
  if (features) ++jobs_taken_;
  return features;
}

void ExtractionAhead::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  auto nextUnstarted = [this]() -> Job* {
    for (Job& job : jobs_)
      if (!job.started) return &job;
    return nullptr;
  };
  while (true) {
    cv_.wait(lock, [&] { return stop_ || nextUnstarted() != nullptr; });
    if (stop_) return;
    Job* job = nextUnstarted();
    job->started = true;
    const long generation = job->generation;
    const cv::Mat image = job->image;
    const int n_features = job->n_features;
    lock.unlock();
    std::optional<ExtractedFeatures> features;
    try {
      ScopedStage stage(timer_, "extract_ahead");
      features = builder_.extractFeatures(image, n_features);
    } catch (const std::exception&) {
      // Left to the caller, whose own extraction reports the error.
    }
    lock.lock();
    // The deque may have changed meanwhile: find the job again by its generation.
    for (Job& queued : jobs_) {
      if (queued.generation != generation) continue;
      queued.features = std::move(features);
      queued.done = true;
      cv_.notify_all();
      break;
    }
  }
}

}  // namespace vslam
