// Sequence readers on the real TUM and KITTI data in ../shared/data, and every
// kind of bad input on small folders made in the scratch directory.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/io/sequence_catalog.hpp"
#include "vslam/io/sequence_files.hpp"
#include "vslam/io/text_table.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

SequenceOptions sharedRoot() {
  SequenceOptions options;
  options.data_root = test::sharedData().string();
  return options;
}

void writeText(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// A 3-frame TUM folder with real (tiny) images and 16-bit depth.
fs::path makeTumFolder(const std::string& scratch, const std::string& folder_name) {
  const fs::path root = test::scratchDir(scratch) / folder_name;
  fs::create_directories(root / "rgb");
  fs::create_directories(root / "depth");
  std::string rgb = "# color images\n", depth = "# depth\n";
  for (int i = 0; i < 3; ++i) {
    const std::string stamp = std::to_string(100 + i) + ".000000";
    cv::imwrite((root / "rgb" / (stamp + ".png")).string(), cv::Mat(6, 8, CV_8UC3, cv::Scalar(10, 20, 30 + i)));
    cv::imwrite((root / "depth" / (stamp + ".png")).string(), cv::Mat(6, 8, CV_16UC1, cv::Scalar(5000 * (i + 1))));
    rgb += stamp + " rgb/" + stamp + ".png\n";
    depth += std::to_string(100 + i) + ".010000 depth/" + stamp + ".png\n";
  }
  writeText(root / "rgb.txt", rgb);
  writeText(root / "depth.txt", depth);
  return root;
}

// ORB-SLAM2 settings without image size: the reader takes it from the first image.
std::string tinyCameraSettings(const std::string& scratch) {
  const fs::path path = test::scratchDir(scratch + "_config") / "tiny.yaml";
  writeText(path, "%YAML:1.0\nCamera.fx: 10.0\nCamera.fy: 10.0\nCamera.cx: 4.0\nCamera.cy: 3.0\n");
  return path.string();
}

std::string openError(const std::string& spec, const SequenceOptions& options = {}) {
  try {
    openSequence(spec, options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(Sequence, TumFr1XyzFromTheSharedData) {
  const Sequence seq = openSequence("tum/fr1_xyz", sharedRoot());
  EXPECT_EQ(seq.name, "tum/fr1_xyz");
  EXPECT_EQ(seq.kind, SequenceKind::Tum);
  EXPECT_EQ(fs::path(seq.root).filename(), "rgbd_dataset_freiburg1_xyz");
  ASSERT_EQ(seq.frames.size(), 798u);
  EXPECT_EQ(seq.frames[0].index, 0);
  EXPECT_DOUBLE_EQ(seq.frames[0].timestamp, 1305031102.175304);
  EXPECT_EQ(seq.frames[0].image_path, seq.root + "/rgb/1305031102.175304.jpg");
  EXPECT_DOUBLE_EQ(seq.frames.back().timestamp, 1305031128.747363);
  // associate.py's greedy one-to-one rule leaves 6 colour frames of fr1_xyz without a
  // depth image closer than 0.02 s (checked with an independent Python run of the rule).
  EXPECT_EQ(seq.framesWithDepth(), 792);
  EXPECT_FALSE(seq.hasDepth());
  EXPECT_EQ(seq.frames[0].depth_path, seq.root + "/depth/1305031102.160407.png");
  EXPECT_EQ(seq.frames[2].depth_path, "");  // 1305031102.243211: both near depth images taken by closer frames
  ASSERT_EQ(seq.groundtruth.size(), 3000u);
  EXPECT_TRUE(seq.hasGroundTruth());
  EXPECT_DOUBLE_EQ(seq.groundtruth[0].timestamp, 1305031098.6659);
  EXPECT_DOUBLE_EQ(seq.groundtruth[0].T_wc.t.x(), 1.3563);
  EXPECT_EQ(seq.config.camera.name, "tum_fr1");
  EXPECT_DOUBLE_EQ(seq.config.camera.fx, 517.306408);
  EXPECT_DOUBLE_EQ(seq.config.camera.k1, 0.262383);

  const cv::Mat color = seq.loadColor(0);
  EXPECT_EQ(color.type(), CV_8UC3);
  EXPECT_EQ(color.cols, 640);
  EXPECT_EQ(color.rows, 480);
  EXPECT_EQ(seq.loadGray(0).type(), CV_8UC1);
  const cv::Mat depth = seq.loadDepthMeters(0, color.size());
  ASSERT_EQ(depth.type(), CV_32F);
  cv::Mat valid = depth > 0;
  const double mean_depth = cv::mean(depth, valid)[0];
  EXPECT_GT(mean_depth, 0.5);  // a desk seen from about a metre
  EXPECT_LT(mean_depth, 3.0);
}

TEST(Sequence, TumFr3TeddyAndLongOffice) {
  const Sequence teddy = openSequence("tum/fr3_teddy", sharedRoot());
  EXPECT_EQ(teddy.frames.size(), 200u);
  EXPECT_EQ(teddy.config.camera.name, "tum_fr3");
  EXPECT_EQ(teddy.groundtruth.size(), 8080u);
  const Sequence office = openSequence("tum/fr3_long_office_household", sharedRoot());
  EXPECT_EQ(office.frames.size(), 16u);
  EXPECT_EQ(office.groundtruth.size(), 8710u);
  EXPECT_EQ(office.loadColor(15).cols, 640);  // PNG colour
}

TEST(Sequence, KittiOdometry00) {
  const Sequence seq = openSequence("kitti/00", sharedRoot());
  EXPECT_EQ(seq.kind, SequenceKind::Kitti);
  ASSERT_EQ(seq.frames.size(), 200u);
  EXPECT_EQ(fs::path(seq.frames[7].image_path).filename(), "000007.jpg");
  EXPECT_DOUBLE_EQ(seq.frames[7].timestamp, 0.7);
  ASSERT_EQ(seq.groundtruth.size(), 200u);
  EXPECT_DOUBLE_EQ(seq.groundtruth[7].timestamp, 0.7);
  EXPECT_DOUBLE_EQ(seq.groundtruth[1].T_wc.t.z(), 8.586941e-01);
  EXPECT_EQ(seq.config.camera.name, "kitti_00-02");
  EXPECT_DOUBLE_EQ(seq.config.camera.fx, 718.856);
  EXPECT_DOUBLE_EQ(seq.config.camera.cx, 607.1928);
  EXPECT_DOUBLE_EQ(seq.config.camera.cy, 185.2157);
  EXPECT_NEAR(seq.config.camera.bf, 386.1448, 1e-9);
  EXPECT_NEAR(seq.config.camera.baseline(), 386.1448 / 718.856, 1e-12);
  EXPECT_FALSE(seq.hasDepth());
  const cv::Mat gray = seq.loadGray(0);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.cols, 1241);
  EXPECT_EQ(gray.rows, 376);
  EXPECT_EQ(seq.loadColor(0).type(), CV_8UC3);
}

// Issue 15: the Bonn RGB-D Dynamic sequence in ../shared by its name, with its
// own camera; before, only a folder path with --config config/bonn.yaml worked.
TEST(Sequence, BonnCrowdByNameWithItsCamera) {
  const Sequence crowd = openSequence("bonn/crowd", sharedRoot());
  EXPECT_EQ(crowd.kind, SequenceKind::Tum);
  EXPECT_EQ(crowd.frames.size(), 300u);
  EXPECT_TRUE(crowd.hasDepth());
  EXPECT_EQ(crowd.config.camera.name, "bonn");
  EXPECT_DOUBLE_EQ(crowd.config.camera.fx, 542.822841);
  EXPECT_DOUBLE_EQ(crowd.config.camera.k1, 0.039903);
  EXPECT_EQ(crowd.frames_expected, 0);  // not catalogued
  EXPECT_FALSE(crowd.groundtruth.empty());
  // The folder by path takes the same camera from its name.
  EXPECT_EQ(openSequence(crowd.root, sharedRoot()).config.camera.name, "bonn");
}

// Bonn's groundtruth.txt gives its markers' pose; the sequence hands out the
// camera's, T_world_markers * (config/bonn.yaml's camera in the markers). The
// markers are turned 173 degrees from the camera, so read as the camera's
// they made every rotation error (RPE) false (10.3 deg/s where it is 0.6).
TEST(Sequence, BonnGroundTruthIsTheCamerasNotTheMarkers) {
  const Sequence crowd = openSequence("bonn/crowd", sharedRoot());
  const std::vector<StampedPose> markers = readTumTrajectory(crowd.groundtruth_path);
  ASSERT_EQ(crowd.groundtruth.size(), markers.size());
  ASSERT_TRUE(crowd.config.evaluation.groundtruth_camera_in_body.has_value());
  const SE3& camera_in_markers = *crowd.config.evaluation.groundtruth_camera_in_body;
  for (size_t i : {size_t{0}, markers.size() / 2, markers.size() - 1}) {
    const SE3 expected = markers[i].T_wc * camera_in_markers;
    EXPECT_DOUBLE_EQ(crowd.groundtruth[i].timestamp, markers[i].timestamp);
    EXPECT_LT((crowd.groundtruth[i].T_wc.R - expected.R).cwiseAbs().maxCoeff(), 1e-12) << i;
    EXPECT_LT((crowd.groundtruth[i].T_wc.t - expected.t).norm(), 1e-12) << i;
  }
  // The camera's and the markers' rotations differ by the offset's 172.7 degrees.
  const double turn = Eigen::AngleAxisd(markers[0].T_wc.R.transpose() * crowd.groundtruth[0].T_wc.R).angle();
  EXPECT_NEAR(turn * 180 / M_PI, 172.73, 0.01);
  // TUM's ground truth is the camera's own: read as written.
  const Sequence xyz = openSequence("tum/fr1_xyz", sharedRoot());
  const std::vector<StampedPose> written = readTumTrajectory(xyz.groundtruth_path);
  EXPECT_EQ((xyz.groundtruth[10].T_wc.t - written[10].T_wc.t).norm(), 0.0);
  EXPECT_EQ((xyz.groundtruth[10].T_wc.R - written[10].T_wc.R).norm(), 0.0);
}

TEST(Sequence, CalibrationP0OverridesTheConfig) {
  // A KITTI folder whose calib.txt differs from config/kitti_00-02.yaml.
  const fs::path data = test::scratchDir("kitti_calib");
  const fs::path root = data / "kitti" / "sequences" / "01";
  fs::create_directories(root / "image_0");
  // Images of another size than config/kitti_00-02.yaml's 1241x376: the sequence's files win.
  cv::imwrite((root / "image_0" / "000000.png").string(), cv::Mat(370, 1226, CV_8UC1, cv::Scalar(0)));
  cv::imwrite((root / "image_0" / "000001.png").string(), cv::Mat(370, 1226, CV_8UC1, cv::Scalar(0)));
  writeText(root / "times.txt", "0.0\n0.1\n");
  writeText(root / "calib.txt", "P0: 700 0 600 0 0 701 180 0 0 0 1 0\n");
  SequenceOptions options;
  options.data_root = data.string();
  const Sequence seq = openSequence("kitti/1", options);
  EXPECT_EQ(seq.frames.size(), 2u);
  EXPECT_DOUBLE_EQ(seq.config.camera.fx, 700);
  EXPECT_DOUBLE_EQ(seq.config.camera.fy, 701);
  EXPECT_DOUBLE_EQ(seq.config.camera.cx, 600);
  EXPECT_DOUBLE_EQ(seq.config.camera.cy, 180);
  EXPECT_EQ(seq.config.camera.width, 1226);
  EXPECT_EQ(seq.config.camera.height, 370);
  EXPECT_FALSE(seq.hasGroundTruth());  // no poses/01.txt: runs without ground truth
  EXPECT_EQ(seq.loadGray(1).cols, 1226);
}

TEST(Sequence, FolderTakesTheCameraFromItsName) {
  const std::string folder = test::tumSequence("freiburg1_xyz").string();
  const Sequence seq = openSequence(folder, {});
  EXPECT_EQ(seq.name, folder);
  EXPECT_EQ(seq.config.camera.name, "tum_fr1");
  EXPECT_EQ(seq.frames.size(), 798u);
}

TEST(Sequence, FolderWithConfigAndImageSizeFromTheFirstImage) {
  const fs::path root = makeTumFolder("tum_config", "my_recording");
  // No camera in the name and no --config: say so.
  const std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, root.string())) << message;
  EXPECT_TRUE(contains(message, "--config")) << message;

  SequenceOptions options;
  options.config_path = tinyCameraSettings("tum_config");
  const Sequence seq = openSequence(root.string(), options);
  EXPECT_EQ(seq.frames.size(), 3u);
  EXPECT_EQ(seq.config.camera.width, 8);
  EXPECT_EQ(seq.config.camera.height, 6);
  EXPECT_TRUE(seq.hasDepth());
  EXPECT_FALSE(seq.hasGroundTruth());
  EXPECT_EQ(seq.groundtruth_path, "");
  const cv::Mat depth = seq.loadDepthMeters(1, cv::Size(8, 6));
  ASSERT_EQ(depth.type(), CV_32F);
  EXPECT_FLOAT_EQ(depth.at<float>(0, 0), 2.0f);  // 10000 raw / 5000 per metre
  EXPECT_EQ(seq.loadColor(2).at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 32));
}

