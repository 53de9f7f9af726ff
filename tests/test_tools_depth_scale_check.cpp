// tools/depth_scale_check.py on the synthetic room, whose depth is exact and
// whose ground truth is stamped exactly (30 Hz): the depth reads true, the
// clock offset is 0, and an offset put into the ground truth is found with
// the sign `vslam eval --offset` uses (docs/RGBD.md). Until 3 Dec 2026 the
// tool refused every pose of a 30 Hz ground truth (it bridged at most 20 ms)
// and ended in "no point passed the checks".
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "cli_test_support.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;
using test::contains;
using test::quoted;
using ToolRun = test::CliOutcome;

// Runs a command from the project root, its output in a scratch folder of its own.
ToolRun runTool(const std::string& command) { return test::runFromProjectRoot(command, test::callDir("depth_check_")); }

// A copy of `room` whose ground truth is restamped by `shift_s` (images linked, not copied).
fs::path restamped(const fs::path& room, const fs::path& to, double shift_s) {
  fs::remove_all(to);
  fs::create_directories(to);
  for (const char* entry : {"rgb", "depth"}) fs::create_directory_symlink(fs::absolute(room / entry), to / entry);
  for (const char* list : {"rgb.txt", "depth.txt"}) fs::copy_file(room / list, to / list);
  std::vector<StampedPose> poses = readTumTrajectory((room / "groundtruth.txt").string());
  for (StampedPose& pose : poses) pose.timestamp += shift_s;
  writeTumTrajectory((to / "groundtruth.txt").string(), poses);
  return to;
}

double offsetFound(const std::string& out) {
  std::smatch match;
  if (!std::regex_search(out, match, std::regex("time offset: ([-+][0-9.]+) ms"))) return NAN;
  return std::stod(match[1]);
}

double medianRatio(const std::string& out) {
  std::smatch match;
  if (!std::regex_search(out, match, std::regex("triangulated depth: median ([0-9.]+)"))) return NAN;
  return std::stod(match[1]);
}

TEST(DepthScaleCheck, TheSyntheticRoomReadsTrueAndItsClockOffsetIsFound) {
  const fs::path dir = test::scratchDir("tools_depth_scale_check");
  const fs::path room = dir / "room";
  fs::remove_all(room);
  const ToolRun synth = runTool(test::vslamBinary() + " synth --frames 200 --out " + quoted(room.string()));
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const std::string tool = "tools/depth_scale_check.py --intrinsics 525 525 319.5 239.5 --seq ";

  const ToolRun exact = runTool(tool + quoted(room.string()));
  ASSERT_EQ(exact.exit_code, 0) << exact.err;
  // Measured: 0.0 ms, ratio 0.9993 (the 16-bit depth's 0.2 mm steps and
  // triangulation keep it off 1 by less than 0.1 %).
  EXPECT_NEAR(offsetFound(exact.out), 0.0, 2.5) << exact.out;
  EXPECT_NEAR(medianRatio(exact.out), 1.0, 0.002) << exact.out;

  // Ground truth stamped 15 ms late: the estimate's (here the images') time
  // plus the offset is the ground truth's time. Measured: +15.0 ms.
  const ToolRun late = runTool(tool + quoted(restamped(room, dir / "late", 0.015).string()));
  ASSERT_EQ(late.exit_code, 0) << late.err;
  EXPECT_NEAR(offsetFound(late.out), 15.0, 2.5) << late.out;
  EXPECT_NEAR(medianRatio(late.out), 1.0, 0.002) << late.out;

  // Ground truth that does not cover the frames: said, with both time spans.
  const ToolRun apart = runTool(tool + quoted(restamped(room, dir / "apart", 100.0).string()));
  EXPECT_EQ(apart.exit_code, 1);
  EXPECT_TRUE(contains(apart.err, "no two frames with ground truth at their times are --min-baseline 0.2 m apart "
                                  "(colour frames 0.000-6.633 s, ground truth 100.000-106.633 s"))
      << apart.err;
}

}  // namespace
}  // namespace vslam
