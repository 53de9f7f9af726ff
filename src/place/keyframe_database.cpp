#include "vslam/place/keyframe_database.hpp"

#include <algorithm>
#include <mutex>

namespace vslam {

void KeyframeDatabase::add(long keyframe_id, const BowVector& bow) {
  std::unique_lock lock(mutex_);
  eraseLocked(keyframe_id);
  std::vector<WordId>& words = words_of_keyframe_[keyframe_id];
  words.reserve(bow.size());
  for (const auto& [word, value] : bow) {
    inverted_file_[word].push_back({keyframe_id, value});
    words.push_back(word);
  }
}

void KeyframeDatabase::erase(long keyframe_id) {
  std::unique_lock lock(mutex_);
  eraseLocked(keyframe_id);
}

void KeyframeDatabase::eraseLocked(long keyframe_id) {
  const auto found = words_of_keyframe_.find(keyframe_id);
  if (found == words_of_keyframe_.end()) return;
  for (WordId word : found->second) {
    const auto postings = inverted_file_.find(word);
    if (postings == inverted_file_.end()) continue;
    auto& list = postings->second;
    list.erase(std::remove_if(list.begin(), list.end(),
                              [&](const Posting& posting) { return posting.keyframe_id == keyframe_id; }),
               list.end());
    if (list.empty()) inverted_file_.erase(postings);
  }
  words_of_keyframe_.erase(found);
}

void KeyframeDatabase::clear() {
  std::unique_lock lock(mutex_);
  inverted_file_.clear();
  words_of_keyframe_.clear();
}

std::vector<std::pair<long, double>> KeyframeDatabase::query(const BowVector& bow, double min_score,
                                                             const std::unordered_set<long>& exclude,
                                                             size_t max_results) const {
  std::unordered_map<long, double> scores;
  {
    std::shared_lock lock(mutex_);
    // Words in increasing order, as l1Score visits them, so both give the same sum.
    for (const auto& [word, value] : bow) {
      const auto postings = inverted_file_.find(word);
      if (postings == inverted_file_.end()) continue;
      for (const Posting& posting : postings->second) {
        if (exclude.count(posting.keyframe_id)) continue;
        scores[posting.keyframe_id] += std::min(value, posting.value);
      }
    }
  }
  std::vector<std::pair<long, double>> results;
  for (const auto& [keyframe_id, score] : scores)
    if (std::min(score, 1.0) >= min_score) results.emplace_back(keyframe_id, std::min(score, 1.0));
  std::sort(results.begin(), results.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  if (max_results > 0 && results.size() > max_results) results.resize(max_results);
  return results;
}

std::unordered_map<long, int> KeyframeDatabase::sharedWordCounts(const BowVector& bow,
                                                                 const std::unordered_set<long>& exclude) const {
  std::unordered_map<long, int> counts;
  std::shared_lock lock(mutex_);
  for (const auto& [word, value] : bow) {
    const auto postings = inverted_file_.find(word);
    if (postings == inverted_file_.end()) continue;
    for (const Posting& posting : postings->second)
      if (!exclude.count(posting.keyframe_id)) ++counts[posting.keyframe_id];
  }
  return counts;
}

size_t KeyframeDatabase::size() const {
  std::shared_lock lock(mutex_);
  return words_of_keyframe_.size();
}

bool KeyframeDatabase::contains(long keyframe_id) const {
  std::shared_lock lock(mutex_);
  return words_of_keyframe_.count(keyframe_id) > 0;
}

}  // namespace vslam
