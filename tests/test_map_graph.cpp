// The map database's bookkeeping on hand-built keyframes and points:
// covisibility weights, spanning tree, culling, duplicate fusion, class votes.
#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "synthetic_views.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/slam/local_mapping.hpp"
#include "vslam/slam/place_candidates.hpp"

namespace vslam {
namespace {

class MapGraphTest : public ::testing::Test {
 protected:
  // A frame with `n` keypoints whose descriptors are all-zero except byte 0 = i.
  Frame makeFrame(long id, int n, double x_offset = 0) {
    Frame frame;
    frame.id = id;
    frame.index = static_cast<int>(id);
    frame.timestamp = static_cast<double>(id);
    frame.camera = &camera_;
    frame.pyramid = &pyramid_;
    frame.descriptors = cv::Mat::zeros(n, 32, CV_8U);
    for (int i = 0; i < n; ++i) {
      cv::KeyPoint kp(cv::Point2f(10.f + 5.f * (i % 100), 10.f + 5.f * (i / 100)), 31.f, 0.f, 1.f, 0);
      frame.keypoints.push_back(kp);
      frame.points.emplace_back(kp.pt.x, kp.pt.y);
      frame.colours.emplace_back(static_cast<uchar>(i), 0, 0);
      frame.descriptors.at<uint8_t>(i, 0) = static_cast<uint8_t>(i);
    }
    frame.T_cw.t = Vec3(x_offset, 0, 0);
    frame.finalizeFeatures(cv::Rect2f(0, 0, 640, 480));
    return frame;
  }

  // Point observed by keypoint `index` in each given keyframe.
  MapPoint* observe(const std::vector<KeyFrame*>& keyframes, int index) {
    MapPoint* point = map_.createMapPoint(Vec3(0, 0, 5), keyframes.front());
    for (KeyFrame* kf : keyframes) {
      point->addObservation(kf, index);
      kf->setMapPoint(index, point);
    }
    return point;
  }

  PinholeCamera camera_ = test::vgaCamera();
  ScalePyramid pyramid_ = makeScalePyramid(8, 1.2);
  Map map_;
};

TEST_F(MapGraphTest, CovisibilityWeightsAndParent) {
  // Keyframes join one after the other, as in a run.
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 100));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 100));
  std::vector<MapPoint*> shared_by_all;
  for (int i = 0; i < 40; ++i) shared_by_all.push_back(observe({a, b}, i));
  for (int i = 40; i < 60; ++i) observe({a, b}, i);  // 20 more shared by a and b only
  a->updateConnections();
  b->updateConnections();
  KeyFrame* c = map_.createKeyFrame(makeFrame(2, 100));
  for (int i = 0; i < 40; ++i) {
    shared_by_all[i]->addObservation(c, i);
    c->setMapPoint(i, shared_by_all[i]);
  }
  for (int i = 60; i < 70; ++i) observe({b, c}, i);  // 10 more by b and c
  c->updateConnections();
  EXPECT_EQ(a->weight(b), 60);
  EXPECT_EQ(b->weight(a), 60);
  EXPECT_EQ(a->weight(c), 40);
  EXPECT_EQ(c->weight(b), 50);
  EXPECT_EQ(b->weight(c), 50);
  ASSERT_EQ(b->orderedCovisibles().size(), 2u);
  EXPECT_EQ(b->orderedCovisibles()[0], a);
  EXPECT_EQ(b->parent(), a);  // strongest link at its first connection
  EXPECT_EQ(c->parent(), b);
  EXPECT_EQ(a->parent(), nullptr);
  EXPECT_EQ(a->trackedMapPoints(3), 40);
  EXPECT_EQ(b->trackedMapPoints(2), 70);
}

