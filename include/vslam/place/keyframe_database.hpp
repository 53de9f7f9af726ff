#pragma once
// Keyframe database for relocalisation and loop detection: an inverted file
// from each word to the keyframes whose bag of words contains it.
//
// A query visits only the keyframes that share at least one word with it and
// scores them with the L1 score (l1Score in vocabulary.hpp), accumulated word
// by word from the inverted file: for L1-normalised bags,
// 1 - 0.5 |a - b|_1 = sum over shared words of min(a_w, b_w). ORB-SLAM's
// further steps (minimum shared words, covisibility groups) belong to the
// caller; sharedWordCounts gives what they need.
//
// Thread safety: every member may be called from any thread. Tracking
// (relocalisation) and Loop Closing query while Local Mapping adds and erases;
// an internal std::shared_mutex lets queries run together and makes add and
// erase exclusive. A query sees the database either before or after a
// concurrent add/erase, never half of it.
#include <cstddef>
#include <shared_mutex>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "vslam/place/vocabulary.hpp"

namespace vslam {

class KeyframeDatabase {
 public:
  // Adds a keyframe's bag of words; adding an id again replaces its bag.
  void add(long keyframe_id, const BowVector& bow);
  // Removes a keyframe; unknown ids are ignored.
  void erase(long keyframe_id);
  void clear();

  // Keyframes sharing at least one word with `bow`, not in `exclude`, whose L1
  // score is >= min_score; best score first (ties: lower id first), at most
  // `max_results` of them (0: all).
  std::vector<std::pair<long, double>> query(const BowVector& bow, double min_score,
                                             const std::unordered_set<long>& exclude, size_t max_results) const;

  // For every keyframe not in `exclude` that shares words with `bow`: how many.
  std::unordered_map<long, int> sharedWordCounts(const BowVector& bow, const std::unordered_set<long>& exclude) const;

  size_t size() const;  // keyframes held
  bool contains(long keyframe_id) const;

 private:
  struct Posting {
    long keyframe_id;
    double value;  // the keyframe's value for this word
  };
  void eraseLocked(long keyframe_id);

  mutable std::shared_mutex mutex_;
  std::unordered_map<WordId, std::vector<Posting>> inverted_file_;
  std::unordered_map<long, std::vector<WordId>> words_of_keyframe_;  // to erase without scanning every word
};

}  // namespace vslam
