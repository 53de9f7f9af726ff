// Vocabulary lookups: descent through the tree, bags of words, the L1 score.
// Training is in vocabulary_train.cpp, files in vocabulary_io.cpp.
#include "vslam/place/vocabulary.hpp"

#include <algorithm>
#include <climits>
#include <cstring>
#include <stdexcept>

#include "hamming.hpp"

namespace vslam {

double l1Score(const BowVector& a, const BowVector& b) {
  // For non-negative a, b with |a|_1 = |b|_1 = 1:
  //   1 - 0.5 |a - b|_1 = 1 - 0.5 (sum a + sum b - 2 sum min(a_w, b_w)) = sum min(a_w, b_w).
  double score = 0.0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      score += std::min(ia->second, ib->second);
      ++ia;
      ++ib;
    }
  }
  return std::min(score, 1.0);  // rounding may overshoot 1 by an ulp or two
}

VocabularyParams Vocabulary::params() const {
  VocabularyParams p;
  p.branching = branching_;
  p.depth = depth_;
  p.seed = seed_;
  p.max_kmeans_iterations = max_kmeans_iterations_;
  return p;
}

void Vocabulary::indexTree() {
  // Breadth-first numbering: the children of node n directly follow those of node n - 1.
  first_child_.assign(child_count_.size(), 0);
  word_of_node_.assign(child_count_.size(), kNoWord);
  node_of_word_.clear();
  uint32_t next = 1;
  for (size_t n = 0; n < child_count_.size(); ++n) {
    first_child_[n] = next;
    next += child_count_[n];
    if (child_count_[n] == 0) {
      word_of_node_[n] = static_cast<WordId>(node_of_word_.size());
      node_of_word_.push_back(static_cast<NodeId>(n));
    }
  }
}

NodeId Vocabulary::descend(const uint64_t* descriptor, int direct_index_level, NodeId* direct_index_node) const {
  NodeId node = 0;
  int level = 0;
  if (direct_index_node) *direct_index_node = 0;
  while (child_count_[node] > 0) {
    const NodeId first = first_child_[node];
    const uint32_t count = child_count_[node];
    const uint64_t* children = &node_descriptors_[static_cast<size_t>(first) * kWordsPerDescriptor];
    int best_distance = INT_MAX;
    uint32_t best = 0;
    for (uint32_t c = 0; c < count; ++c) {
      const int distance = place::hamming256(descriptor, children + c * kWordsPerDescriptor);
      if (distance < best_distance) {
        best_distance = distance;
        best = c;
      }
    }
    node = first + best;
    ++level;
    if (direct_index_node && level <= direct_index_level) *direct_index_node = node;
  }
  return node;
}

WordId Vocabulary::wordOf(const uint8_t* descriptor) const {
  if (empty()) return kNoWord;
  uint64_t packed[kWordsPerDescriptor];
  std::memcpy(packed, descriptor, sizeof(packed));
  return word_of_node_[descend(packed, 0, nullptr)];
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features,
                           int direct_index_levels_up) const {
  bow.clear();
  features.clear();
  if (descriptors.empty() || empty()) return;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != 32)
    throw std::invalid_argument("Vocabulary::transform: descriptors must be CV_8U rows of 32 bytes");

  const int direct_index_level = std::max(0, depth_ - std::max(0, direct_index_levels_up));
  uint64_t packed[kWordsPerDescriptor];
  for (int row = 0; row < descriptors.rows; ++row) {
    std::memcpy(packed, descriptors.ptr<uint8_t>(row), sizeof(packed));
    NodeId direct_index_node = 0;
    const NodeId leaf = descend(packed, direct_index_level, &direct_index_node);
    const WordId word = word_of_node_[leaf];
    // Summing idf once per feature gives count * idf; dividing by the feature
    // count (tf) is absorbed by the L1 normalisation below.
    if (weights_[word] > 0.0) bow[word] += weights_[word];
    features[direct_index_node].push_back(row);
  }

  double total = 0.0;
  for (const auto& [word, value] : bow) total += value;
  if (total > 0.0)
    for (auto& [word, value] : bow) value /= total;
}

BowVector Vocabulary::transform(const cv::Mat& descriptors) const {
  BowVector bow;
  FeatureVector features;
  transform(descriptors, bow, features);
  return bow;
}

}  // namespace vslam