TEST_F(MapGraphTest, CullingAKeyFrameReparentsItsChildren) {
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 100, 0.0));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 100, 0.1));
  std::vector<MapPoint*> shared_by_all;
  for (int i = 0; i < 30; ++i) shared_by_all.push_back(observe({a, b}, i));
  a->updateConnections();
  b->updateConnections();
  KeyFrame* c = map_.createKeyFrame(makeFrame(2, 100, 0.2));
  for (int i = 0; i < 30; ++i) {
    shared_by_all[i]->addObservation(c, i);
    c->setMapPoint(i, shared_by_all[i]);
  }
  for (int i = 30; i < 50; ++i) observe({b, c}, i);
  c->updateConnections();
  ASSERT_EQ(c->parent(), b);
  b->setBad();
  EXPECT_TRUE(b->isBad());
  EXPECT_EQ(c->parent(), a);
  EXPECT_EQ(a->children().count(c), 1u);
  EXPECT_EQ(a->weight(b), 0);
  // b's pose relative to its parent is kept for the trajectory: T_b_a = T_bw * T_aw^-1.
  EXPECT_NEAR(b->poseRelativeToParent().t.x(), 0.1, 1e-12);
  // Points seen by b and c only lost one observation and became single-view: bad.
  EXPECT_EQ(map_.mapPointCount(), 30u);
  EXPECT_EQ(map_.keyframeCount(), 2u);
}

TEST_F(MapGraphTest, ReplaceMovesObservationsAndKeepsOneSlot) {
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 10));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 10));
  KeyFrame* c = map_.createKeyFrame(makeFrame(2, 10));
  MapPoint* kept = observe({a, b}, 3);
  MapPoint* duplicate = map_.createMapPoint(Vec3(0, 0, 5), b);
  duplicate->addObservation(b, 4);  // b sees both: that slot is dropped, not duplicated
  b->setMapPoint(4, duplicate);
  duplicate->addObservation(c, 5);
  c->setMapPoint(5, duplicate);
  duplicate->replaceWith(kept);
  EXPECT_TRUE(duplicate->isBad());
  EXPECT_EQ(duplicate->replacement(), kept);
  EXPECT_EQ(kept->observationCount(), 3);
  EXPECT_EQ(c->mapPoint(5), kept);
  EXPECT_EQ(b->mapPoint(4), nullptr);
  EXPECT_EQ(b->mapPoint(3), kept);
}

TEST_F(MapGraphTest, DescriptorIsTheMedoid) {
  // Byte 0 of keypoint i's descriptor is i. Observed descriptors 7, 25, 1, 97,
  // 129: the one with byte 1 is 2 bits from 7, 25 and 97 and 1 from 129, so its
  // median distance to the others (2) is the only smallest one.
  const std::vector<int> keypoints = {7, 25, 1, 97, 129};
  MapPoint* point = nullptr;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    KeyFrame* kf = map_.createKeyFrame(makeFrame(static_cast<long>(k), 130));
    if (!point) point = map_.createMapPoint(Vec3(0, 0, 5), kf);
    point->addObservation(kf, keypoints[k]);
  }
  point->updateDescriptor();
  EXPECT_EQ(point->descriptor().at<uint8_t>(0, 0), 1);
}

TEST_F(MapGraphTest, ClassTakesTheMajorityOfObservations) {
  std::vector<KeyFrame*> kfs;
  for (int k = 0; k < 5; ++k) kfs.push_back(map_.createKeyFrame(makeFrame(k, 10)));
  MapPoint* point = observe(kfs, 2);
  kfs[0]->labels[2].class_id = 56;  // chair
  kfs[1]->labels[2].class_id = 56;
  kfs[2]->labels[2].class_id = 62;
  point->updateClass();
  EXPECT_EQ(point->classId(), -1);  // 2 of 5 is no majority
  kfs[3]->labels[2].class_id = 56;
  point->updateClass();
  EXPECT_EQ(point->classId(), 56);
  EXPECT_DOUBLE_EQ(point->classConfidence(), 0.6);
}

TEST_F(MapGraphTest, ScaleRangePredictsLevel) {
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 10));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 10, 1.0));
  MapPoint* point = observe({a, b}, 0);  // seen at level 0 from 5 m by a (reference)
  point->updateNormalAndDepth(pyramid_);
  EXPECT_NEAR(point->maxDistance(), 1.2 * 5.0, 1e-9);
  EXPECT_NEAR(point->minDistance(), 0.8 * 5.0 / std::pow(1.2, 7), 1e-9);
  EXPECT_EQ(point->predictLevel(5.0, pyramid_), 0);
  EXPECT_EQ(point->predictLevel(5.0 / 1.1, pyramid_), 1);
  EXPECT_EQ(point->predictLevel(5.0 / (1.2 * 1.2 * 1.01), pyramid_), 3);
}

}  // namespace
}  // namespace vslam

