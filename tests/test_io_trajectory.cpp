// TUM and KITTI trajectory files: round trips, the real files, and bad lines.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

std::string writeText(const std::string& scratch, const std::string& name, const std::string& text) {
  const fs::path path = test::scratchDir(scratch) / name;
  std::ofstream(path) << text;
  return path.string();
}

template <typename Read>
std::string errorOf(Read read) {
  try {
    read();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::vector<StampedPose> someTrajectory() {
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) {
    StampedPose pose;
    pose.timestamp = 1305031102.175304 + 0.033 * i;
    pose.T_wc = SE3(Quat(Eigen::AngleAxisd(0.3 * i, Vec3(1, 2, 3).normalized())), Vec3(1.25 * i, -0.5, 3.0 / (i + 1)));
    poses.push_back(pose);
  }
  return poses;
}

TEST(TrajectoryIo, TumRoundTrip) {
  const std::vector<StampedPose> poses = someTrajectory();
  const std::string path = (test::scratchDir("traj_tum") / "t.txt").string();
  writeTumTrajectory(path, poses);
  const std::vector<StampedPose> back = readTumTrajectory(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp, poses[i].timestamp, 1e-6);
    EXPECT_LT((back[i].T_wc.t - poses[i].T_wc.t).norm(), 1e-8);  // 9 significant digits
    EXPECT_LT((back[i].T_wc.R - poses[i].T_wc.R).norm(), 1e-8);
  }
  std::ifstream in(path);
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(first.substr(0, 18), "1305031102.175304 ");
}

TEST(TrajectoryIo, KittiRoundTrip) {
  const std::vector<StampedPose> poses = someTrajectory();
  const std::string path = (test::scratchDir("traj_kitti") / "t.txt").string();
  writeKittiTrajectory(path, poses);
  const std::vector<StampedPose> by_index = readKittiTrajectory(path);
  ASSERT_EQ(by_index.size(), poses.size());
  EXPECT_DOUBLE_EQ(by_index[3].timestamp, 3.0);
  EXPECT_LT((by_index[3].T_wc.matrix() - poses[3].T_wc.matrix()).norm(), 1e-8);
  const std::vector<StampedPose> timed = readKittiTrajectory(path, {0.0, 0.1, 0.2, 0.3, 0.4});
  EXPECT_DOUBLE_EQ(timed[4].timestamp, 0.4);
}

TEST(TrajectoryIo, RealGroundTruthFiles) {
  const auto fr1 = readTumTrajectory((test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string());
  ASSERT_EQ(fr1.size(), 3000u);
  // "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986"
  EXPECT_DOUBLE_EQ(fr1[0].timestamp, 1305031098.6659);
  EXPECT_DOUBLE_EQ(fr1[0].T_wc.t.z(), 1.6380);
  const Quat q = fr1[0].T_wc.quaternion();
  const double sign = q.w() < 0 ? -1.0 : 1.0;  // q and -q are the same rotation
  const double n = std::sqrt(0.6132 * 0.6132 + 0.5962 * 0.5962 + 0.3311 * 0.3311 + 0.3986 * 0.3986);
  EXPECT_NEAR(sign * q.x(), -0.6132 / n, 1e-12);
  EXPECT_NEAR(sign * q.w(), 0.3986 / n, 1e-12);

  const auto kitti = readKittiTrajectory((test::sharedData() / "kitti" / "poses" / "00.txt").string());
  ASSERT_EQ(kitti.size(), 200u);
  EXPECT_DOUBLE_EQ(kitti[1].T_wc.t.x(), -4.690294e-02);
  EXPECT_DOUBLE_EQ(kitti[1].T_wc.R(0, 1), 5.272628e-04);
}

TEST(TrajectoryIoErrors, MissingFile) {
  const std::string message = errorOf([] { readTumTrajectory("/nonexistent/traj.txt"); });
  EXPECT_EQ(message, "/nonexistent/traj.txt: cannot open file");
}

TEST(TrajectoryIoErrors, MalformedTumLines) {
  std::string path = writeText("traj_bad_tum", "a.txt", "# header\n1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0\n");
  EXPECT_EQ(errorOf([&] { readTumTrajectory(path); }),
            path + ":3: expected 8 fields 'timestamp tx ty tz qx qy qz qw', found 7");
  path = writeText("traj_bad_tum", "b.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 zero 0 0 0 0 1\n");
  EXPECT_EQ(errorOf([&] { readTumTrajectory(path); }), path + ":2: ty 'zero' is not a number");
  path = writeText("traj_bad_tum", "c.txt", "1.0 0 0 0 0 0 0 0\n");
  EXPECT_EQ(errorOf([&] { readTumTrajectory(path); }), path + ":1: quaternion (qx qy qz qw) has norm 0.000000, not 1");
  path = writeText("traj_bad_tum", "d.txt", "1.0 0 0 0 0 0 0 1\n0.9 0 0 0 0 0 0 1\n");
  EXPECT_EQ(errorOf([&] { readTumTrajectory(path); }),
            path + ":2: timestamp 0.900000 does not increase (previous line has 1.000000)");
  path = writeText("traj_bad_tum", "e.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(errorOf([&] { readTumTrajectory(path); }).find(":1: expected 8 fields"), std::string::npos);
  EXPECT_NE(errorOf([&] { readTumTrajectory(path); }).find("a KITTI trajectory?"), std::string::npos);
}

TEST(TrajectoryIoErrors, MalformedKittiLines) {
  std::string path = writeText("traj_bad_kitti", "a.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_EQ(errorOf([&] { readKittiTrajectory(path); }),
            path + ":2: expected 12 numbers (3x4 matrix [R|t], row-major), found 11");
  path = writeText("traj_bad_kitti", "b.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 x\n");
  EXPECT_EQ(errorOf([&] { readKittiTrajectory(path); }), path + ":2: matrix entry 12 'x' is not a number");
  path = writeText("traj_bad_kitti", "c.txt", "2 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_EQ(errorOf([&] { readKittiTrajectory(path); }), path + ":1: the 3x3 part is not a rotation matrix");
  path = writeText("traj_bad_kitti", "d.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_EQ(errorOf([&] {
              readKittiTrajectory(path, {0.0, 0.1});
            }),
            path + ": has 1 poses but there are 2 timestamps (one pose per frame expected)");
}

}  // namespace
}  // namespace vslam
