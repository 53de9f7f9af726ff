#pragma once
// Pairing of two timestamp lists by the TUM RGB-D benchmark's associate.py rule.
#include <utility>
#include <vector>

namespace vslam {

// Pairs (index into `first`, index into `second`) of timestamps that differ by
// strictly less than `max_difference` seconds. As associate.py does: every
// candidate pair is sorted by |difference| (ties by the earlier timestamps) and
// taken greedily, so each timestamp is used at most once and the closest pairs
// win. Both lists must be sorted ascending. The result is sorted by `first`.
std::vector<std::pair<int, int>> associateTimestamps(const std::vector<double>& first,
                                                     const std::vector<double>& second, double max_difference);

}  // namespace vslam