namespace vslam {
namespace {

// A rejected initialisation clears the map; the next map's first keyframe must
// again be keyframe 0, the spanning tree's root (a parent cycle hung the
// full bundle adjustment once).
TEST_F(MapGraphTest, ClearedMapRestartsAtKeyFrameZeroWithoutParentCycle) {
  map_.createKeyFrame(makeFrame(0, 10));
  map_.createKeyFrame(makeFrame(1, 10));
  map_.clear();
  KeyFrame* a = map_.createKeyFrame(makeFrame(2, 100));
  KeyFrame* b = map_.createKeyFrame(makeFrame(3, 100));
  EXPECT_EQ(a->id(), 0);
  for (int i = 0; i < 30; ++i) observe({a, b}, i);
  a->updateConnections();
  b->updateConnections();
  EXPECT_EQ(a->parent(), nullptr);
  EXPECT_EQ(b->parent(), a);
}

// Regression: culling iterated the keyframe's own covisibility list while
// setBad() rebuilt it, so after each cull the next neighbour was skipped (and
// the loop read past the list's end). Ten keyframes see the same 100 points;
// culling goes on while a point keeps more than three observers, so exactly
// seven of the eight erasable neighbours must go, not every other one.
TEST_F(MapGraphTest, CullingSeveralRedundantNeighboursExaminesEveryOne) {
  std::vector<KeyFrame*> keyframes;
  for (int k = 0; k < 10; ++k) keyframes.push_back(map_.createKeyFrame(makeFrame(k, 100, 0.1 * k)));
  for (int i = 0; i < 100; ++i) observe(keyframes, i);
  for (KeyFrame* kf : keyframes) kf->updateConnections();
  KeyFrame* current = keyframes.back();
  ASSERT_EQ(current->orderedCovisibles().size(), 9u);  // keyframe 0 among them, never culled

  const std::vector<KeyFrame*> culled = cullRedundantKeyFrames(current, 0.9);
  // Each cull removes one observation per point: 10 -> 3 observers after
  // seven, and a point seen three times makes no keyframe redundant.
  ASSERT_EQ(culled.size(), 7u);
  for (size_t k = 0; k < culled.size(); ++k) EXPECT_EQ(culled[k]->id(), static_cast<long>(k + 1));
  EXPECT_EQ(map_.keyframeCount(), 3u);
  EXPECT_EQ(current->orderedCovisibles().size(), 2u);
  // Every live keyframe still reaches the root through its parents.
  for (KeyFrame* kf : map_.keyframes()) {
    const KeyFrame* k = kf;
    int steps = 0;
    while (k->parent() && steps++ < 20) k = k->parent();
    EXPECT_EQ(k->id(), 0) << "keyframe " << kf->id();
  }
}

// Issue 18: on the road a keyframe shares its points with only the last few,
// so the keyframes before it (along the spanning tree) make up the number of
// triangulation neighbours. Here each keyframe shares 20 points with the one
// before it only, as on a drive.
TEST_F(MapGraphTest, TriangulationNeighboursAddTheKeyFramesBeforeWhereCovisiblesAreFew) {
  std::vector<KeyFrame*> keyframes;
  for (int k = 0; k < 8; ++k) {
    keyframes.push_back(map_.createKeyFrame(makeFrame(k, 200, 0.1 * k)));
    if (k > 0)
      for (int i = 20 * (k - 1); i < 20 * k; ++i) observe({keyframes[k - 1], keyframes[k]}, i);
    keyframes.back()->updateConnections();
  }
  KeyFrame* current = keyframes.back();
  ASSERT_EQ(current->parent(), keyframes[6]);
  auto ids = [](const std::vector<KeyFrame*>& list) {
    std::vector<long> out;
    for (const KeyFrame* kf : list) out.push_back(kf->id());
    return out;
  };
  // 0: the covisible keyframes only (the TUM default), as before the setting.
  EXPECT_EQ(ids(triangulationNeighbours(current, 20, 0)), (std::vector<long>{6}));
  // The parent is covisible already: it is not listed twice.
  EXPECT_EQ(ids(triangulationNeighbours(current, 20, 3)), (std::vector<long>{6, 5, 4}));
  EXPECT_EQ(ids(triangulationNeighbours(current, 20, 4)), (std::vector<long>{6, 5, 4, 3}));
  // More than the chain holds: it ends at the root.
  EXPECT_EQ(ids(triangulationNeighbours(current, 20, 80)), (std::vector<long>{6, 5, 4, 3, 2, 1, 0}));
  // Enough covisible keyframes: none is added.
  EXPECT_EQ(ids(triangulationNeighbours(keyframes[3], 20, 2)), (std::vector<long>{2, 4}));
}

// Regression: a keyframe got a parent only at its first link with shared
// points; one linked before it shared any stayed outside the spanning tree.
TEST_F(MapGraphTest, KeyFrameWithoutSharedPointsTakesItsFallbackParent) {
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 100));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 100));
  for (int i = 0; i < 30; ++i) observe({a, b}, i);
  a->updateConnections();
  b->updateConnections();
  KeyFrame* c = map_.createKeyFrame(makeFrame(2, 100));
  c->setFallbackParent(b);
  c->updateConnections();  // no shared point yet
  EXPECT_EQ(c->parent(), b);
  EXPECT_EQ(b->children().count(c), 1u);
  // A real link replaces the fallback.
  for (int i = 30; i < 60; ++i) observe({a, c}, i);
  c->updateConnections();
  EXPECT_EQ(c->parent(), a);
  EXPECT_EQ(b->children().count(c), 0u);
}