TEST(Sequence, MonocularFolderNeedsOnlyRgbTxt) {
  const fs::path root = makeTumFolder("tum_mono", "rgbd_dataset_freiburg2_mine");
  fs::remove(root / "depth.txt");
  SequenceOptions options;
  options.config_path = tinyCameraSettings("tum_mono");
  const Sequence seq = openSequence(root.string(), options);
  EXPECT_EQ(seq.frames.size(), 3u);
  EXPECT_EQ(seq.framesWithDepth(), 0);
  const std::string depth_txt = (root / "depth.txt").string();
  try {
    seq.loadDepthMeters(0, cv::Size(8, 6));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), depth_txt)) << e.what();
  }
}

TEST(Sequence, ColourAndDepthPairLikeAssociatePy) {
  // rgb 0.000 0.030 0.060; depth 0.015 0.035 0.100: 0.030-0.035 (0.005) wins first,
  // so 0.000 pairs with 0.015, and 0.060 has nothing within 0.02 s.
  const fs::path root = test::scratchDir("tum_pairing") / "rgbd_dataset_freiburg1_pairs";
  writeText(root / "rgb.txt", "0.000 rgb/a.png\n0.030 rgb/b.png\n0.060 rgb/c.png\n");
  writeText(root / "depth.txt", "0.015 depth/a.png\n0.035 depth/b.png\n0.100 depth/c.png\n");
  const Sequence seq = openSequence(root.string(), {});
  EXPECT_EQ(seq.frames[0].depth_path, (root / "depth/a.png").string());
  EXPECT_EQ(seq.frames[1].depth_path, (root / "depth/b.png").string());
  EXPECT_EQ(seq.frames[2].depth_path, "");
}

