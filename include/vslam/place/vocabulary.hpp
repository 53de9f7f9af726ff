#pragma once
// Visual vocabulary for place recognition, in the style of DBoW2 (Galvez-Lopez
// and Tardos, T-RO 2012), trained in this repository.
//
// A vocabulary tree clusters binary ORB descriptors (rows of 32 bytes) by
// hierarchical k-means with Hamming distance: `branching` children per node,
// at most `depth` levels below the root. The leaves are the words. Each word
// carries an IDF weight, log(N_images / n_images_containing_the_word), learnt
// from the training images. An image becomes a TF-IDF bag of words; two bags
// are compared with the L1 score.
//
// Files: `save` writes our compact little-endian binary form; `load` reads it
// or DBoW2's text format (ORB-SLAM's ORBvoc.txt), told apart by content.
//
// A Vocabulary does not change after train/load: its const members may be
// called from several threads at once (Tracking, Local Mapping, Loop Closing).
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vslam {

using WordId = uint32_t;
using NodeId = uint32_t;

// Word -> TF-IDF value. Ordered by word so that two bags merge in one pass.
// After `Vocabulary::transform` the values are positive and sum to 1; words
// whose weight is 0 (seen in every training image) are left out.
using BowVector = std::map<WordId, double>;

// Direct index: tree node -> indices (rows of the descriptor matrix) of the
// features that passed through it. Features that share a node are the only
// candidates worth comparing when matching two images.
using FeatureVector = std::map<NodeId, std::vector<int>>;

struct VocabularyParams {
  int branching = 10;  // k: children per node
  int depth = 5;       // L: levels below the root; the leaves are the words
  uint32_t seed = 42;  // the same seed and descriptors give the same vocabulary, bit for bit
  int max_kmeans_iterations = 10;
};

// L1 score of two L1-normalised bags: 1 - 0.5 * |a - b|_1, in [0, 1]
// (1: the same bag, 0: no word in common). Computed as the sum over shared
// words of min(a_w, b_w), which is the same number for normalised
// non-negative vectors and touches only the shared words.
double l1Score(const BowVector& a, const BowVector& b);

class Vocabulary {
 public:
  static constexpr WordId kNoWord = 0xFFFFFFFFu;

  Vocabulary() = default;  // empty: no words; transform gives empty bags

  // Hierarchical k-means++ on all rows of all matrices (CV_8U, 32 columns),
  // then IDF weights from how many of the images (one matrix per image)
  // contain each word. Deterministic: std::mt19937 seeded with params.seed,
  // mapped to integers by our own code (std::uniform_*_distribution is
  // implementation-defined), integer arithmetic throughout, fixed tie-breaks.
  // `progress`, when given, is called with the fraction done in [0, 1].
  // Throws std::invalid_argument for bad params or descriptors.
  static Vocabulary train(const std::vector<cv::Mat>& descriptors_per_image, const VocabularyParams& params,
                          const std::function<void(double)>& progress = {});

  // Bag of words of one image's descriptors (rows of 32 bytes, CV_8U) and its
  // direct index at the nodes `direct_index_levels_up` levels above the leaves
  // (level depth() - levels_up from the root; the root when that is <= 0; a
  // leaf that ends its branch higher up stands for itself). tf = count/total,
  // value = tf * idf, then L1-normalised. Every feature enters the direct
  // index, including those whose word has weight 0.
  void transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features,
                 int direct_index_levels_up = 4) const;
  BowVector transform(const cv::Mat& descriptors) const;

  // Word of one descriptor (32 bytes): greedy descent, closest child by
  // Hamming distance at each level, the lowest child index on ties; kNoWord
  // for an empty vocabulary. Word ids are 0 .. wordCount() - 1: the leaves
  // numbered breadth-first, whatever file the vocabulary came from (so an
  // ORBvoc.txt's word ids differ from ORB-SLAM's own numbering; bags and
  // scores are the same up to that renaming).
  WordId wordOf(const uint8_t* descriptor) const;

  // The L1 score; see l1Score.
  double score(const BowVector& a, const BowVector& b) const { return l1Score(a, b); }

  // Compact binary form, little-endian on every host; see
  // docs/PLACE_RECOGNITION.md for the layout. Throws InputError when the file
  // cannot be written, std::logic_error for an empty vocabulary.
  void save(const std::string& path) const;

  // DBoW2's text format, readable by ORB-SLAM2/3 (ORBvoc.txt) and by `load`:
  // nodes in breadth-first order, IDF weights printed so that they read back
  // exactly. Throws InputError when the file cannot be written.
  void saveDbow2Text(const std::string& path) const;

  // Our binary form (starts with "VSLAMVOC") or DBoW2's text format (first
  // line "k L scoring weighting", then "parent is_leaf d0 .. d31 weight" per
  // node). A missing, truncated or malformed file throws InputError
  // "FILE:LINE: what is wrong" (LINE for text files).
  static Vocabulary load(const std::string& path);
  // The same from the file's bytes; `name` is the file named in errors.
  static Vocabulary parse(const std::string& bytes, const std::string& name);

  size_t wordCount() const { return node_of_word_.size(); }
  size_t nodeCount() const { return child_count_.size(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  // Training parameters (seed and iterations are 0 for a DBoW2 text file).
  VocabularyParams params() const;
  double wordWeight(WordId word) const { return weights_.at(word); }
  bool empty() const { return node_of_word_.empty(); }

 private:
  static constexpr int kWordsPerDescriptor = 4;  // 32 bytes as four 64-bit words

  // Node `n` has children first_child_[n] .. first_child_[n] + child_count_[n] - 1
  // (nodes are numbered breadth-first, so siblings are contiguous and so are
  // their descriptors). Node 0 is the root and has no descriptor of its own.
  // Leaves have child_count_ 0 and a word.
  NodeId descend(const uint64_t* descriptor, int direct_index_level, NodeId* direct_index_node) const;
  // first_child_, word_of_node_ and node_of_word_ from child_count_: words are
  // the leaves in node order.
  void indexTree();
  static Vocabulary loadBinary(const std::string& path, const std::string& bytes);
  static Vocabulary loadDbow2Text(const std::string& path, const std::string& text);

  int branching_ = 0;
  int depth_ = 0;
  uint32_t seed_ = 0;
  int max_kmeans_iterations_ = 0;
  std::vector<uint32_t> child_count_;
  std::vector<uint32_t> first_child_;
  std::vector<uint64_t> node_descriptors_;  // kWordsPerDescriptor per node, node 0's is zero
  std::vector<WordId> word_of_node_;         // kNoWord for inner nodes
  std::vector<NodeId> node_of_word_;
  std::vector<double> weights_;              // per word (idf)
};

}  // namespace vslam
