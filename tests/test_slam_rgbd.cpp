// RGB-D SLAM (issue 13): depth per keypoint in the frame, a metric map from one
// frame, stereo residuals, SE(3) loops. End to end on the synthetic room (exact
// depth) and on TUM fr1_xyz, threaded as users run it and deterministic.
#include <cmath>
#include <limits>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "sequence_test_support.hpp"
#include "system_test_support.hpp"
#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/frame_builder.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

AteResult ate(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth,
              Alignment alignment) {
  AteOptions options;
  options.alignment = alignment;
  return computeAte(estimate, groundtruth, options);
}

Config rgbdConfig(Config config) {
  config.sensor = SensorMode::RgbD;
  config.detector.model = "none";
  return config;
}

// A textured image: FAST corners everywhere.
cv::Mat noiseImage(int width, int height) {
  cv::Mat small(height / 8, width / 8, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(small, cv::RNG::UNIFORM, 0, 256);
  cv::Mat image;
  cv::resize(small, image, cv::Size(width, height), 0, 0, cv::INTER_NEAREST);
  return image;
}

// Each keypoint's depth is the depth image's reading where the keypoint was
// detected; u_R = u - bf / d exactly; 0, NaN and readings beyond max_depth_m
// leave a monocular keypoint. Box keypoints of the keypoint filter get depth too.
TEST(RgbdFrame, DepthAndRightCoordinatePerKeypoint) {
  Config config;
  config.camera.width = 640;
  config.camera.height = 480;
  config.camera.fx = config.camera.fy = 500;
  config.camera.cx = 320;
  config.camera.cy = 240;
  config.camera.bf = 40;
  config.camera.max_depth_m = 10;
  config.sensor = SensorMode::RgbD;
  const FrameBuilder builder(config, config.camera);
  const cv::Mat image = noiseImage(640, 480);
  // Depth rises with the column; four bands of invalid readings.
  cv::Mat depth(480, 640, CV_32F);
  for (int r = 0; r < 480; ++r)
    for (int c = 0; c < 640; ++c) depth.at<float>(r, c) = 1.0f + c / 640.0f;
  depth.rowRange(0, 60).setTo(0.0f);
  depth.rowRange(60, 120).setTo(std::numeric_limits<float>::quiet_NaN());
  depth.rowRange(120, 180).setTo(12.0f);  // beyond max_depth_m
  depth.rowRange(180, 240).setTo(10.0f);  // at the limit: kept

  std::vector<Detection> detections(1);
  detections[0].id = 0;
  detections[0].class_id = 56;
  detections[0].confidence = 0.9f;
  detections[0].box = cv::Rect2f(300, 300, 200, 150);
  const Frame frame = builder.build(0, 0, 0.0, image, depth, -1, &detections);
  ASSERT_EQ(frame.depth.size(), frame.size());
  ASSERT_EQ(frame.u_right.size(), frame.size());
  int invalid = 0, at_limit = 0, valid = 0, in_box_with_depth = 0, outside_right = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    const int row = cvRound(frame.keypoints[i].pt.y), col = cvRound(frame.keypoints[i].pt.x);
    if (row < 180 && row >= 0) {
      EXPECT_FALSE(frame.hasDepth(i)) << "row " << row;
      EXPECT_FALSE(hasRightCoordinate(frame.rightCoordinate(i)));
      ++invalid;
      continue;
    }
    const float expected = row < 240 ? 10.0f : depth.at<float>(row, col);
    if (frame.points[i].x < 40.0 / expected) {
      // u_R < 0: outside the virtual right image, so monocular.
      EXPECT_FALSE(frame.hasDepth(i));
      ++outside_right;
      continue;
    }
    ASSERT_TRUE(frame.hasDepth(i)) << "row " << row << " col " << col;
    EXPECT_EQ(frame.depth[i], expected);
    // No distortion: the undistorted u is the keypoint's own.
    EXPECT_FLOAT_EQ(frame.u_right[i], static_cast<float>(frame.points[i].x - 40.0 / expected));
    (row < 240 ? at_limit : valid)++;
    if (frame.labels[i].class_id == 56) ++in_box_with_depth;
  }
  EXPECT_GT(invalid, 100);
  EXPECT_GT(at_limit, 20);
  EXPECT_GT(valid, 300);
  EXPECT_GT(in_box_with_depth, 50);
  EXPECT_GT(outside_right, 5);

  // Without a depth image the frame is monocular.
  const Frame mono = builder.build(1, 1, 0.0, image);
  EXPECT_TRUE(mono.depth.empty());
  EXPECT_FALSE(mono.hasDepth(0));
}