// Regression: culling a keyframe without a parent handed its children to a
// null parent, cutting them off the tree. Such a keyframe is kept.
TEST_F(MapGraphTest, KeyFrameWithoutParentIsNotCulled) {
  KeyFrame* root = map_.createKeyFrame(makeFrame(0, 100));
  KeyFrame* orphan = map_.createKeyFrame(makeFrame(1, 100));  // never linked: no parent
  KeyFrame* child = map_.createKeyFrame(makeFrame(2, 100));
  for (int i = 0; i < 30; ++i) observe({orphan, child}, i);
  child->updateConnections();
  ASSERT_EQ(child->parent(), orphan);
  ASSERT_EQ(orphan->parent(), nullptr);
  orphan->setBad();
  EXPECT_FALSE(orphan->isBad());
  EXPECT_EQ(child->parent(), orphan);
  EXPECT_FALSE(root->isBad());
}

// The paper's rule: a map point lives only while seen in at least 3 keyframes.
// On probation (just triangulated) two views suffice; once confirmed, losing
// the third observer kills it. It used to survive with two.
TEST_F(MapGraphTest, ConfirmedPointDiesBelowThreeObservations) {
  KeyFrame* a = map_.createKeyFrame(makeFrame(0, 10));
  KeyFrame* b = map_.createKeyFrame(makeFrame(1, 10));
  KeyFrame* c = map_.createKeyFrame(makeFrame(2, 10));
  KeyFrame* d = map_.createKeyFrame(makeFrame(3, 10));
  MapPoint* on_probation = observe({a, b, c}, 0);
  MapPoint* confirmed = observe({a, b, c}, 1);
  confirmed->confirm(3);
  on_probation->eraseObservation(c);
  confirmed->eraseObservation(c);
  EXPECT_FALSE(on_probation->isBad());
  EXPECT_TRUE(confirmed->isBad());
  EXPECT_EQ(a->mapPoint(1), nullptr);
  MapPoint* four = observe({a, b, c, d}, 2);
  four->confirm(3);
  four->eraseObservation(d);
  EXPECT_FALSE(four->isBad());
}

