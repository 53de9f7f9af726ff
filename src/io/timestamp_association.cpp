#include "vslam/io/timestamp_association.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace vslam {

std::vector<std::pair<int, int>> associateTimestamps(const std::vector<double>& first,
                                                     const std::vector<double>& second, double max_difference) {
  struct Candidate {
    double difference;
    int first_index;
    int second_index;
  };
  // Only timestamps inside the window can pair, so a sorted scan replaces
  // associate.py's all-pairs loop without changing the result.
  std::vector<Candidate> candidates;
  for (int i = 0; i < static_cast<int>(first.size()); ++i) {
    auto it = std::lower_bound(second.begin(), second.end(), first[i] - max_difference);
    for (; it != second.end() && *it < first[i] + max_difference; ++it) {
      const double difference = std::abs(first[i] - *it);
      if (difference < max_difference) candidates.push_back({difference, i, static_cast<int>(it - second.begin())});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::tie(a.difference, a.first_index, a.second_index) <
           std::tie(b.difference, b.first_index, b.second_index);
  });

  std::vector<bool> first_used(first.size(), false), second_used(second.size(), false);
  std::vector<std::pair<int, int>> pairs;
  for (const Candidate& c : candidates) {
    if (first_used[c.first_index] || second_used[c.second_index]) continue;
    first_used[c.first_index] = second_used[c.second_index] = true;
    pairs.emplace_back(c.first_index, c.second_index);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace vslam
