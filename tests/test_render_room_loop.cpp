// The synthetic room-loop sequence: its path, its pictures, its TUM folder.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/render/room_loop.hpp"

namespace vslam {
namespace {

RoomLoopParams smallRoom(int frames) {
  RoomLoopParams params;
  params.frames = frames;
  params.texture_px = 256;
  return params;
}

TEST(RoomLoop, PathCirclesOutwardLookingAndClosesAfterOneTurn) {
  RoomLoopParams params = smallRoom(9);
  params.turns = 1.0;
  params.bob_m = 0.0;
  const std::vector<StampedPose> path = roomLoopPath(params);
  ASSERT_EQ(path.size(), 9u);
  for (size_t k = 0; k < path.size(); ++k) {
    const SE3& T_wc = path[k].T_wc;
    EXPECT_DOUBLE_EQ(path[k].timestamp, k / 30.0);
    EXPECT_NEAR(T_wc.t.norm(), 0.8, 1e-12);
    EXPECT_NEAR(T_wc.t.y(), 0.0, 1e-12);
    // Looks straight out from the centre, upright (camera y along world y, down).
    EXPECT_NEAR(T_wc.R.col(2).dot(T_wc.t.normalized()), 1.0, 1e-12);
    EXPECT_NEAR(T_wc.R.col(1).y(), 1.0, 1e-12);
    EXPECT_NEAR(T_wc.R.determinant(), 1.0, 1e-12);
  }
  // A quarter turn every two frames; the last pose is the first.
  EXPECT_NEAR(path[2].T_wc.t.x(), 0.0, 1e-12);
  EXPECT_NEAR(path[2].T_wc.t.z(), 0.8, 1e-12);
  EXPECT_NEAR((path[8].T_wc.t - path[0].T_wc.t).norm(), 0.0, 1e-12);
  EXPECT_NEAR((path[8].T_wc.R - path[0].T_wc.R).norm(), 0.0, 1e-12);
  // Between close frames the camera moves sideways (to its left), the motion
  // monocular SLAM sees best: one degree of arc, 1.4 cm, bends 0.12 mm inwards.
  params.frames = 361;
  const std::vector<StampedPose> fine = roomLoopPath(params);
  const Vec3 motion_c = fine[0].T_wc.R.transpose() * (fine[1].T_wc.t - fine[0].T_wc.t);
  EXPECT_NEAR(motion_c.x(), -0.8 * std::sin(M_PI / 180), 1e-12);
  EXPECT_NEAR(motion_c.y(), 0.0, 1e-12);
  EXPECT_NEAR(motion_c.z(), -0.8 * (1 - std::cos(M_PI / 180)), 1e-12);
}

// Where a room corner (the meeting line of two walls) falls in the image is
// known exactly: a camera at the centre looking at the corner x = z = +w sees
// the corner line on its principal column, and the walls on either side are
// different panels, so the picture changes abruptly there and nowhere near.
TEST(RoomLoop, RenderPutsARoomCornerOnThePrincipalColumn) {
  const RoomLoopParams params = smallRoom(2);
  RoomLoopRenderer renderer(params);
  Mat3 R_wc;
  R_wc.col(2) = Vec3(1, 0, 1).normalized();
  R_wc.col(1) = Vec3(0, 1, 0);
  R_wc.col(0) = R_wc.col(1).cross(R_wc.col(2));
  const cv::Mat image = renderer.render(SE3(R_wc, Vec3::Zero()));
  ASSERT_EQ(image.cols, 640);
  ASSERT_EQ(image.rows, 480);
  ASSERT_EQ(image.type(), CV_8UC3);

  // Column of the strongest vertical edge, summed over the rows of the walls' middle band.
  cv::Mat grey, dx;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  cv::Sobel(grey(cv::Rect(0, 200, 640, 80)), dx, CV_32F, 1, 0);
  cv::Mat column_energy;
  cv::reduce(cv::abs(dx), column_energy, 0, cv::REDUCE_SUM);
  // Random shapes make edges too, but none straight and unbroken over the
  // whole band. The nearest panel seams (x = +-1 m on the far walls) fall
  // 26.6 degrees off the axis, 263 px away: search 100 px either side.
  cv::Point best;
  cv::minMaxLoc(column_energy(cv::Rect(220, 0, 200, 1)), nullptr, nullptr, nullptr, &best);
  EXPECT_NEAR(220 + best.x, params.camera.cx, 1.0);

  // The same pose draws the same picture.
  const cv::Mat again = renderer.render(SE3(R_wc, Vec3::Zero()));
  EXPECT_EQ(cv::norm(image, again, cv::NORM_INF), 0.0);
}

TEST(RoomLoop, WritesATumFolderThatOpensAsASequence) {
  const std::filesystem::path folder = test::scratchDir("RoomLoop_Folder") / "room";
  const RoomLoopParams params = smallRoom(4);
  int reported = 0;
  writeRoomLoopSequence(params, folder.string(), [&](int done, int total) {
    EXPECT_EQ(total, 4);
    reported = done;
  });
  EXPECT_EQ(reported, 4);

  SequenceOptions options;
  options.config_path = (folder / "camera.yaml").string();
  const Sequence sequence = openSequence(folder.string(), options);
  ASSERT_EQ(sequence.frames.size(), 4u);
  EXPECT_EQ(sequence.config.camera.fx, 525.0);
  EXPECT_EQ(sequence.config.camera.cx, 319.5);
  EXPECT_FALSE(sequence.config.camera.hasDistortion());
  const std::vector<StampedPose> path = roomLoopPath(params);
  ASSERT_EQ(sequence.groundtruth.size(), path.size());
  for (size_t k = 0; k < path.size(); ++k) {
    EXPECT_NEAR(sequence.frames[k].timestamp, path[k].timestamp, 1e-6);
    EXPECT_NEAR((sequence.groundtruth[k].T_wc.t - path[k].T_wc.t).norm(), 0.0, 1e-8);
  }
  RoomLoopRenderer renderer(params);
  const cv::Mat written = sequence.loadColor(2);
  EXPECT_EQ(cv::norm(written, renderer.render(path[2].T_wc), cv::NORM_INF), 0.0);  // PNG is lossless
}

}  // namespace
}  // namespace vslam
