#include "vslam/core/stage_timer.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace vslam {

void StageTimer::record(const std::string& stage, double ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  samples_[stage].push_back(ms);
}

std::vector<double> StageTimer::samples(const std::string& stage) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = samples_.find(stage);
  return it == samples_.end() ? std::vector<double>{} : it->second;
}

std::map<std::string, StageStats> StageTimer::summary() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, StageStats> result;
  for (const auto& [stage, values] : samples_) {
    if (values.empty()) continue;
    std::vector<double> sorted = values;
    std::sort(sorted.begin(), sorted.end());
    StageStats stats;
    stats.count = sorted.size();
    stats.total_ms = std::accumulate(sorted.begin(), sorted.end(), 0.0);
    stats.mean_ms = stats.total_ms / sorted.size();
    const size_t n = sorted.size();
    stats.median_ms = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    // Nearest-rank percentile.
    const size_t rank = static_cast<size_t>(std::ceil(0.95 * n));
    stats.p95_ms = sorted[std::clamp<size_t>(rank, 1, n) - 1];
    result[stage] = stats;
  }
  return result;
}

}  // namespace vslam