// ---- bad input: one-line errors naming the file, the line, and the problem ----

TEST(SequenceErrors, MissingRgbTxt) {
  const fs::path root = test::scratchDir("err_no_rgb") / "rgbd_dataset_freiburg1_empty";
  fs::create_directories(root);
  const std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "rgb.txt").string() + ": missing")) << message;
}

TEST(SequenceErrors, FolderOfNeitherLayout) {
  const fs::path root = test::scratchDir("err_layout");
  const std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "rgb.txt").string())) << message;
  EXPECT_TRUE(contains(message, "neither")) << message;
}

TEST(SequenceErrors, MalformedRgbLine) {
  const fs::path root = test::scratchDir("err_rgb_line") / "rgbd_dataset_freiburg1_bad";
  writeText(root / "rgb.txt", "# comment\n1.0 rgb/a.png\n2.0x rgb/b.png\n");
  std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "rgb.txt").string() + ":3: timestamp '2.0x' is not a number")) << message;

  writeText(root / "rgb.txt", "1.0 rgb/a.png\n2.0\n");
  message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "rgb.txt").string() + ":2: expected 'timestamp path', found 1 fields"))
      << message;
}

TEST(SequenceErrors, TimestampsGoingBackwards) {
  const fs::path root = test::scratchDir("err_backwards") / "rgbd_dataset_freiburg1_bad";
  writeText(root / "rgb.txt", "1.0 rgb/a.png\n2.0 rgb/b.png\n\n1.5 rgb/c.png\n");
  std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "rgb.txt").string() + ":4: timestamp 1.500000 goes backwards")) << message;

  writeText(root / "rgb.txt", "1.0 rgb/a.png\n");
  writeText(root / "depth.txt", "1.0 depth/a.png\n0.5 depth/b.png\n");
  message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "depth.txt").string() + ":2: timestamp 0.500000 goes backwards")) << message;
}

