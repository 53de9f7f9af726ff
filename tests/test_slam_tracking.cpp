// Tracking on its own (no System): a deterministic map of the rendered room,
// with Local Mapping run synchronously after each keyframe.
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "vslam/map/map.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/frame_builder.hpp"
#include "vslam/slam/local_mapping.hpp"
#include "vslam/slam/tracking.hpp"

namespace vslam {
namespace {

struct TrackedRoom {
  explicit TrackedRoom(const Config& config)
      : builder(config, config.camera),
        local_mapping(config, map, nullptr),
        tracking(config, map, local_mapping, nullptr, KeyFrameInsertion::Synchronous) {}

  bool track(long id, const cv::Mat& image) {
    // Monocular initialisation extracts twice the features, as System does.
    const int n_features = tracking.state() == TrackingState::NotInitialized ? 2 * builder.extractor().params().n_features : -1;
    last = builder.build(id, static_cast<int>(id), 0.1 * static_cast<double>(id), image, cv::Mat(), n_features);
    return tracking.track(last);
  }

  Map map;
  FrameBuilder builder;
  LocalMapping local_mapping;
  Tracking tracking;
  Frame last;
};

// The room's camera, no detector, no vocabulary (relocalisation retries the
// reference keyframe): Tracking alone on exact geometry.
Config roomTrackingConfig(const RoomLoopParams& room) {
  Config config;
  config.camera = room.camera;
  config.detector.model = "none";
  config.loop.vocabulary.clear();
  return config;
}

// Moves the whole map into another world frame: p' = G p, T_cw' = T_cw G^-1,
// as a loop correction or a local BA moves the keyframes under Tracking.
void moveWorld(Map& map, const SE3& G) {
  std::lock_guard<std::mutex> lock(map.mutex());
  for (KeyFrame* keyframe : map.keyframes()) keyframe->setPose(keyframe->pose() * G.inverse());
  for (MapPoint* point : map.mapPoints()) point->setPosition(G * point->position());
  for (MapPoint* point : map.mapPoints())
    if (point->reference() && !point->reference()->isBad()) point->updateNormalAndDepth(point->reference()->pyramid());
}

// The constant-velocity model predicts the next pose from the last frame's.
// That pose must be re-derived from the last frame's reference keyframe before
// each frame, so that a correction of the map (local BA, a loop) reaches the
// prediction. Before, the last frame kept the pose it was tracked with: after
// the map moved, the prediction pointed into the old map, the projection
// search found nothing and tracking fell back to the reference keyframe.
TEST(TrackingMotionModel, PredictionFollowsAMapCorrection) {
  RoomLoopParams room;
  room.frames = 500;
  const std::vector<StampedPose> path = roomLoopPath(room);
  constexpr long kFramesBeforeMove = 40;
  std::vector<cv::Mat> images;
  {
    RoomLoopRenderer renderer(room);
    for (long k = 0; k <= kFramesBeforeMove; ++k) images.push_back(renderer.render(path[k].T_wc).clone());
  }
  const Config config = roomTrackingConfig(room);

  TrackedRoom moved(config), still(config);
  for (long k = 0; k < kFramesBeforeMove; ++k) {
    moved.track(k, images[k]);
    still.track(k, images[k]);
  }
  ASSERT_EQ(moved.tracking.state(), TrackingState::Ok);
  ASSERT_EQ(still.tracking.state(), TrackingState::Ok);
  const int misses_before = moved.tracking.motionModelMisses();

  // Half a unit of map scale (the map's median depth is about 1) and 10 degrees:
  // projections from the stale pose would miss by hundreds of pixels.
  SE3 G;
  G.R = Eigen::AngleAxisd(0.17, Vec3(0, 1, 0)).toRotationMatrix();
  G.t = Vec3(0.5, -0.2, 0.3);
  moveWorld(moved.map, G);

  ASSERT_TRUE(moved.track(kFramesBeforeMove, images[kFramesBeforeMove]));
  ASSERT_TRUE(still.track(kFramesBeforeMove, images[kFramesBeforeMove]));
  EXPECT_EQ(moved.tracking.motionModelMisses(), misses_before);
  EXPECT_EQ(moved.tracking.motionModelMisses(), still.tracking.motionModelMisses());
  // The same frame in the moved world: T_cw' = T_cw G^-1.
  const SE3 expected = still.last.T_cw * G.inverse();
  EXPECT_LT((moved.last.T_cw.t - expected.t).norm(), 1e-3);
  EXPECT_LT(Eigen::AngleAxisd(moved.last.T_cw.R.transpose() * expected.R).angle(), 1e-3);
}

// ORB-SLAM2's rules after a relocalisation at frame 100.
TEST(TrackingAfterRelocalisation, TheNextFrameIsTrackedFromItsReferenceKeyFrame) {
  EXPECT_TRUE(motionModelAllowed(5, -1));  // never relocalised
  EXPECT_FALSE(motionModelAllowed(100, 100));
  EXPECT_FALSE(motionModelAllowed(101, 100));
  EXPECT_TRUE(motionModelAllowed(102, 100));
}

TEST(TrackingAfterRelocalisation, NoKeyFrameUntilTheRelocalisedPoseHasHeld) {
  EXPECT_TRUE(keyFrameAllowedAfterRelocalisation(5, -1, 20, 50));
  EXPECT_FALSE(keyFrameAllowedAfterRelocalisation(100, 100, 20, 50));
  EXPECT_FALSE(keyFrameAllowedAfterRelocalisation(119, 100, 20, 50));
  EXPECT_TRUE(keyFrameAllowedAfterRelocalisation(120, 100, 20, 50));
  EXPECT_TRUE(keyFrameAllowedAfterRelocalisation(101, 100, 20, 20));  // a small map still grows
  EXPECT_FALSE(keyFrameAllowedAfterRelocalisation(101, 100, 20, 21));
}

// ORB-SLAM2's step after relocalisation's PnP: with fewer than 50 inliers, a
// guided search by projection adds the candidate keyframe's other points and
// the pose is optimised again. Here a frame the room map tracks is given only
// 20 of its matches with the candidate and a pose 1 cm and 0.5 degrees off.
TEST(TrackingAfterRelocalisation, AGuidedSearchAddsTheCandidatesOtherPoints) {
  RoomLoopParams room;
  const std::vector<StampedPose> path = roomLoopPath(room);
  constexpr long kFrames = 40;
  RoomLoopRenderer renderer(room);
  const Config config = roomTrackingConfig(room);
  TrackedRoom tracked(config);
  cv::Mat image;
  for (long k = 0; k <= kFrames; ++k) {
    image = renderer.render(path[k].T_wc);
    tracked.track(k, image);
  }
  ASSERT_EQ(tracked.tracking.state(), TrackingState::Ok);
  const KeyFrame* candidate = tracked.map.keyframes().back();
  std::vector<size_t> seen_by_candidate;
  for (size_t i = 0; i < tracked.last.size(); ++i)
    if (tracked.last.map_points[i] && tracked.last.map_points[i]->keypointIn(candidate) >= 0)
      seen_by_candidate.push_back(i);
  ASSERT_GE(seen_by_candidate.size(), 80u) << "the last frame should see much of its newest keyframe";

  // The same image as a new frame: the same keypoints, 20 of the matches.
  Frame frame = tracked.builder.build(kFrames + 1, static_cast<int>(kFrames), 0.1 * kFrames, image, cv::Mat());
  ASSERT_EQ(frame.size(), tracked.last.size());
  frame.map_points.assign(frame.size(), nullptr);
  for (size_t k = 0; k < 20; ++k) {
    const size_t i = seen_by_candidate[k * seen_by_candidate.size() / 20];
    frame.map_points[i] = tracked.last.map_points[i];
  }
  SE3 offset;
  offset.R = Eigen::AngleAxisd(0.5 * M_PI / 180, Vec3(0, 1, 0)).toRotationMatrix();
  offset.t = Vec3(0.01, 0, 0);
  frame.T_cw = offset * tracked.last.T_cw;

  const int inliers = tracked.tracking.refineRelocalisedPose(frame, *candidate);
  EXPECT_GE(inliers, 50);
  EXPECT_GE(inliers, static_cast<int>(0.8 * seen_by_candidate.size()));
  EXPECT_LT((frame.T_cw.t - tracked.last.T_cw.t).norm(), 2e-3);
  EXPECT_LT(Eigen::AngleAxisd(frame.T_cw.R.transpose() * tracked.last.T_cw.R).angle(), 0.1 * M_PI / 180);
}

// Ours, after a relocalisation: when the next frame's reference keyframe
// gives too few matches, the relocalised frame's points are searched at its
// pose (a camera at rest). One frame of the room later (2.5 cm, 0.7 degrees of
// motion at 30 Hz) that finds the same pose as the motion model does.
TEST(TrackingAfterRelocalisation, TheNextFrameCanBeTrackedFromTheLastFrameAtRest) {
  RoomLoopParams room;
  const std::vector<StampedPose> path = roomLoopPath(room);
  constexpr long kFrames = 40;
  RoomLoopRenderer renderer(room);
  const Config config = roomTrackingConfig(room);
  TrackedRoom resting(config), moving(config);
  for (long k = 0; k < kFrames; ++k) {
    const cv::Mat image = renderer.render(path[k].T_wc).clone();
    resting.track(k, image);
    moving.track(k, image);
  }
  ASSERT_EQ(resting.tracking.state(), TrackingState::Ok);
  const cv::Mat next_image = renderer.render(path[kFrames].T_wc).clone();

  Frame at_rest = resting.builder.build(kFrames, static_cast<int>(kFrames), 0.1 * kFrames, next_image, cv::Mat());
  ASSERT_TRUE(resting.tracking.trackFromLastFrameAtRest(at_rest));
  EXPECT_EQ(resting.tracking.atRestAttempts(), 1);
  EXPECT_GE(at_rest.trackedCount(), 50);
  ASSERT_TRUE(moving.track(kFrames, next_image));  // the motion model, then the local map
  EXPECT_EQ(moving.tracking.atRestAttempts(), 0);
  EXPECT_LT((at_rest.T_cw.t - moving.last.T_cw.t).norm(), 5e-3);
  EXPECT_LT(Eigen::AngleAxisd(at_rest.T_cw.R.transpose() * moving.last.T_cw.R).angle(), 0.2 * M_PI / 180);
}

// The monocular start scores each window match at its keypoints' pyramid
// levels (KITTI's configs match on levels 0-1). Before this, every match was
// scored with sigma_px alone, as if found at level 0.
TEST(TrackingInitialisation, MatchesCarryTheVarianceOfTheirPyramidLevels) {
  ScalePyramid pyramid;
  pyramid.levels = 3;
  pyramid.scale = {1.0, 1.2, 1.44};
  pyramid.sigma2 = {1.0, 1.44, 2.0736};
  pyramid.inv_sigma2 = {1.0, 1.0 / 1.44, 1.0 / 2.0736};
  auto frameWith = [&](const std::vector<int>& octaves) {
    Frame frame;
    frame.pyramid = &pyramid;
    for (size_t i = 0; i < octaves.size(); ++i) {
      cv::KeyPoint keypoint(cv::Point2f(10.0f * static_cast<float>(i), 5.0f), 31.0f);
      keypoint.octave = octaves[i];
      frame.keypoints.push_back(keypoint);
      frame.points.push_back(keypoint.pt + cv::Point2f(0.5f, 0.25f));
    }
    return frame;
  };
  const Frame reference = frameWith({0, 1, 2});
  const Frame current = frameWith({1, 0, 0, 2});
  // Reference keypoint 0 matches current 3, 1 none, 2 matches current 0.
  const InitialisationMatches matches = initialisationMatches(reference, current, {3, -1, 0}, 1.5);
  ASSERT_EQ(matches.pairs.size(), 2u);
  EXPECT_EQ(matches.pairs[0], std::make_pair(0, 3));
  EXPECT_EQ(matches.pairs[1], std::make_pair(2, 0));
  EXPECT_EQ(matches.pts_ref[1], Vec2(20.5, 5.25));
  EXPECT_EQ(matches.pts_cur[0], Vec2(30.5, 5.25));
  ASSERT_EQ(matches.sigma2_ref.size(), 2u);
  ASSERT_EQ(matches.sigma2_cur.size(), 2u);
  EXPECT_DOUBLE_EQ(matches.sigma2_ref[0], 2.25 * 1.0);     // level 0, sigma_px 1.5
  EXPECT_DOUBLE_EQ(matches.sigma2_cur[0], 2.25 * 2.0736);  // level 2
  EXPECT_DOUBLE_EQ(matches.sigma2_ref[1], 2.25 * 2.0736);
  EXPECT_DOUBLE_EQ(matches.sigma2_cur[1], 2.25 * 1.44);    // level 1
}

}  // namespace
}  // namespace vslam
