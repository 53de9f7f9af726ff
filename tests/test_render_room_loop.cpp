// The synthetic room-loop sequence: its path, its pictures, its TUM folder.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
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

// Camera z of the room surface through the centre of pixel (u, v), from the
// geometry alone: the room is a box seen from inside, so the surface is the
// nearest of its six planes the ray meets ahead of the camera.
double roomDepthAt(const RoomLoopParams& room, const SE3& T_wc, double u, double v) {
  const PinholeCamera& camera = room.camera;
  const Vec3 ray = T_wc.R * Vec3((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0);  // camera z = 1
  double nearest = std::numeric_limits<double>::infinity();
  auto meet = [&](int axis, double plane) {
    if (ray[axis] == 0.0) return;
    const double z = (plane - T_wc.t[axis]) / ray[axis];  // the ray's parameter is its camera z
    if (z > 0) nearest = std::min(nearest, z);
  };
  meet(0, room.room_half_width_m);
  meet(0, -room.room_half_width_m);
  meet(2, room.room_half_width_m);
  meet(2, -room.room_half_width_m);
  meet(1, room.ceiling_y_m);
  meet(1, room.floor_y_m);
  return nearest;
}

std::vector<std::string> listedTimestamps(const std::filesystem::path& list, const std::string& folder) {
  std::ifstream in(list);
  std::vector<std::string> stamps;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    EXPECT_EQ(line.substr(space + 1), folder + "/" + line.substr(0, space) + ".png") << list;
    stamps.push_back(line.substr(0, space));
  }
  return stamps;
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

// Every pixel's depth against the box's planes, from an off-centre, turned,
// tilted and rolled camera: all six planes and both image halves differ, so a
// row flip, a half-pixel shift, ray length instead of z, or a wrong
// linearisation shows as centimetres, not tenths of a millimetre.
TEST(RoomLoop, RenderDepthIsTheCameraZOfTheRoomsPlanes) {
  const RoomLoopParams params = smallRoom(2);
  RoomLoopRenderer renderer(params);
  const Mat3 R_wc = (Eigen::AngleAxisd(0.7, Vec3::UnitY()) * Eigen::AngleAxisd(-0.25, Vec3::UnitX()) *
                     Eigen::AngleAxisd(0.15, Vec3::UnitZ()))
                        .toRotationMatrix();
  const SE3 T_wc(R_wc, Vec3(0.9, -0.35, -1.1));
  const cv::Mat depth = renderer.renderDepth(T_wc);
  ASSERT_EQ(depth.cols, 640);
  ASSERT_EQ(depth.rows, 480);
  ASSERT_EQ(depth.type(), CV_32FC1);

  double worst = 0.0, nearest = 1e9, farthest = 0.0;
  cv::Point worst_at;
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u) {
      const double expected = roomDepthAt(params, T_wc, u, v);
      const double error = std::abs(depth.at<float>(v, u) - expected);
      if (error > worst) worst = error, worst_at = cv::Point(u, v);
      nearest = std::min(nearest, expected);
      farthest = std::max(farthest, expected);
    }
  // Measured (Mesa's software rasteriser, 24-bit buffer, near plane 5 cm):
  // 0.077 mm at most, median 0.005 mm, over 1.76-4.73 m; the bound is one TUM
  // depth step. Half a pixel off in x alone gives 7 mm, rows upside down 1.7 m.
  EXPECT_LT(worst, 2e-4) << "worst at " << worst_at << ", depth " << nearest << " .. " << farthest << " m";

  // Without the model: facing the wall z = -w head on from 1 m, z is 1 m at
  // every pixel (the ray's length would be 1.2 m in the image's corners).
  const SE3 facing(Eigen::AngleAxisd(M_PI, Vec3::UnitY()).toRotationMatrix(), Vec3(0.0, 0.0, -2.0));
  const cv::Mat head_on = renderer.renderDepth(facing);
  for (const cv::Point& pixel : {cv::Point(320, 240), cv::Point(0, 0), cv::Point(639, 0), cv::Point(0, 479),
                                 cv::Point(639, 479), cv::Point(600, 10)})
    EXPECT_NEAR(head_on.at<float>(pixel), 1.0, 1e-4) << pixel;
}

