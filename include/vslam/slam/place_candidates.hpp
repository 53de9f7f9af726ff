#pragma once
// ORB-SLAM2's selection of place-recognition candidates, shared by
// relocalisation (Tracking) and loop detection (Loop Closing): keyframes that
// share at least 80 % of the best candidate's count of words with the query
// and score at least `min_score`; each is grouped with its 10 best covisible
// keyframes, the group's score is the sum of its scored members, and the groups
// within 75 % of the best group survive, each represented by its best-scoring
// member. A place seen by several keyframes thus beats a single keyframe that
// happens to score high.
#include <unordered_set>
#include <vector>

#include "vslam/map/map.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {

struct PlaceCandidateRule {
  double min_shared_words_ratio = 0.8;  // of the most words any keyframe shares with the query
  double min_group_score_ratio = 0.75;  // of the best group's accumulated score
  size_t group_covisibles = 10;         // a candidate's group: itself and this many best covisibles
};

// Candidates in the order of their groups' first members (best single score
// first), each once. Caller holds the map lock; keyframes that are bad or have
// no bag of words are skipped.
std::vector<KeyFrame*> selectPlaceCandidates(const KeyframeDatabase& database, const Map& map, const BowVector& bow,
                                             const std::unordered_set<long>& exclude, double min_score,
                                             const PlaceCandidateRule& rule = {});

}  // namespace vslam