TEST(SequenceErrors, MissingImageFailsWhenLoadedAndNamesIt) {
  const fs::path root = makeTumFolder("err_missing_image", "rgbd_dataset_freiburg1_gap");
  const fs::path gone = root / "rgb" / "101.000000.png";
  fs::remove(gone);
  SequenceOptions options;
  options.config_path = tinyCameraSettings("err_missing_image");
  const Sequence seq = openSequence(root.string(), options);  // the index files are fine
  EXPECT_NO_THROW(seq.loadColor(0));
  try {
    seq.loadColor(1);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_TRUE(contains(message, gone.string() + ": image file does not exist")) << message;
    EXPECT_TRUE(contains(message, (root / "rgb.txt").string() + ":3")) << message;  // the line listing it
  }
}

TEST(SequenceErrors, UnreadableImage) {
  const fs::path root = makeTumFolder("err_unreadable", "rgbd_dataset_freiburg1_text");
  const fs::path fake = root / "rgb" / "102.000000.png";
  writeText(fake, "this is not a PNG\n");
  const Sequence seq = openSequence(root.string(), {});
  try {
    seq.loadGray(2);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), fake.string() + ": cannot decode image")) << e.what();
  }
}

TEST(SequenceErrors, ImageOfAnotherSizeThanTheCamera) {
  const fs::path root = makeTumFolder("err_size", "rgbd_dataset_freiburg1_small");  // 8x6 images, tum_fr1 is 640x480
  const Sequence seq = openSequence(root.string(), {});
  try {
    seq.loadColor(0);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "image is 8x6 but camera 'tum_fr1'")) << e.what();
  }
}

