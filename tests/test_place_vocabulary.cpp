#include <fstream>
#include <iterator>
#include <random>

#include <gtest/gtest.h>

#include "place_test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {
namespace {

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string writeText(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = (test::scratchDir(dir) / name).string();
  std::ofstream(path) << text;
  return path;
}

std::string loadError(const std::string& path) {
  try {
    Vocabulary::load(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Tiny vocabulary (k = 5, L = 3) on a few real fr3_teddy frames, trained once.
struct TinyVocabulary {
  std::vector<cv::Mat> training = test::teddyDescriptors({0, 40, 80, 120, 160, 199});
  std::vector<cv::Mat> held_out = test::teddyDescriptors({20, 100});
  VocabularyParams params{5, 3, 7, 10};
  Vocabulary vocabulary = Vocabulary::train(training, params);
};

const TinyVocabulary& tiny() {
  static const TinyVocabulary instance;
  return instance;
}

void expectSameWords(const Vocabulary& a, const Vocabulary& b, const std::vector<cv::Mat>& images) {
  for (const cv::Mat& image : images) {
    for (int row = 0; row < image.rows; ++row)
      ASSERT_EQ(a.wordOf(image.ptr<uint8_t>(row)), b.wordOf(image.ptr<uint8_t>(row))) << "row " << row;
    BowVector bow_a, bow_b;
    FeatureVector features_a, features_b;
    a.transform(image, bow_a, features_a, 1);
    b.transform(image, bow_b, features_b, 1);
    EXPECT_EQ(bow_a, bow_b);  // exact: same words, bit-identical values
    EXPECT_EQ(features_a, features_b);
  }
}

TEST(PlaceVocabulary, TrainsATreeOfTheRequestedShape) {
  const Vocabulary& vocabulary = tiny().vocabulary;
  EXPECT_EQ(vocabulary.branching(), 5);
  EXPECT_EQ(vocabulary.depth(), 3);
  EXPECT_EQ(vocabulary.params().seed, 7u);
  // ~6000 descriptors fill most of the 125 possible leaves.
  EXPECT_GT(vocabulary.wordCount(), 100u);
  EXPECT_LE(vocabulary.wordCount(), 125u);
  double max_weight = 0.0;
  for (WordId w = 0; w < vocabulary.wordCount(); ++w) {
    EXPECT_GE(vocabulary.wordWeight(w), 0.0);
    max_weight = std::max(max_weight, vocabulary.wordWeight(w));
  }
  EXPECT_LE(max_weight, std::log(6.0) + 1e-12);  // idf = log(N / n), N = 6 images
  EXPECT_GT(max_weight, 0.0);

  // Bags are L1-normalised and the direct index holds every feature once.
  const cv::Mat& image = tiny().held_out[0];
  BowVector bow;
  FeatureVector features;
  vocabulary.transform(image, bow, features, 1);
  double total = 0.0;
  for (const auto& [word, value] : bow) {
    EXPECT_LT(word, vocabulary.wordCount());
    EXPECT_GT(value, 0.0);
    total += value;
  }
  EXPECT_NEAR(total, 1.0, 1e-12);
  size_t indexed = 0;
  for (const auto& [node, rows] : features) indexed += rows.size();
  EXPECT_EQ(indexed, static_cast<size_t>(image.rows));
  EXPECT_LE(features.size(), 25u);  // one level up from the leaves of a k = 5, L = 3 tree
}

TEST(PlaceVocabulary, SaveLoadRoundTripIsExact) {
  const Vocabulary& trained = tiny().vocabulary;
  const auto dir = test::scratchDir("place_round_trip");
  const std::string first = (dir / "tiny.vsv").string();
  const std::string second = (dir / "tiny_again.vsv").string();
  trained.save(first);
  const Vocabulary loaded = Vocabulary::load(first);
  EXPECT_EQ(loaded.wordCount(), trained.wordCount());
  EXPECT_EQ(loaded.nodeCount(), trained.nodeCount());
  EXPECT_EQ(loaded.params().seed, trained.params().seed);
  EXPECT_EQ(loaded.params().max_kmeans_iterations, trained.params().max_kmeans_iterations);
  for (WordId w = 0; w < trained.wordCount(); ++w) EXPECT_EQ(loaded.wordWeight(w), trained.wordWeight(w));
  expectSameWords(trained, loaded, tiny().training);
  expectSameWords(trained, loaded, tiny().held_out);

  const BowVector a = trained.transform(tiny().held_out[0]);
  const BowVector b = trained.transform(tiny().held_out[1]);
  EXPECT_EQ(loaded.score(loaded.transform(tiny().held_out[0]), loaded.transform(tiny().held_out[1])),
            trained.score(a, b));

  loaded.save(second);
  const std::string bytes = readBytes(first);
  EXPECT_EQ(bytes, readBytes(second));
  // 36-byte header, 2 bytes per node, 32 per non-root node, 8 per word.
  EXPECT_EQ(bytes.size(), 36 + 2 * trained.nodeCount() + 32 * (trained.nodeCount() - 1) + 8 * trained.wordCount());
}

TEST(PlaceVocabulary, SameInputGivesTheSameFile) {
  const auto dir = test::scratchDir("place_reproducible");
  const std::string first = (dir / "a.vsv").string();
  const std::string second = (dir / "b.vsv").string();
  const std::string other_seed = (dir / "c.vsv").string();
  tiny().vocabulary.save(first);
  Vocabulary::train(tiny().training, tiny().params).save(second);
  VocabularyParams different = tiny().params;
  different.seed = 8;
  Vocabulary::train(tiny().training, different).save(other_seed);
  EXPECT_EQ(readBytes(first), readBytes(second));
  EXPECT_NE(readBytes(first), readBytes(other_seed));  // the seed does steer the clustering
}

TEST(PlaceVocabulary, ProgressRisesToOne) {
  std::vector<double> reported;
  Vocabulary::train({tiny().training[0], tiny().training[1]}, VocabularyParams{4, 2, 1, 3},
                    [&](double fraction) { reported.push_back(fraction); });
  ASSERT_FALSE(reported.empty());
  EXPECT_TRUE(std::is_sorted(reported.begin(), reported.end()));
  EXPECT_GE(reported.front(), 0.0);
  EXPECT_DOUBLE_EQ(reported.back(), 1.0);
}

TEST(PlaceVocabulary, ScoreIsOneForItselfZeroForDisjointAndSymmetric) {
  const Vocabulary& vocabulary = tiny().vocabulary;
  const BowVector a = vocabulary.transform(tiny().held_out[0]);
  const BowVector b = vocabulary.transform(tiny().held_out[1]);
  EXPECT_NEAR(vocabulary.score(a, a), 1.0, 1e-12);
  EXPECT_EQ(vocabulary.score(a, b), vocabulary.score(b, a));
  EXPECT_GT(vocabulary.score(a, b), 0.0);
  EXPECT_LT(vocabulary.score(a, b), 1.0);

  const BowVector left{{1, 0.25}, {2, 0.75}};
  const BowVector right{{3, 0.5}, {4, 0.5}};
  EXPECT_EQ(l1Score(left, right), 0.0);
  const BowVector overlapping{{2, 0.5}, {3, 0.5}};
  EXPECT_DOUBLE_EQ(l1Score(left, overlapping), 0.5);  // 1 - 0.5 * (0.25 + 0.25 + 0.5)
  EXPECT_EQ(l1Score(BowVector{}, left), 0.0);
}

TEST(PlaceVocabulary, TrainRejectsBadInput) {
  EXPECT_THROW(Vocabulary::train({}, VocabularyParams{}), std::invalid_argument);
  EXPECT_THROW(Vocabulary::train(tiny().training, VocabularyParams{1, 3, 0, 1}), std::invalid_argument);
  EXPECT_THROW(Vocabulary::train(tiny().training, VocabularyParams{4, 0, 0, 1}), std::invalid_argument);
  EXPECT_THROW(Vocabulary::train({cv::Mat(3, 16, CV_8U, cv::Scalar(1))}, VocabularyParams{}), std::invalid_argument);
  BowVector bow;
  FeatureVector features;
  EXPECT_THROW(tiny().vocabulary.transform(cv::Mat(3, 32, CV_32F, cv::Scalar(1)), bow, features),
               std::invalid_argument);
  // An empty vocabulary gives empty bags rather than crashing.
  EXPECT_TRUE(Vocabulary().transform(tiny().held_out[0]).empty());
}

// ---------------------------------------------------------------- DBoW2 text

std::string descriptorText(uint8_t first_byte, uint8_t other_bytes) {
  std::string text = std::to_string(first_byte);
  for (int i = 1; i < 32; ++i) text += " " + std::to_string(other_bytes);
  return text;
}

// k = 2, L = 2. File order: node 1 = A (inner, all bits 0), node 2 = C (leaf
// under A, first byte 0x0F), node 3 = D (leaf under A, first byte 0xF0, the
// rest 0x01), node 4 = B (leaf under the root, all bits 1). Breadth-first the
// leaves are B, C, D: words 0, 1, 2.
std::string handWrittenDbow2() {
  return "2 2 0 0\n"
         "0 0 " + descriptorText(0, 0) + " 0\n"
         "1 1 " + descriptorText(0x0F, 0) + " 1.5\n"
         "1 1 " + descriptorText(0xF0, 1) + " 2.25\n"
         "0 1 " + descriptorText(0xFF, 0xFF) + " 0.5\n";
}

TEST(PlaceVocabulary, LoadsHandWrittenDbow2Text) {
  const std::string path = writeText("place_dbow2", "small_voc.txt", handWrittenDbow2());
  const Vocabulary vocabulary = Vocabulary::load(path);
  EXPECT_EQ(vocabulary.branching(), 2);
  EXPECT_EQ(vocabulary.depth(), 2);
  ASSERT_EQ(vocabulary.wordCount(), 3u);
  EXPECT_EQ(vocabulary.nodeCount(), 5u);
  EXPECT_EQ(vocabulary.wordWeight(0), 0.5);
  EXPECT_EQ(vocabulary.wordWeight(1), 1.5);
  EXPECT_EQ(vocabulary.wordWeight(2), 2.25);

  auto descriptor = [](uint8_t first, uint8_t rest) {
    std::vector<uint8_t> d(32, rest);
    d[0] = first;
    return d;
  };
  EXPECT_EQ(vocabulary.wordOf(descriptor(0xFF, 0xFF).data()), 0u);  // B itself
  EXPECT_EQ(vocabulary.wordOf(descriptor(0xFF, 0xFE).data()), 0u);  // one bit from B per byte
  EXPECT_EQ(vocabulary.wordOf(descriptor(0x0F, 0x00).data()), 1u);  // C itself
  EXPECT_EQ(vocabulary.wordOf(descriptor(0x07, 0x00).data()), 1u);  // closer to A than B, then to C than D
  EXPECT_EQ(vocabulary.wordOf(descriptor(0xF0, 0x01).data()), 2u);  // D itself
  EXPECT_EQ(vocabulary.wordOf(descriptor(0xE0, 0x01).data()), 2u);

  // TF-IDF: two features in C (idf 1.5), one in D (idf 2.25): 3 : 2.25.
  cv::Mat rows(3, 32, CV_8U, cv::Scalar(0));
  rows.at<uint8_t>(0, 0) = 0x0F;
  rows.at<uint8_t>(1, 0) = 0x07;
  rows.row(2).setTo(1);
  rows.at<uint8_t>(2, 0) = 0xF0;
  BowVector bow;
  FeatureVector features;
  vocabulary.transform(rows, bow, features, 1);
  ASSERT_EQ(bow.size(), 2u);
  EXPECT_DOUBLE_EQ(bow.at(1), 3.0 / 5.25);
  EXPECT_DOUBLE_EQ(bow.at(2), 2.25 / 5.25);
  // One level up from the leaves is A (node 1) for all three features.
  ASSERT_EQ(features.size(), 1u);
  EXPECT_EQ(features.begin()->first, 1u);
  EXPECT_EQ(features.begin()->second, (std::vector<int>{0, 1, 2}));
}

TEST(PlaceVocabulary, Dbow2TextRoundTripKeepsWordsAndWeights) {
  const auto dir = test::scratchDir("place_dbow2_round_trip");
  const std::string path = (dir / "tiny_voc.txt").string();
  tiny().vocabulary.saveDbow2Text(path);
  const Vocabulary loaded = Vocabulary::load(path);
  ASSERT_EQ(loaded.wordCount(), tiny().vocabulary.wordCount());
  for (WordId w = 0; w < loaded.wordCount(); ++w) EXPECT_EQ(loaded.wordWeight(w), tiny().vocabulary.wordWeight(w));
  expectSameWords(tiny().vocabulary, loaded, tiny().held_out);
}

TEST(PlaceVocabulary, MalformedDbow2TextNamesFileAndLine) {
  // Line 5 (the fourth node) lacks its weight: 34 numbers instead of 35.
  std::string text = handWrittenDbow2();
  size_t line5 = 0;
  for (int line = 1; line < 5; ++line) line5 = text.find('\n', line5) + 1;
  text = text.substr(0, line5) + "0 1 " + descriptorText(0xFF, 0xFF) + "\n";
  const std::string path = writeText("place_dbow2_bad", "bad_voc.txt", text);
  const std::string message = loadError(path);
  EXPECT_EQ(message.rfind(path + ":5: ", 0), 0u) << message;
  EXPECT_NE(message.find("found 34"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

TEST(PlaceVocabulary, OtherMalformedFilesGiveOneLineErrors) {
  const std::string good = handWrittenDbow2();
  struct Case {
    std::string text;
    std::string where;
    std::string what;
  };
  const std::vector<Case> cases = {
      {"", ":1: ", "empty file"},
      {"hello world\n", ":1: ", "not a vocabulary"},
      {"2 2 1 0\n" + good.substr(good.find('\n') + 1), ":1: ", "scoring 1"},
      {"2 2 0 0\n0 0 " + descriptorText(0, 0) + " 0\n", ":2: ", "no line names it as parent"},
      {"2 2 0 0\n3 1 " + descriptorText(0, 0) + " 0\n", ":2: ", "not the id of an earlier node"},
      {"2 2 0 0\n0 1 " + descriptorText(0, 0) + " 0\n1 1 " + descriptorText(0, 0) + " 0\n", ":3: ", "is a leaf"},
      {"2 2 0 0\n0 1 " + descriptorText(0, 0) + " 0\n0 1 " + descriptorText(0, 0) + " 0\n0 1 " +
           descriptorText(0, 0) + " 0\n",
       ":4: ", "more than k = 2"},
      {"2 2 0 0\n0 1 256" + descriptorText(0, 0).substr(1) + " 0\n", ":2: ", "descriptor byte 0"},
      {"2 2 0 0\n0 1 " + descriptorText(0, 0) + " nan\n", ":2: ", "weight"},
      {"2 1 0 0\n0 0 " + descriptorText(0, 0) + " 0\n1 1 " + descriptorText(0, 0) + " 0\n", ":3: ", "deeper than L = 1"},
      {"2 2 0 0\n", ":2: ", "no node lines"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = writeText("place_bad_" + std::to_string(i), "voc.txt", cases[i].text);
    const std::string message = loadError(path);
    EXPECT_EQ(message.rfind(path + cases[i].where, 0), 0u) << "case " << i << ": " << message;
    EXPECT_NE(message.find(cases[i].what), std::string::npos) << "case " << i << ": " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST(PlaceVocabulary, DamagedBinaryFilesGiveErrorsNotCrashes) {
  const auto dir = test::scratchDir("place_bad_binary");
  const std::string good_path = (dir / "good.vsv").string();
  tiny().vocabulary.save(good_path);
  const std::string good = readBytes(good_path);

  const std::string truncated = writeText("place_bad_binary_t", "truncated.vsv", good.substr(0, good.size() - 5));
  EXPECT_NE(loadError(truncated).find("truncated"), std::string::npos) << loadError(truncated);
  EXPECT_EQ(loadError(truncated).rfind(truncated + ": byte ", 0), 0u) << loadError(truncated);

  std::string bad_version = good;
  bad_version[8] = 9;
  const std::string version_path = writeText("place_bad_binary_v", "version.vsv", bad_version);
  EXPECT_NE(loadError(version_path).find("version 9"), std::string::npos) << loadError(version_path);

  std::string bad_tree = good;
  bad_tree[36] = static_cast<char>(0xFF);  // the root claims 255 children
  const std::string tree_path = writeText("place_bad_binary_c", "tree.vsv", bad_tree);
  EXPECT_NE(loadError(tree_path).find("children"), std::string::npos) << loadError(tree_path);

  // Random bytes after the magic must never crash the loader.
  std::mt19937 noise(3);
  for (int trial = 0; trial < 50; ++trial) {
    std::string damaged = good;
    for (int flips = 0; flips < 4; ++flips) damaged[8 + noise() % 200] = static_cast<char>(noise());
    const std::string path = writeText("place_bad_binary_r", "random.vsv", damaged);
    try {
      const Vocabulary v = Vocabulary::load(path);
      v.transform(tiny().held_out[0]);
    } catch (const InputError&) {
    }
  }
  EXPECT_NE(loadError("/nonexistent/voc.vsv").find("/nonexistent/voc.vsv: cannot open"), std::string::npos);
}

}  // namespace
}  // namespace vslam
