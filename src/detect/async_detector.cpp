#include "vslam/detect/async_detector.hpp"

#include <algorithm>
#include <chrono>
#include <iterator>
#include <stdexcept>
#include <string>

namespace vslam {

AsyncDetector::AsyncDetector(DetectFunction detect) : detect_(std::move(detect)), worker_([this] { run(); }) {}

AsyncDetector::~AsyncDetector() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  job_ready_.notify_all();
  worker_.join();
}

void AsyncDetector::submit(int frame_index, const cv::Mat& bgr) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool queued = std::any_of(jobs_.begin(), jobs_.end(), [&](const Job& job) { return job.frame_index == frame_index; });
    if (queued || in_progress_ == frame_index || results_.count(frame_index))
      throw std::logic_error("AsyncDetector: frame " + std::to_string(frame_index) + " submitted twice");
    jobs_.push_back({frame_index, bgr.clone()});
  }
  job_ready_.notify_one();
}

std::vector<Detection> AsyncDetector::wait(int frame_index) {
  const auto start = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  const bool known = in_progress_ == frame_index || results_.count(frame_index) ||
                     std::any_of(jobs_.begin(), jobs_.end(), [&](const Job& job) { return job.frame_index == frame_index; });
  if (!known) throw std::logic_error("AsyncDetector: wait for frame " + std::to_string(frame_index) + " never submitted");
  result_ready_.wait(lock, [&] { return results_.count(frame_index) > 0; });
  Result result = std::move(results_[frame_index]);
  results_.erase(frame_index);
  last_wait_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  total_wait_ms_ += last_wait_ms_;
  if (result.error) std::rethrow_exception(result.error);
  return std::move(result.detections);
}

std::optional<std::pair<int, std::vector<Detection>>> AsyncDetector::takeNewest() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (results_.empty()) return std::nullopt;
  auto newest = std::prev(results_.end());
  const int frame_index = newest->first;
  Result result = std::move(newest->second);
  results_.clear();
  if (result.error) std::rethrow_exception(result.error);
  return std::make_pair(frame_index, std::move(result.detections));
}

bool AsyncDetector::pending(int frame_index) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return in_progress_ == frame_index || results_.count(frame_index) ||
         std::any_of(jobs_.begin(), jobs_.end(), [&](const Job& job) { return job.frame_index == frame_index; });
}

bool AsyncDetector::idle() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return jobs_.empty() && in_progress_ < 0;
}

double AsyncDetector::lastRunMs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_run_ms_;
}

std::chrono::steady_clock::time_point AsyncDetector::lastFinish() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_finish_;
}

void AsyncDetector::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    job_ready_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
    if (stopping_) return;
    Job job = std::move(jobs_.front());
    jobs_.pop_front();
    in_progress_ = job.frame_index;
    lock.unlock();

    Result result;
    const auto start = std::chrono::steady_clock::now();
    try {
      result.detections = detect_(job.image);
    } catch (...) {
      result.error = std::current_exception();  // handed to whoever waits for this frame
    }
    const auto end = std::chrono::steady_clock::now();

    lock.lock();
    last_run_ms_ = std::chrono::duration<double, std::milli>(end - start).count();
    last_finish_ = end;
    results_[job.frame_index] = std::move(result);
    in_progress_ = -1;
    result_ready_.notify_all();
  }
}

}  // namespace vslam
