// tools/depth_scale_check.py on the synthetic room, whose depth is exact and
// whose ground truth is stamped exactly (30 Hz): the depth reads true, the
// clock offset is 0, and an offset put into the ground truth is found with
// the sign `vslam eval --offset` uses (docs/RGBD.md). Until 3 Dec 2026 the
// tool refused every pose of a 30 Hz ground truth (it bridged at most 20 ms)
// and ended in "no point passed the checks".
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

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

// The synthetic room of 200 frames, rendered afresh into `room`.
::testing::AssertionResult renderRoom(const fs::path& room) {
  fs::remove_all(room);
  const ToolRun synth = runTool(test::vslamBinary() + " synth --frames 200 --out " + quoted(room.string()));
  if (synth.exit_code != 0) return ::testing::AssertionFailure() << "vslam synth failed: " << synth.err;
  return ::testing::AssertionSuccess();
}

TEST(DepthScaleCheck, TheSyntheticRoomReadsTrueAndItsClockOffsetIsFound) {
  const fs::path dir = test::scratchDir("tools_depth_scale_check");
  const fs::path room = dir / "room";
  ASSERT_TRUE(renderRoom(room));
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

// --depth-bins: the bins printed are the ones given, with the decimals the
// edges need (0.75 is not printed as 0.8), and a list that does not increase
// is refused before any work, naming the option.
TEST(DepthScaleCheck, PrintsTheDepthBinsGivenAndRefusesABadList) {
  const fs::path room = test::scratchDir("tools_depth_scale_check_bins") / "room";
  ASSERT_TRUE(renderRoom(room));
  const std::string tool = "tools/depth_scale_check.py --intrinsics 525 525 319.5 239.5 --time-offset 0 --seq " +
                           quoted(room.string());

  const ToolRun binned = runTool(tool + " --depth-bins 0 0.75 1.5 3 6 12");
  ASSERT_EQ(binned.exit_code, 0) << binned.err;
  const std::regex bin_line("depth ([0-9.]+)-([0-9.]+) m: median ([0-9.]+) over [0-9]+ points");
  const std::vector<std::string> edges = {"0.00", "0.75", "1.50", "3.00", "6.00", "12.00"};
  int bins = 0;
  for (std::sregex_iterator it(binned.out.begin(), binned.out.end(), bin_line), end; it != end; ++it, ++bins) {
    const auto lo = std::find(edges.begin(), edges.end(), (*it)[1].str());
    ASSERT_NE(lo, edges.end()) << it->str();
    ASSERT_NE(lo + 1, edges.end()) << it->str();
    EXPECT_EQ((*it)[2].str(), *(lo + 1)) << it->str();
  }
  EXPECT_GT(bins, 0) << binned.out;

  const ToolRun bad = runTool(tool + " --depth-bins 1 0.5");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_TRUE(contains(bad.err, "--depth-bins 1 0.5: give at least two edges, >= 0 and increasing")) << bad.err;
}

}  // namespace
}  // namespace vslam
