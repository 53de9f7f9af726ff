#include "vslam/slam/place_candidates.hpp"

#include <algorithm>
#include <utility>

namespace vslam {

std::vector<KeyFrame*> selectPlaceCandidates(const KeyframeDatabase& database, const Map& map, const BowVector& bow,
                                             const std::unordered_set<long>& exclude, double min_score,
                                             const PlaceCandidateRule& rule) {
  const auto shared = database.sharedWordCounts(bow, exclude);
  int max_shared = 0;
  for (const auto& [id, count] : shared) max_shared = std::max(max_shared, count);
  std::vector<std::pair<KeyFrame*, double>> scored;
  for (const auto& [id, score] : database.query(bow, min_score, exclude, 0)) {
    auto it = shared.find(id);
    if (it == shared.end() || it->second < rule.min_shared_words_ratio * max_shared) continue;
    KeyFrame* keyframe = map.keyFrameById(id);
    if (keyframe && !keyframe->isBad() && keyframe->hasBow()) scored.emplace_back(keyframe, score);
  }

  KeyFrameMap<double> score_of;
  for (const auto& [keyframe, score] : scored) score_of[keyframe] = score;
  std::vector<std::pair<KeyFrame*, double>> groups;  // best member, accumulated score
  double best_group = 0;
  for (const auto& [keyframe, score] : scored) {
    double accumulated = score;
    KeyFrame* best = keyframe;
    double best_score = score;
    for (KeyFrame* neighbour : keyframe->bestCovisibles(rule.group_covisibles)) {
      auto it = score_of.find(neighbour);
      if (it == score_of.end()) continue;
      accumulated += it->second;
      if (it->second > best_score) {
        best_score = it->second;
        best = neighbour;
      }
    }
    groups.emplace_back(best, accumulated);
    best_group = std::max(best_group, accumulated);
  }
  std::vector<KeyFrame*> candidates;
  KeyFrameSet seen;
  for (const auto& [keyframe, accumulated] : groups)
    if (accumulated >= rule.min_group_score_ratio * best_group && seen.insert(keyframe).second)
      candidates.push_back(keyframe);
  return candidates;
}

}  // namespace vslam