TEST(SequenceErrors, DepthThatIsNot16Bit) {
  const fs::path root = makeTumFolder("err_depth8", "my_recording");
  const fs::path depth = root / "depth" / "100.000000.png";
  cv::imwrite(depth.string(), cv::Mat(6, 8, CV_8UC1, cv::Scalar(7)));
  SequenceOptions options;
  options.config_path = tinyCameraSettings("err_depth8");
  const Sequence seq = openSequence(root.string(), options);
  try {
    seq.loadDepthMeters(0, cv::Size(8, 6));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), depth.string() + ": depth image is not a single-channel 16-bit PNG")) << e.what();
  }
}

// A depth image of another size than its colour image cannot be registered to
// it: the error names both files and both sizes (issue 13).
TEST(SequenceErrors, DepthOfAnotherSizeThanItsColourImage) {
  const fs::path root = makeTumFolder("err_depth_size", "my_recording");
  const fs::path depth = root / "depth" / "100.000000.png";
  cv::imwrite(depth.string(), cv::Mat(3, 4, CV_16UC1, cv::Scalar(5000)));
  SequenceOptions options;
  options.config_path = tinyCameraSettings("err_depth_size");
  const Sequence seq = openSequence(root.string(), options);
  const cv::Mat colour = seq.loadColor(0);
  try {
    seq.loadDepthMeters(0, colour.size());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), depth.string() + ": depth image is 4x3 but its colour image ")) << e.what();
    EXPECT_TRUE(contains(e.what(), seq.frames[0].image_path + " is 8x6")) << e.what();
  }
}

