// Vocabulary training: hierarchical k-means++ on binary descriptors with
// Hamming distance and bitwise-majority centres, then IDF weights.
//
// Reproducibility: the only randomness is one std::mt19937 seeded with
// params.seed, consumed in a fixed order (nodes breadth-first). Its raw 32-bit
// outputs are mapped to ranges by DeterministicRandom below rather than by
// std::uniform_int_distribution, whose algorithm differs between standard
// libraries. All distances and sums are integers, so the same descriptors
// give the same tree, bit for bit, on every platform.
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <deque>
#include <random>
#include <stdexcept>
#include <string>

#include "hamming.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {
namespace {

constexpr int kWords = 4;  // 64-bit words per descriptor

class DeterministicRandom {
 public:
  explicit DeterministicRandom(uint32_t seed) : engine_(seed) {}

  // Uniform integer in [0, n), n > 0: 64 random bits, rejecting the lowest
  // 2^64 mod n values so that every remainder is equally likely.
  uint64_t below(uint64_t n) {
    const uint64_t rejected = (0 - n) % n;
    for (;;) {
      const uint64_t high = engine_() & 0xFFFFFFFFu;  // two statements: the order of the draws is fixed
      const uint64_t low = engine_() & 0xFFFFFFFFu;
      const uint64_t x = (high << 32) | low;
      if (x >= rejected) return x % n;
    }
  }

 private:
  std::mt19937 engine_;
};

struct Clusters {
  std::vector<uint64_t> centres;                // kWords per cluster
  std::vector<std::vector<uint32_t>> members;  // indices into the training descriptors
};

const uint64_t* descriptorAt(const std::vector<uint64_t>& data, uint32_t index) {
  return &data[static_cast<size_t>(index) * kWords];
}

// Closest centre, the lowest index on ties (the same rule as Vocabulary::descend,
// so a training descriptor ends in the word that transform gives it).
uint32_t nearestCentre(const uint64_t* descriptor, const std::vector<uint64_t>& centres) {
  const uint32_t count = static_cast<uint32_t>(centres.size() / kWords);
  int best_distance = INT_MAX;
  uint32_t best = 0;
  for (uint32_t c = 0; c < count; ++c) {
    const int distance = place::hamming256(descriptor, &centres[static_cast<size_t>(c) * kWords]);
    if (distance < best_distance) {
      best_distance = distance;
      best = c;
    }
  }
  return best;
}

// k-means++ seeding: the first centre uniformly, each next one with probability
// proportional to its squared distance to the closest centre so far. Stops
// early when every descriptor coincides with a centre.
std::vector<uint64_t> seedCentres(const std::vector<uint64_t>& data, const std::vector<uint32_t>& members, int k,
                                  DeterministicRandom& random) {
  std::vector<uint64_t> centres;
  auto addCentre = [&](uint32_t member) {
    const uint64_t* d = descriptorAt(data, members[member]);
    centres.insert(centres.end(), d, d + kWords);
  };
  addCentre(static_cast<uint32_t>(random.below(members.size())));

  std::vector<uint64_t> squared_distance(members.size());
  for (size_t i = 0; i < members.size(); ++i) {
    const uint64_t d = place::hamming256(descriptorAt(data, members[i]), centres.data());
    squared_distance[i] = d * d;
  }
  while (static_cast<int>(centres.size() / kWords) < k) {
    uint64_t total = 0;
    for (uint64_t d2 : squared_distance) total += d2;  // <= 65536 * 2^32: no overflow
    if (total == 0) break;
    const uint64_t target = random.below(total);
    uint64_t cumulative = 0;
    uint32_t chosen = 0;
    for (size_t i = 0; i < members.size(); ++i) {
      cumulative += squared_distance[i];
      if (target < cumulative) {
        chosen = static_cast<uint32_t>(i);
        break;
      }
    }
    addCentre(chosen);
    const uint64_t* centre = &centres[centres.size() - kWords];
    for (size_t i = 0; i < members.size(); ++i) {
      const uint64_t d = place::hamming256(descriptorAt(data, members[i]), centre);
      squared_distance[i] = std::min(squared_distance[i], d * d);
    }
  }
  return centres;
}

// Each bit of the centre is the majority of that bit over the members (0 on a tie).
void majorityCentre(const std::vector<uint64_t>& data, const std::vector<uint32_t>& members, uint64_t* centre) {
  uint32_t ones[kWords * 64] = {};
  for (uint32_t index : members) {
    const uint64_t* d = descriptorAt(data, index);
    for (int w = 0; w < kWords; ++w) {
      const uint64_t bits = d[w];
      uint32_t* counts = ones + w * 64;
      for (int b = 0; b < 64; ++b) counts[b] += static_cast<uint32_t>((bits >> b) & 1u);
    }
  }
  const uint64_t half = members.size();
  for (int w = 0; w < kWords; ++w) {
    uint64_t bits = 0;
    for (int b = 0; b < 64; ++b)
      if (2ull * ones[w * 64 + b] > half) bits |= (1ull << b);
    centre[w] = bits;
  }
}

// Assigns members to their nearest centre; returns whether any assignment changed.
bool assign(const std::vector<uint64_t>& data, const std::vector<uint32_t>& members,
            const std::vector<uint64_t>& centres, std::vector<uint32_t>& assignment) {
  bool changed = false;
  for (size_t i = 0; i < members.size(); ++i) {
    const uint32_t nearest = nearestCentre(descriptorAt(data, members[i]), centres);
    if (nearest != assignment[i]) {
      assignment[i] = nearest;
      changed = true;
    }
  }
  return changed;
}

// Groups members by assignment, dropping centres that nobody chose. Dropping
// an empty cluster changes no one's nearest centre (ties go to the lower index,
// so no member was tied with it either).
Clusters group(const std::vector<uint32_t>& members, const std::vector<uint64_t>& centres,
               const std::vector<uint32_t>& assignment) {
  const size_t count = centres.size() / kWords;
  std::vector<std::vector<uint32_t>> by_centre(count);
  for (size_t i = 0; i < members.size(); ++i) by_centre[assignment[i]].push_back(members[i]);
  Clusters clusters;
  for (size_t c = 0; c < count; ++c) {
    if (by_centre[c].empty()) continue;
    clusters.centres.insert(clusters.centres.end(), centres.begin() + c * kWords, centres.begin() + (c + 1) * kWords);
    clusters.members.push_back(std::move(by_centre[c]));
  }
  return clusters;
}

// One k-means run. It ends with an assignment step, so every member is in the
// cluster of its nearest final centre.
Clusters kMeans(const std::vector<uint64_t>& data, const std::vector<uint32_t>& members, int k, int max_iterations,
                DeterministicRandom& random) {
  std::vector<uint64_t> centres = seedCentres(data, members, k, random);
  std::vector<uint32_t> assignment(members.size(), UINT32_MAX);
  assign(data, members, centres, assignment);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    // Update: majority centres of the non-empty clusters, renumbered densely.
    Clusters clusters = group(members, centres, assignment);
    std::vector<char> used(centres.size() / kWords, 0);
    for (uint32_t a : assignment) used[a] = 1;
    std::vector<uint32_t> renumbered(used.size(), UINT32_MAX);
    for (size_t i = 0, next = 0; i < used.size(); ++i)
      if (used[i]) renumbered[i] = static_cast<uint32_t>(next++);
    for (uint32_t& a : assignment) a = renumbered[a];
    centres.assign(clusters.centres.size(), 0);
    for (size_t c = 0; c < clusters.members.size(); ++c)
      majorityCentre(data, clusters.members[c], &centres[c * kWords]);
    if (!assign(data, members, centres, assignment)) break;  // converged
  }
  return group(members, centres, assignment);
}