TEST(RoomLoop, TumDepthEncodingRoundsAndDropsWhatDoesNotFit) {
  const cv::Mat metres = (cv::Mat_<float>(1, 7) << 0.f, 1.f, 2.50004f, 2.50006f, 13.107f, 13.2f, 0.00009f);
  const cv::Mat raw = encodeTumDepth(metres, 5000.0);
  ASSERT_EQ(raw.type(), CV_16UC1);
  const std::vector<uint16_t> expected = {0, 5000, 12500, 12500, 65535, 0, 0};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(raw.at<uint16_t>(0, i), expected[i]) << "entry " << i;
}

TEST(RoomLoop, WritesDepthForEveryColourFrame) {
  const std::filesystem::path folder = test::scratchDir("RoomLoop_Depth") / "room";
  const RoomLoopParams params = smallRoom(3);
  writeRoomLoopSequence(params, folder.string());

  const std::vector<std::string> colour_stamps = listedTimestamps(folder / "rgb.txt", "rgb");
  EXPECT_EQ(listedTimestamps(folder / "depth.txt", "depth"), colour_stamps);
  ASSERT_EQ(colour_stamps.size(), 3u);
  for (const std::string& stamp : colour_stamps) {
    const cv::Mat raw = cv::imread((folder / "depth" / (stamp + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(raw.type(), CV_16UC1) << stamp;
    EXPECT_EQ(raw.size(), cv::Size(640, 480)) << stamp;
  }

  SequenceOptions options;
  options.config_path = (folder / "camera.yaml").string();
  const Sequence sequence = openSequence(folder.string(), options);
  ASSERT_EQ(sequence.frames.size(), 3u);
  EXPECT_TRUE(sequence.hasDepth());
  EXPECT_EQ(sequence.framesWithDepth(), 3);
  const PinholeCamera& camera = sequence.config.camera;
  EXPECT_EQ(camera.depth_factor, 5000.0);
  EXPECT_EQ(camera.bf, 40.0);
  EXPECT_EQ(camera.th_depth, 40.0);
  EXPECT_EQ(camera.max_depth_m, 10.0);

  const std::vector<StampedPose> path = roomLoopPath(params);
  RoomLoopRenderer renderer(params);
  for (size_t k = 0; k < sequence.frames.size(); ++k) {
    EXPECT_EQ(std::filesystem::path(sequence.frames[k].depth_path).stem(),
              std::filesystem::path(sequence.frames[k].image_path).stem());
    const cv::Mat metres = sequence.loadDepthMeters(k, sequence.loadColor(k).size());
    ASSERT_EQ(metres.type(), CV_32FC1);
    // A closed room: every pixel sees a wall, and the file holds the render to its 0.2 mm step.
    EXPECT_EQ(cv::countNonZero(metres), 640 * 480) << "frame " << k;
    EXPECT_LE(cv::norm(metres, renderer.renderDepth(path[k].T_wc), cv::NORM_INF), 0.5 / 5000 + 1e-6) << "frame " << k;
  }
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

namespace vslam {
namespace {

// A room with a billboard of a plain picture (pure red, twice as wide as
// tall) crossing the view during frames 20-60 of 100.
RoomLoopParams roomWithMovingObject(const std::string& scratch) {
  RoomLoopParams params = smallRoom(100);
  const std::filesystem::path picture = test::scratchDir(scratch) / "red.png";
  cv::imwrite(picture.string(), cv::Mat(50, 100, CV_8UC3, cv::Scalar(0, 0, 255)));
  params.moving_object_image = picture.string();
  params.moving_object_first_frame = 20;
  params.moving_object_frames = 40;
  params.moving_object_sweep_deg = 40.0;
  return params;
}

// The bearing of a world point from the camera, in the horizontal plane,
// positive towards the camera's +x.
double bearingDeg(const SE3& T_wc, const Vec3& point_w) {
  const Vec3 p_c = T_wc.inverse() * point_w;
  return std::atan2(p_c.x(), p_c.z()) * 180.0 / M_PI;
}

TEST(RoomLoopMovingObject, CrossesTheViewFromSideToSideFacingTheRoomsCentre) {
  const RoomLoopParams params = roomWithMovingObject("moving_object_geometry");
  const std::vector<StampedPose> path = roomLoopPath(params);
  const double aspect = 0.5;
  auto centreAt = [&](int frame) {
    const std::array<Vec3, 4> c = movingObjectCorners(params, frame, aspect);
    return Vec3(0.25 * (c[0] + c[1] + c[2] + c[3]));
  };
  // The sweep: from one side of the camera's heading to the other, at the given radius, at y = 0.
  for (const auto& [frame, bearing] : std::vector<std::pair<int, double>>{{20, 20.0}, {40, 0.0}, {60, -20.0}}) {
    const Vec3 centre = centreAt(frame);
    EXPECT_NEAR(Vec2(centre.x(), centre.z()).norm(), params.moving_object_radius_m, 1e-12) << frame;
    EXPECT_NEAR(centre.y(), 0.0, 1e-12) << frame;
    // Bearing from the room's centre relative to the camera's heading (the
    // camera itself is off-centre, so its own bearing of the object differs).
    const Vec3 heading = path[frame].T_wc.R.col(2);
    const double angle = std::atan2(centre.z(), centre.x()) - std::atan2(heading.z(), heading.x());
    EXPECT_NEAR(std::remainder(angle, 2 * M_PI) * 180.0 / M_PI, bearing, 1e-9) << frame;
  }
  // The camera sees it cross: its bearing from the camera changes sign.
  EXPECT_LT(bearingDeg(path[20].T_wc, centreAt(20)) * bearingDeg(path[60].T_wc, centreAt(60)), 0.0);
  // Still before and after its crossing.
  EXPECT_EQ((centreAt(0) - centreAt(20)).norm(), 0.0);
  EXPECT_EQ((centreAt(99) - centreAt(60)).norm(), 0.0);
  // Upright, width and height as asked, facing the room's centre.
  const std::array<Vec3, 4> c = movingObjectCorners(params, 40, aspect);
  EXPECT_NEAR((c[1] - c[0]).norm(), params.moving_object_width_m, 1e-12);
  EXPECT_NEAR((c[3] - c[0]).norm(), aspect * params.moving_object_width_m, 1e-12);
  EXPECT_NEAR((c[3] - c[0]).normalized().dot(Vec3::UnitY()), 1.0, 1e-12);  // image rows go down (+y)
  const Vec3 normal = (c[1] - c[0]).cross(c[3] - c[0]).normalized();
  const Vec3 centre = centreAt(40);
  EXPECT_NEAR(std::abs(normal.dot(Vec3(centre.x(), 0, centre.z()).normalized())), 1.0, 1e-12);
}

TEST(RoomLoopMovingObject, IsDrawnInColourAndDepthWhereItStands) {
  const RoomLoopParams params = roomWithMovingObject("moving_object_render");
  const std::vector<StampedPose> path = roomLoopPath(params);
  RoomLoopRenderer renderer(params);
  // Mid-crossing it is straight ahead of the room's centre through the camera:
  // on the principal point, radius - path radius away along the optical axis.
  renderer.setFrame(40);
  const SE3& T_wc = path[40].T_wc;
  const cv::Mat image = renderer.render(T_wc);
  const cv::Mat depth = renderer.renderDepth(T_wc);
  const cv::Point principal(cvRound(params.camera.cx), cvRound(params.camera.cy));
  EXPECT_EQ(image.at<cv::Vec3b>(principal), cv::Vec3b(0, 0, 255));
  EXPECT_NEAR(depth.at<float>(principal), params.moving_object_radius_m - params.path_radius_m, 2e-4);
  // Its 0.75 m x 0.375 m at 1.1 m cover about 358 x 179 px: a corner of the image is room.
  EXPECT_NEAR(depth.at<float>(0, 0), roomDepthAt(params, T_wc, 0, 0), 2e-4);
  EXPECT_NE(image.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));

  // At frame 0 it waits out of view: the picture is the static room's.
  RoomLoopParams static_room = params;
  static_room.moving_object_image.clear();
  RoomLoopRenderer static_renderer(static_room);
  renderer.setFrame(0);
  EXPECT_EQ(cv::norm(renderer.render(path[0].T_wc), static_renderer.render(path[0].T_wc), cv::NORM_INF), 0.0);
  // Mid-crossing the two differ.
  EXPECT_GT(cv::norm(image, static_renderer.render(T_wc), cv::NORM_INF), 0.0);
}

TEST(RoomLoopMovingObject, AnUnreadablePictureIsAnInputErrorNamingTheFile) {
  RoomLoopParams params = smallRoom(2);
  params.moving_object_image = (test::scratchDir("moving_object_bad") / "missing.png").string();
  try {
    RoomLoopRenderer renderer(params);
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("missing.png"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace vslam
