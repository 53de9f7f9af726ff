// Issue 15 through the `vslam` binary: --detect-every and its sibling options
// refuse bad values in one line with exit code 2, and a run that detects every
// N-th frame runs the network on exactly those frames.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

TEST(DetectRate, BadOptionValuesAreOneLineInputErrors) {
  const struct {
    std::string option, message;
  } cases[] = {
      {"--detect-every 0", "error: --detect-every: expected a whole number >= 1, 'keyframes' or 'auto', not '0'"},
      {"--detect-every often", "error: --detect-every: expected a whole number >= 1, 'keyframes' or 'auto', not 'often'"},
      {"--box-filter fast", "error: --box-filter: expected 'paper', 'reuse' or 'label', not 'fast'"},
      {"--max-box-age -3", "error: --max-box-age: must be >= 0, not -3"},
      {"--dnn-threads -1", "error: --dnn-threads: must be >= 0, not -1"},
  };
  for (const auto& c : cases) {
    const fs::path dir = test::callDir("detect_rate_");
    const test::CliOutcome outcome =
        test::runFromProjectRoot(test::vslamBinary() + " run --seq tum/fr1_xyz --max-frames 5 --no-render " + c.option +
                                     " --out " + test::quoted((dir / "run").string()),
                                 dir);
    EXPECT_EQ(outcome.exit_code, 2) << c.option << "\n" << outcome.err;
    const std::vector<std::string> lines = test::errorLines(outcome.err);
    ASSERT_EQ(lines.size(), 1u) << c.option << "\n" << outcome.err;
    EXPECT_EQ(lines[0], c.message);
  }
}

// Deterministic, so the schedule does not depend on timing: frames 0, 4, ..., 28 of 30.
TEST(DetectRate, EveryFourthFrameRunsTheNetworkOnThoseFramesOnly) {
  const fs::path dir = test::callDir("detect_rate_");
  const test::CliOutcome outcome = test::runFromProjectRoot(
      test::vslamBinary() + " run --seq tum/fr1_xyz --max-frames 30 --no-render --deterministic --detect-every 4 " +
          "--box-filter reuse --out " + test::quoted((dir / "run").string()),
      dir);
  ASSERT_EQ(outcome.exit_code, 0) << outcome.err;
  std::ifstream in(dir / "run/report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  const nlohmann::json& detector = report["detector"];
  EXPECT_EQ(detector["detect_every"], "4");
  EXPECT_EQ(detector["box_filter"], "reuse");
  EXPECT_EQ(detector["network_frames"], 8);
  EXPECT_EQ(detector["frames"], 30);
  EXPECT_EQ(detector["fresh_frames"].get<int>() + detector["carried_frames"].get<int>(), 30);
  EXPECT_LE(detector["fresh_frames"].get<int>(), 8);
  EXPECT_GT(detector["keypoints_added_total"].get<int>(), 0);
  // Measured on the 7 detected frames after the first: carried boxes against fresh ones.
  ASSERT_TRUE(detector["carried_iou_median"].is_number()) << detector.dump();
  EXPECT_GE(detector["carried_iou_median"].get<double>(), 0.0);
  EXPECT_LE(detector["carried_iou_median"].get<double>(), 1.0);
  EXPECT_TRUE(test::contains(outcome.out, "detect every 4: network on 8 frames")) << outcome.out;
}

}  // namespace
}  // namespace vslam