bool allIdentical(const std::vector<uint64_t>& data, const std::vector<uint32_t>& members) {
  const uint64_t* first = descriptorAt(data, members.front());
  for (uint32_t index : members)
    if (std::memcmp(descriptorAt(data, index), first, kWords * sizeof(uint64_t)) != 0) return false;
  return true;
}

// Calls `progress` only when the fraction moved by a visible amount, so that
// callers may print from it.
class ProgressReporter {
 public:
  explicit ProgressReporter(const std::function<void(double)>& callback) : callback_(callback) {}
  void report(double fraction) {
    if (!callback_ || (fraction - last_ < 0.001 && fraction < 1.0)) return;
    last_ = fraction;
    callback_(fraction);
  }

 private:
  const std::function<void(double)>& callback_;
  double last_ = -1.0;
};

constexpr double kTreeShareOfProgress = 0.9;  // the rest is the IDF pass

}  // namespace

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& descriptors_per_image, const VocabularyParams& params,
                             const std::function<void(double)>& progress) {
  if (params.branching < 2 || params.branching > 65535)
    throw std::invalid_argument("Vocabulary::train: branching must be in [2, 65535], got " +
                                std::to_string(params.branching));
  if (params.depth < 1 || params.depth > 32)
    throw std::invalid_argument("Vocabulary::train: depth must be in [1, 32], got " + std::to_string(params.depth));
  if (params.max_kmeans_iterations < 0)
    throw std::invalid_argument("Vocabulary::train: max_kmeans_iterations must be >= 0");

  // All descriptors, contiguous, as 64-bit words.
  std::vector<uint64_t> data;
  for (const cv::Mat& image : descriptors_per_image) {
    if (image.empty()) continue;
    if (image.type() != CV_8UC1 || image.cols != 32)
      throw std::invalid_argument("Vocabulary::train: descriptors must be CV_8U rows of 32 bytes");
    for (int row = 0; row < image.rows; ++row) {
      uint64_t packed[kWords];
      std::memcpy(packed, image.ptr<uint8_t>(row), sizeof(packed));
      data.insert(data.end(), packed, packed + kWords);
    }
  }
  const size_t descriptor_count = data.size() / kWords;
  if (descriptor_count == 0) throw std::invalid_argument("Vocabulary::train: no descriptors to train on");
  if (descriptor_count > UINT32_MAX) throw std::invalid_argument("Vocabulary::train: too many descriptors");

  Vocabulary vocabulary;
  vocabulary.branching_ = params.branching;
  vocabulary.depth_ = params.depth;
  vocabulary.seed_ = params.seed;
  vocabulary.max_kmeans_iterations_ = params.max_kmeans_iterations;

  ProgressReporter reporter(progress);
  reporter.report(0.0);
  DeterministicRandom random(params.seed);

  // Breadth-first: a node's children get consecutive ids when it is split, and
  // nodes are split in id order, which is the numbering Vocabulary expects.
  struct Pending {
    NodeId node;
    int level;
    std::vector<uint32_t> members;
  };
  std::deque<Pending> queue;
  {
    std::vector<uint32_t> everyone(descriptor_count);
    for (size_t i = 0; i < descriptor_count; ++i) everyone[i] = static_cast<uint32_t>(i);
    queue.push_back({0, 0, std::move(everyone)});
  }
  vocabulary.child_count_.push_back(0);
  vocabulary.node_descriptors_.assign(kWords, 0);

  // Work is counted as descriptor-levels: a descriptor costs one per level at
  // which its node is split; a leaf above the bottom pays for the levels it skips.
  const double total_work = static_cast<double>(descriptor_count) * params.depth;
  double work_done = 0.0;

  while (!queue.empty()) {
    Pending pending = std::move(queue.front());
    queue.pop_front();
    if (pending.level >= params.depth || allIdentical(data, pending.members)) {
      work_done += static_cast<double>(pending.members.size()) * (params.depth - pending.level);
      reporter.report(kTreeShareOfProgress * work_done / total_work);
      continue;  // a leaf
    }
    Clusters clusters = kMeans(data, pending.members, params.branching, params.max_kmeans_iterations, random);
    vocabulary.child_count_[pending.node] = static_cast<uint32_t>(clusters.members.size());
    for (size_t c = 0; c < clusters.members.size(); ++c) {
      const NodeId child = static_cast<NodeId>(vocabulary.child_count_.size());
      vocabulary.child_count_.push_back(0);
      vocabulary.node_descriptors_.insert(vocabulary.node_descriptors_.end(),
                                          clusters.centres.begin() + c * kWords,
                                          clusters.centres.begin() + (c + 1) * kWords);
      queue.push_back({child, pending.level + 1, std::move(clusters.members[c])});
    }
    work_done += static_cast<double>(pending.members.size());
    reporter.report(kTreeShareOfProgress * work_done / total_work);
  }
  vocabulary.indexTree();

  // IDF: log(N / n_w) over the N training images, n_w of which contain word w.
  // Images are classified by the same descent as transform, so a weight
  // describes exactly the words that transform produces.
  const size_t image_count = descriptors_per_image.size();
  std::vector<uint32_t> images_with_word(vocabulary.wordCount(), 0);
  std::vector<WordId> words_in_image;
  for (size_t i = 0; i < image_count; ++i) {
    const cv::Mat& image = descriptors_per_image[i];
    words_in_image.clear();
    for (int row = 0; row < image.rows; ++row) words_in_image.push_back(vocabulary.wordOf(image.ptr<uint8_t>(row)));
    std::sort(words_in_image.begin(), words_in_image.end());
    words_in_image.erase(std::unique(words_in_image.begin(), words_in_image.end()), words_in_image.end());
    for (WordId word : words_in_image) ++images_with_word[word];
    reporter.report(kTreeShareOfProgress + (1.0 - kTreeShareOfProgress) * (i + 1) / image_count);
  }
  vocabulary.weights_.resize(vocabulary.wordCount());
  for (size_t w = 0; w < vocabulary.wordCount(); ++w) {
    // Every leaf holds at least one training descriptor, so n_w >= 1; guard anyway.
    const double containing = std::max<uint32_t>(images_with_word[w], 1);
    vocabulary.weights_[w] = std::log(static_cast<double>(image_count) / containing);
  }
  reporter.report(1.0);
  return vocabulary;
}

}  // namespace vslam