// Loop Closing pauses Local Mapping before it corrects the map. pause() must
// return only once every queued keyframe is linked and mapped (a keyframe left
// in the queue would sit outside the covisibility graph and the spanning tree
// while the map moves), and no keyframe may be taken until resume(). Before,
// pause() returned as soon as the keyframe in hand was done, with the rest
// still queued.
TEST_F(MapGraphTest, LocalMappingPausesOnlyOnceItsQueueIsDrained) {
  Config config;
  LocalMapping local_mapping(config, map_, nullptr);
  std::atomic<int> mapped{0};
  local_mapping.setAfterKeyFrameHook([&](long) {
    std::this_thread::sleep_for(std::chrono::milliseconds(40));  // a slow keyframe: the queue fills
    ++mapped;
  });
  local_mapping.start();
  for (long id = 0; id < 4; ++id) {
    std::lock_guard<std::mutex> lock(map_.mutex());
    local_mapping.insertKeyFrame(map_.createKeyFrame(makeFrame(id, 10, 0.1 * id)));
  }
  local_mapping.pause();
  EXPECT_EQ(mapped.load(), 4);
  EXPECT_EQ(local_mapping.queuedKeyFrames(), 0u);
  EXPECT_TRUE(local_mapping.paused());
  EXPECT_FALSE(local_mapping.acceptsKeyFrames());

  // Paused: a keyframe inserted now waits in the queue until resume().
  {
    std::lock_guard<std::mutex> lock(map_.mutex());
    local_mapping.insertKeyFrame(map_.createKeyFrame(makeFrame(4, 10, 0.4)));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(mapped.load(), 4);
  EXPECT_EQ(local_mapping.queuedKeyFrames(), 1u);
  EXPECT_FALSE(local_mapping.acceptsKeyFrames());

  local_mapping.resume();
  local_mapping.waitUntilIdle();
  EXPECT_EQ(mapped.load(), 5);
  EXPECT_FALSE(local_mapping.paused());
  EXPECT_TRUE(local_mapping.acceptsKeyFrames());
  local_mapping.finish();
}

// ORB-SLAM2's place-recognition candidates (relocalisation and loop
// detection), on hand-made bags of words scored against a query of words 1-10
// at 0.1 each. B alone scores best (0.9); A1, A2, A3 see one place together
// (0.72, 0.72, 0.81: 2.25 as a group); C scores 0.5 but shares only 5 words,
// under 80 % of the 9 the best share. The group wins, represented by its best
// member A3; B's 0.9 is under 75 % of 2.25. Relocalisation used to try the 10
// best single scores: B first.
TEST_F(MapGraphTest, PlaceCandidatesAreTheBestCovisibilityGroups) {
  auto bagOf = [](double per_word, int words, WordId own_word) {
    BowVector bow;
    for (int w = 1; w <= words; ++w) bow[w] = per_word;
    bow[own_word] = 1.0 - per_word * words;
    return bow;
  };
  KeyframeDatabase database;
  auto addKeyFrame = [&](long id, const BowVector& bow) {
    KeyFrame* keyframe = map_.createKeyFrame(makeFrame(id, 100, 0.1 * id));
    keyframe->bow = bow;
    keyframe->bow_features[0].push_back(0);
    database.add(keyframe->id(), bow);
    return keyframe;
  };
  KeyFrame* b = addKeyFrame(0, bagOf(0.1, 9, 200));
  KeyFrame* a1 = addKeyFrame(1, bagOf(0.08, 9, 100));
  KeyFrame* a2 = addKeyFrame(2, bagOf(0.08, 9, 101));
  KeyFrame* a3 = addKeyFrame(3, bagOf(0.09, 9, 102));
  KeyFrame* c = addKeyFrame(4, bagOf(0.2, 5, 103));
  for (int i = 0; i < 30; ++i) observe({a1, a2, a3}, i);
  for (KeyFrame* keyframe : {b, a1, a2, a3, c}) keyframe->updateConnections();
  ASSERT_EQ(a1->weight(a3), 30);

  const BowVector query = bagOf(0.1, 10, 300);
  EXPECT_EQ(selectPlaceCandidates(database, map_, query, {}, 0.0), std::vector<KeyFrame*>{a3});
  // Without the group rule B would be kept; without the shared-words rule, C too.
  PlaceCandidateRule loose;
  loose.min_group_score_ratio = 0.0;
  loose.min_shared_words_ratio = 0.0;
  const std::vector<KeyFrame*> all = selectPlaceCandidates(database, map_, query, {}, 0.0, loose);
  EXPECT_EQ(all.size(), 3u);  // B, C and the A group (A3 for all three members)
  // A minimum score and exclusions apply before grouping. Without A3, A1 and
  // A2 tie within their group (1.44), and each represents its own.
  EXPECT_EQ(selectPlaceCandidates(database, map_, query, {a3->id()}, 0.0), (std::vector<KeyFrame*>{a1, a2}));
  EXPECT_EQ(selectPlaceCandidates(database, map_, query, {}, 0.85), std::vector<KeyFrame*>{b});
}

}  // namespace
}  // namespace vslam
