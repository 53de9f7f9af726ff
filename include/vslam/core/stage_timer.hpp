#pragma once
// Per-stage wall-clock samples (milliseconds) for report.json's stage_ms.
#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace vslam {

struct StageStats {
  double median_ms = 0, p95_ms = 0, mean_ms = 0, total_ms = 0;
  size_t count = 0;
};

// Thread-safe: Tracking, Local Mapping and Loop Closing record into one timer.
class StageTimer {
 public:
  void record(const std::string& stage, double ms);
  std::map<std::string, StageStats> summary() const;
  std::vector<double> samples(const std::string& stage) const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::vector<double>> samples_;
};

// Records the time from construction to destruction (or stop()).
class ScopedStage {
 public:
  ScopedStage(StageTimer* timer, std::string stage)
      : timer_(timer), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}
  ~ScopedStage() { stop(); }
  double stop() {
    if (!timer_) return 0;
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
    timer_->record(stage_, ms);
    timer_ = nullptr;
    return ms;
  }

 private:
  StageTimer* timer_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace vslam