// With lens distortion the depth is read at the keypoint's undistorted
// position: the depth image is registered to the colour camera's pinhole model.
TEST(RgbdFrame, DepthIsReadAtTheUndistortedPosition) {
  Config config = loadConfig(projectConfigDir() + "/tum_fr1.yaml");  // k1 = 0.26, k3 = 1.16
  config.sensor = SensorMode::RgbD;
  const FrameBuilder builder(config, config.camera);
  // Each pixel's depth names the pixel: 1 m + column mm + row / 10 mm... exactly
  // representable, so the sampled pixel can be read back.
  cv::Mat depth(480, 640, CV_32F);
  for (int r = 0; r < 480; ++r)
    for (int c = 0; c < 640; ++c) depth.at<float>(r, c) = 1.0f + c / 1024.0f + r / (1024.0f * 1024.0f);
  const Frame frame = builder.build(0, 0, 0.0, noiseImage(640, 480), depth);
  int checked = 0, moved = 0;
  for (size_t i = 0; i < frame.size(); ++i) {
    const int row = cvRound(frame.points[i].y), col = cvRound(frame.points[i].x);
    if (row < 0 || col < 0 || row >= 480 || col >= 640) {
      EXPECT_FALSE(frame.hasDepth(i));
      continue;
    }
    if (!frame.hasDepth(i)) continue;  // u_R < 0: outside the virtual right image
    EXPECT_EQ(frame.depth[i], depth.at<float>(row, col));
    ++checked;
    if (cv::Point(col, row) != cv::Point(cvRound(frame.keypoints[i].pt.x), cvRound(frame.keypoints[i].pt.y))) ++moved;
  }
  EXPECT_GT(checked, 500);
  EXPECT_GT(moved, checked / 2);  // the test tells the two positions apart
}

// The room with its exact rendered depth (16-bit TUM encoding): the map is
// metric from the first frame, so the trajectory needs no scale, and the loop
// is closed as a rigid motion. Threaded, as users run it.
TEST(SlamRgbd, RoomWithExactDepthIsMetric) {
  // 1.3 turns at the default speed (1.2 turns in 500 frames): RGB-D keyframes
  // are sparse, and the 0.2 turn of revisit gave only 3 keyframes with the
  // old place as candidate, one short of ORB-SLAM2's 4 consecutive detections.
  RoomLoopParams room;
  room.turns = 1.3;
  room.frames = 542;
  const std::vector<StampedPose> path = roomLoopPath(room);
  RoomLoopRenderer renderer(room);
  Config config = rgbdConfig(Config());
  config.camera = room.camera;
  ASSERT_GT(config.camera.bf, 0);
  System system(config, SystemOptions());
  test::feedRoom(system, renderer, path, /*with_depth=*/true);
  system.finish();
  EXPECT_EQ(system.stats().initialised_at_index, 0);
  EXPECT_GE(system.stats().frames_tracked, static_cast<int>(path.size()) - 1);
  const AteResult metric = ate(system.keyframeTrajectory(), path, Alignment::SE3);
  const AteResult scaled = ate(system.keyframeTrajectory(), path, Alignment::Sim3);
  const AteResult frames = ate(system.frameTrajectory(), path, Alignment::SE3);
  std::printf("keyframe ATE %.4f m (Sim(3) scale %.4f), frame ATE %.4f m, %zu loops\n", metric.rmse_m, scaled.scale,
              frames.rmse_m, system.loops().size());
  EXPECT_NEAR(scaled.scale, 1.0, 0.01);
  // Issue 13's bound is on keyframes (measured 0.46 cm). The frames between
  // keyframes, tracked by pose-only optimisation, were measured at 0.68 cm:
  // their bound is the measured figure with a margin, not the target.
  EXPECT_LE(metric.rmse_m, 0.005);
  EXPECT_LT(frames.rmse_m, 0.009);
  ASSERT_FALSE(system.loops().empty()) << "the room's second turn revisits the start";
  for (const LoopRecord& loop : system.loops()) EXPECT_EQ(loop.scale, 1.0);  // SE(3): scale fixed
}

struct Fr1Run {
  std::vector<StampedPose> frames, keyframes;
  std::vector<int> lost;
  SystemStats stats;
  size_t loops = 0;
};

Fr1Run runFr1(const Sequence& sequence, SensorMode sensor, bool deterministic, size_t count,
             bool depth_to_mono = false) {
  Config config = rgbdConfig(sequence.config);
  config.sensor = sensor;
  SystemOptions options;
  options.deterministic = deterministic;
  System system(config, options);
  for (size_t i = 0; i < count && i < sequence.frames.size(); ++i) {
    const cv::Mat colour = sequence.loadColor(i);
    const bool with_depth = (sensor == SensorMode::RgbD || depth_to_mono) && !sequence.frames[i].depth_path.empty();
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, colour,
                        with_depth ? sequence.loadDepthMeters(i, colour.size()) : cv::Mat());
  }
  system.finish();
  return {system.frameTrajectory(), system.keyframeTrajectory(), system.lostFrameIndices(), system.stats(),
          system.loops().size()};
}