TEST(SequenceErrors, MalformedGroundTruthLine) {
  const fs::path root = test::scratchDir("err_gt") / "rgbd_dataset_freiburg3_bad";
  writeText(root / "rgb.txt", "1.0 rgb/a.png\n");
  writeText(root / "groundtruth.txt", "# ground truth\n1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 1\n");
  const std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "groundtruth.txt").string() + ":3: expected 8 fields")) << message;
}

TEST(SequenceErrors, MalformedKittiPoseLine) {
  const fs::path data = test::scratchDir("err_kitti_pose");
  const fs::path root = data / "kitti" / "sequences" / "00";
  fs::create_directories(root / "image_0");
  cv::imwrite((root / "image_0" / "000000.png").string(), cv::Mat(376, 1241, CV_8UC1, cv::Scalar(0)));
  writeText(root / "times.txt", "0.0\n");
  writeText(root / "calib.txt", "P0: 718.856 0 607.1928 0 0 718.856 185.2157 0 0 0 1 0\n");
  writeText(data / "kitti" / "poses" / "00.txt", "1 0 0 0 0 1 0 0 0 0 1 nan?\n");
  SequenceOptions options;
  options.data_root = data.string();
  const std::string message = openError("kitti/00", options);
  EXPECT_TRUE(contains(message, (data / "kitti/poses/00.txt").string() + ":1: matrix entry 12 'nan?' is not a number"))
      << message;
}

TEST(SequenceErrors, KittiCalibrationWithoutP0) {
  const fs::path root = test::scratchDir("err_kitti_calib") / "05";
  fs::create_directories(root / "image_0");
  cv::imwrite((root / "image_0" / "000000.png").string(), cv::Mat(376, 1241, CV_8UC1, cv::Scalar(0)));
  writeText(root / "times.txt", "0.0\n");
  writeText(root / "calib.txt", "P1: 718.856 0 607.1928 -386.1448 0 718.856 185.2157 0 0 0 1 0\n");
  std::string message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "calib.txt").string() + ": no 'P0:' line")) << message;

  writeText(root / "times.txt", "0.0\n0.1\n");  // one image only
  message = openError(root.string());
  EXPECT_TRUE(contains(message, (root / "times.txt").string() + ": lists 2 timestamps but")) << message;
}

TEST(SequenceErrors, UnknownTumName) {
  const std::string message = openError("tum/not_a_sequence");
  EXPECT_TRUE(contains(message, "tum/not_a_sequence: unknown TUM RGB-D sequence")) << message;
  EXPECT_TRUE(contains(message, "tum/fr1_xyz")) << message;
  EXPECT_TRUE(contains(openError("kitti/99"), "kitti/99: unknown KITTI odometry sequence"));
  EXPECT_TRUE(contains(openError("no/such/folder"), "no/such/folder: no such folder"));
  EXPECT_TRUE(contains(openError("bonn/Crowd!"), "bonn/Crowd!: not a Bonn RGB-D Dynamic sequence name"));
}

