#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "place_test_support.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {
namespace {

// A small vocabulary (k = 8, L = 3) trained on fr3_teddy frames that are
// neither keyframes nor queries below, and the bags of the frames we use.
struct Scene {
  Vocabulary vocabulary =
      Vocabulary::train(test::teddyDescriptors({10, 30, 70, 90, 120, 140, 170, 190}), VocabularyParams{8, 3, 42, 10});
  std::map<int, BowVector> bow_of_frame = [this] {
    const std::vector<int> frames = {0, 50, 100, 150, 52, 148};
    const std::vector<cv::Mat> descriptors = test::teddyDescriptors(frames);
    std::map<int, BowVector> bows;
    for (size_t i = 0; i < frames.size(); ++i) bows[frames[i]] = vocabulary.transform(descriptors[i]);
    return bows;
  }();

  // Keyframes 0, 50, 100, 150 (the database holds a mutex, so it is filled in place).
  void addKeyframes(KeyframeDatabase& database) const {
    for (int frame : {0, 50, 100, 150}) database.add(frame, bow_of_frame.at(frame));
  }
};

const Scene& scene() {
  static const Scene instance;
  return instance;
}

TEST(PlaceKeyframeDatabase, NearbyFrameRanksItsKeyframeFirst) {
  KeyframeDatabase database;
  scene().addKeyframes(database);
  EXPECT_EQ(database.size(), 4u);

  const auto from52 = database.query(scene().bow_of_frame.at(52), 0.0, {}, 0);
  ASSERT_EQ(from52.size(), 4u);
  for (const auto& [keyframe, score] : from52) std::cout << "frame 52 vs keyframe " << keyframe << ": " << score << "\n";
  EXPECT_EQ(from52[0].first, 50);
  for (size_t i = 1; i < from52.size(); ++i) EXPECT_GE(from52[i - 1].second, from52[i].second);
  EXPECT_GT(from52[0].second, from52[1].second);

  const auto from148 = database.query(scene().bow_of_frame.at(148), 0.0, {}, 1);
  ASSERT_EQ(from148.size(), 1u);
  EXPECT_EQ(from148[0].first, 150);
}

TEST(PlaceKeyframeDatabase, ScoresAreTheVocabularyScore) {
  KeyframeDatabase database;
  scene().addKeyframes(database);
  const BowVector& query = scene().bow_of_frame.at(52);
  for (const auto& [keyframe, score] : database.query(query, 0.0, {}, 0))
    EXPECT_DOUBLE_EQ(score, scene().vocabulary.score(query, scene().bow_of_frame.at(static_cast<int>(keyframe))))
        << "keyframe " << keyframe;
  // A keyframe's own bag finds itself with score 1.
  const auto self = database.query(scene().bow_of_frame.at(100), 0.0, {}, 1);
  ASSERT_EQ(self.size(), 1u);
  EXPECT_EQ(self[0].first, 100);
  EXPECT_NEAR(self[0].second, 1.0, 1e-12);
}

TEST(PlaceKeyframeDatabase, ExcludeMinScoreAndMaxResults) {
  KeyframeDatabase database;
  scene().addKeyframes(database);
  const BowVector& query = scene().bow_of_frame.at(52);
  const auto all = database.query(query, 0.0, {}, 0);

  const auto without50 = database.query(query, 0.0, {50}, 0);
  ASSERT_EQ(without50.size(), 3u);
  for (const auto& [keyframe, score] : without50) EXPECT_NE(keyframe, 50);
  EXPECT_EQ(without50[0], all[1]);

  const double threshold = (all[0].second + all[1].second) / 2;
  const auto strong = database.query(query, threshold, {}, 0);
  ASSERT_EQ(strong.size(), 1u);
  EXPECT_EQ(strong[0].first, 50);

  EXPECT_EQ(database.query(query, 0.0, {}, 2).size(), 2u);
  EXPECT_TRUE(database.query(query, 1.01, {}, 0).empty());
  EXPECT_TRUE(database.query(BowVector{}, 0.0, {}, 0).empty());
}

TEST(PlaceKeyframeDatabase, EraseAndReplace) {
  KeyframeDatabase database;
  scene().addKeyframes(database);
  const BowVector& query = scene().bow_of_frame.at(52);
  database.erase(50);
  database.erase(12345);  // unknown: ignored
  EXPECT_EQ(database.size(), 3u);
  EXPECT_FALSE(database.contains(50));
  for (const auto& [keyframe, score] : database.query(query, 0.0, {}, 0)) EXPECT_NE(keyframe, 50);
  EXPECT_EQ(database.sharedWordCounts(query, {}).count(50), 0u);

  // Adding an id again replaces its bag: keyframe 0 now looks like frame 50.
  database.add(0, scene().bow_of_frame.at(50));
  EXPECT_EQ(database.size(), 3u);
  const auto top = database.query(query, 0.0, {}, 1);
  ASSERT_EQ(top.size(), 1u);
  EXPECT_EQ(top[0].first, 0);

  database.clear();
  EXPECT_EQ(database.size(), 0u);
  EXPECT_TRUE(database.query(query, 0.0, {}, 0).empty());
}

TEST(PlaceKeyframeDatabase, SharedWordCounts) {
  KeyframeDatabase database;
  scene().addKeyframes(database);
  const BowVector& query = scene().bow_of_frame.at(52);
  const auto counts = database.sharedWordCounts(query, {100});
  EXPECT_EQ(counts.count(100), 0u);
  for (int keyframe : {0, 50, 150}) {
    const BowVector& bow = scene().bow_of_frame.at(keyframe);
    int expected = 0;
    for (const auto& [word, value] : query) expected += static_cast<int>(bow.count(word));
    ASSERT_EQ(counts.count(keyframe), 1u);
    EXPECT_EQ(counts.at(keyframe), expected);
  }
}

TEST(PlaceKeyframeDatabase, ConcurrentAddEraseAndQuery) {
  // Local Mapping adds and erases while Tracking and Loop Closing query.
  KeyframeDatabase database;
  scene().addKeyframes(database);
  const BowVector& query = scene().bow_of_frame.at(52);
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 0; i < 300; ++i) {
      database.add(1000 + i, scene().bow_of_frame.at(i % 2 ? 100 : 148));
      if (i >= 10) database.erase(1000 + i - 10);
    }
    done = true;
  });
  std::vector<std::thread> readers;
  std::atomic<int> wrong_first{0};
  for (int r = 0; r < 2; ++r)
    readers.emplace_back([&] {
      while (!done)
        if (database.query(query, 0.0, {}, 1).at(0).first != 50) ++wrong_first;
    });
  writer.join();
  for (auto& reader : readers) reader.join();
  EXPECT_EQ(wrong_first, 0);
  EXPECT_EQ(database.size(), 14u);
}

}  // namespace
}  // namespace vslam