// The whole of fr1_xyz with depth, threaded and deterministic: every frame
// that has a depth image is tracked, and the map is metric. Measured (docs/
// BENCHMARKS.md, "Rolling shutter in the final BA") 0.32-0.38 cm for
// keyframes and 0.48-0.51 cm for frames threaded, scale within 0.4 %; the
// bounds are issue 13's targets (0.9 cm), which leave room for run-to-run
// spread. Before the final BA modelled the rolling shutter the keyframes
// were at 0.76-0.92 cm.
TEST(SlamRgbd, Fr1XyzTracksEveryFrameWithDepthAtMetricScale) {
  const Sequence sequence = test::openSharedSequence("tum/fr1_xyz");
  std::set<int> with_depth;
  for (const FrameEntry& frame : sequence.frames)
    if (!frame.depth_path.empty()) with_depth.insert(frame.index);
  ASSERT_EQ(with_depth.size(), 792u);
  for (bool deterministic : {false, true}) {
    SCOPED_TRACE(deterministic ? "deterministic" : "threaded");
    const Fr1Run run = runFr1(sequence, SensorMode::RgbD, deterministic, sequence.frames.size());
    EXPECT_EQ(run.stats.initialised_at_index, 0);
    EXPECT_EQ(run.stats.frames_without_depth, 6);
    for (int index : run.lost) EXPECT_FALSE(with_depth.count(index)) << "frame " << index << " has depth but was lost";
    const AteResult keyframes = ate(run.keyframes, sequence.groundtruth, Alignment::SE3);
    const AteResult frames = ate(run.frames, sequence.groundtruth, Alignment::SE3);
    EXPECT_LT(keyframes.rmse_m, 0.009);
    EXPECT_LT(frames.rmse_m, 0.009);
    EXPECT_NEAR(ate(run.keyframes, sequence.groundtruth, Alignment::Sim3).scale, 1.0, 0.02);
    EXPECT_EQ(run.loops, 0u) << "fr1_xyz never leaves its local map: a loop closed there is false";
  }
}

// fr3_teddy (200 frames, a camera circling a teddy bear at about 1.5 m):
// threaded, every frame tracked and metric. ORB-SLAM2's RGB-D keyframe
// condition (fewer than a quarter of the reference's points tracked) keeps the
// map dense enough: without it keyframe ATE was 1.1-1.3 cm and the scale 1.5 %
// short; with it 0.72-0.85 cm (docs/BENCHMARKS.md).
TEST(SlamRgbd, Fr3TeddyIsTrackedAccuratelyAtMetricScale) {
  const Sequence sequence = test::openSharedSequence("tum/fr3_teddy");
  const Fr1Run run = runFr1(sequence, SensorMode::RgbD, false, sequence.frames.size());
  EXPECT_EQ(run.stats.frames_tracked, 200);
  EXPECT_LT(ate(run.keyframes, sequence.groundtruth, Alignment::SE3).rmse_m, 0.0105);
  EXPECT_NEAR(ate(run.keyframes, sequence.groundtruth, Alignment::Sim3).scale, 1.0, 0.013);
  EXPECT_EQ(run.loops, 0u) << "no place is left and revisited in these 200 frames: a loop closed there is false";
}

// Depth must change the run: the same frames in mono and RGB-D give other
// trajectories, and only the RGB-D one is metric without a scale.
TEST(SlamRgbd, DepthIsUsed) {
  const Sequence sequence = test::openSharedSequence("tum/fr1_xyz");
  const Fr1Run mono = runFr1(sequence, SensorMode::Monocular, true, 120);
  const Fr1Run rgbd = runFr1(sequence, SensorMode::RgbD, true, 120);
  ASSERT_GT(mono.frames.size(), 60u);
  ASSERT_GT(rgbd.frames.size(), 110u);
  EXPECT_GT(mono.stats.initialised_at_index, 0);  // monocular needs two views
  EXPECT_EQ(rgbd.stats.initialised_at_index, 0);
  const double mono_scale = ate(mono.keyframes, sequence.groundtruth, Alignment::Sim3).scale;
  const double rgbd_scale = ate(rgbd.keyframes, sequence.groundtruth, Alignment::Sim3).scale;
  EXPECT_NEAR(rgbd_scale, 1.0, 0.05);
  EXPECT_GT(std::abs(mono_scale - 1.0), 0.1) << "a monocular map has the scale of its initialisation";

  // A monocular system given depth images ignores them: the same run to the digit.
  const Fr1Run mono_with_depth = runFr1(sequence, SensorMode::Monocular, true, 120, true);
  ASSERT_EQ(mono_with_depth.frames.size(), mono.frames.size());
  for (size_t i = 0; i < mono.frames.size(); ++i) EXPECT_EQ(mono_with_depth.frames[i].T_wc.t, mono.frames[i].T_wc.t);
}

}  // namespace
}  // namespace vslam