TEST(SequenceErrors, NotFoundSaysWhereItLookedAndFallsBackToNothing) {
  // fr2_desk is in no data root here: the error must list the scratch root and the
  // defaults, say how to fetch it, and never hand back another sequence.
  const fs::path empty = test::scratchDir("err_not_found");
  SequenceOptions options;
  options.data_root = empty.string();
  try {
    openSequence("tum/fr2_desk", options);
    ADD_FAILURE() << "no error";
  } catch (const SequenceNotFound& e) {
    const std::string message = e.what();
    EXPECT_TRUE(contains(message, "tum/fr2_desk: sequence not found")) << message;
    EXPECT_TRUE(contains(message, (empty / "tum" / "rgbd_dataset_freiburg2_desk").string())) << message;
    EXPECT_TRUE(contains(message, "../shared/data/tum/rgbd_dataset_freiburg2_desk")) << message;
    EXPECT_TRUE(contains(message, "tools/fetch_dataset.sh tum/fr2_desk")) << message;
    EXPECT_TRUE(contains(message, "freiburg2/rgbd_dataset_freiburg2_desk.tgz")) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  try {
    openSequence("bonn/balloon", options);
    ADD_FAILURE() << "no error";
  } catch (const SequenceNotFound& e) {
    EXPECT_TRUE(contains(e.what(), (empty / "bonn" / "rgbd_bonn_balloon").string())) << e.what();
    EXPECT_TRUE(contains(e.what(), "rgbd_dynamic2019/rgbd_bonn_balloon.zip")) << e.what();
  }
  try {
    openSequence("kitti/05", options);
    ADD_FAILURE() << "no error";
  } catch (const SequenceNotFound& e) {
    EXPECT_TRUE(contains(e.what(), (empty / "kitti" / "sequences" / "05").string())) << e.what();
    EXPECT_TRUE(contains(e.what(), "registration")) << e.what();
  }
}

TEST(SequenceSearch, DataRootComesFirstThenTheDefaults) {
  SequenceOptions options;
  options.data_root = "/somewhere";
  const std::vector<std::string> roots = dataSearchRoots(options);
  ASSERT_GE(roots.size(), 3u);
  EXPECT_EQ(roots.front(), "/somewhere");
  EXPECT_EQ(roots[roots.size() - 2], "./data");
  EXPECT_EQ(roots.back(), "../shared/data");
  EXPECT_EQ(fetchDataRoot(options), "/somewhere");
}

TEST(SequenceCatalog, EveryTumSequenceMapsToItsArchiveAndCamera) {
  EXPECT_EQ(tumSequences().size(), 48u);  // 9 freiburg1 + 19 freiburg2 + 20 freiburg3
  const auto office = findTumSequence("fr3_long_office_household");
  ASSERT_TRUE(office);
  EXPECT_EQ(office->archive_name, "rgbd_dataset_freiburg3_long_office_household");
  EXPECT_EQ(office->camera, "tum_fr3");
  EXPECT_EQ(tumArchiveUrl(*office),
            "https://cvg.cit.tum.de/rgbd/dataset/freiburg3/rgbd_dataset_freiburg3_long_office_household.tgz");
  EXPECT_EQ(findTumSequence("freiburg2_pioneer_slam3")->camera, "tum_fr2");
  EXPECT_EQ(findTumSequence("rgbd_dataset_freiburg1_360")->short_name, "fr1_360");
  EXPECT_FALSE(findTumSequence("fr1_long_office_household"));
  EXPECT_EQ(kittiCameraFor(2), "kitti_00-02");
  EXPECT_EQ(kittiCameraFor(3), "kitti_03");
  EXPECT_EQ(kittiCameraFor(4), "kitti_04-12");
  EXPECT_EQ(kittiCameraFor(12), "kitti_04-12");
}

TEST(SequenceCatalog, FetchScriptKnowsTheSameNames) {
  const fs::path listing = test::scratchDir("catalog") / "list.txt";
  const std::string command =
      "bash '" + (test::sourceDir() / "tools" / "fetch_dataset.sh").string() + "' --list > '" + listing.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(listing);
  std::vector<std::string> from_script;
  for (std::string line; std::getline(in, line);) from_script.push_back(line);
  std::vector<std::string> from_catalog;
  for (const TumSequenceInfo& info : tumSequences()) from_catalog.push_back("tum/" + info.short_name);
  EXPECT_EQ(from_script, from_catalog);
}

// Found by the kitti_calib fuzz target (docs/FUZZING.md): a line holding only
// a form feed passed as a row with no fields, and calib.txt's reader looked at
// its first field (a null dereference).
TEST(SequenceFiles, LinesOfOnlyFormFeedsOrVerticalTabsAreBlank) {
  std::istringstream calib("\f\nP0: 718 0 607 0 0 718 185 0 0 0 1 0\n \v \n\f# comment\n");
  const std::vector<TextRow> rows = readTextRows(calib, "calib.txt");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].line, 2);
  PinholeCamera camera;
  parseKittiCalibration(rows, "calib.txt", camera);
  EXPECT_EQ(camera.fx, 718);
  EXPECT_EQ(camera.cy, 185);

  std::istringstream times("\f\n");
  try {
    parseKittiTimes(readTextRows(times, "times.txt"), "times.txt");
    ADD_FAILURE() << "an empty times.txt was accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "times.txt: lists no timestamps");
  }
}

}  // namespace
}  // namespace vslam
