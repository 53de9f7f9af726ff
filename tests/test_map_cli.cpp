// `vslam run --save-map`, `vslam map info` and `vslam map export` end to end,
// as a user runs them: the saved map holds the run's keyframes and points,
// its point cloud is the run's map.ply, and bad files exit 2 with one line.
#include <filesystem>
#include <algorithm>
#include <fstream>
#include <map>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "map_test_support.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/map_io/sqlite_database.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

using test::contains;
using test::errorLines;
using test::quoted;
using test::slurp;
using test::vslamBinary;

constexpr auto vslam = test::runVslam;

TEST(MapCli, SavedMapHoldsTheRunsKeyFramesAndPoints) {
  const fs::path dir = test::scratchDir("map_cli_save");
  const std::string map = (dir / "fr1.sqlite").string();
  const test::CliOutcome run = vslam("run --seq tum/fr1_xyz --max-frames 120 --detector none --no-render --out " +
                                         quoted((dir / "run").string()) + " --save-map " + quoted(map),
                                     dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(dir / "run" / "report.json"));
  EXPECT_EQ(report["map_file"], map);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_FALSE(contains(entry.path().filename().string(), ".partial")) << entry.path();

  const test::CliOutcome info = vslam("map info " + quoted(map), dir);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_TRUE(contains(info.out, "mode: mono\n")) << info.out;
  EXPECT_TRUE(contains(info.out, "sequence: tum/fr1_xyz\n")) << info.out;
  EXPECT_TRUE(contains(info.out, "keyframes: " + std::to_string(report["keyframes"].get<int>()) + " (")) << info.out;
  EXPECT_TRUE(contains(info.out, "map points: " + std::to_string(report["map_points"].get<int>()) + " (")) << info.out;
  EXPECT_TRUE(contains(info.out, "camera: tum_fr1 640x480 fx 517.306408 ")) << info.out;

  const test::CliOutcome exported = vslam("map export " + quoted(map) + " --ply " + quoted((dir / "map.ply").string()), dir);
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  // The same points, colours and classes, in the same order, as the run's own map.ply.
  EXPECT_EQ(slurp(dir / "map.ply"), slurp(dir / "run" / "map.ply"));
}


// The round trip on a real map (fr1_xyz, threaded run, real vocabulary, culled
// keyframes leaving gaps in the ids): loaded into a System and saved again, it
// gives the same rows.
TEST(MapCli, RealMapLoadedIntoASystemAndSavedAgainGivesTheSameRows) {
  const fs::path dir = test::scratchDir("map_cli_round_trip");
  const std::string first = (dir / "first.sqlite").string();
  const test::CliOutcome run = vslam("run --seq tum/fr1_xyz --max-frames 150 --detector none --no-render --out " +
                                         quoted((dir / "run").string()) + " --save-map " + quoted(first),
                                     dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  SequenceOptions sequence_options;
  sequence_options.data_root = test::sharedData().string();
  Config config = openSequence("tum/fr1_xyz", sequence_options).config;
  config.detector.model = "none";
  const std::string second = (dir / "second.sqlite").string();
  {
    System system(config, SystemOptions());
    system.loadMap(first, true);
    system.saveMap(second, "round trip");
  }
  // Not the creation time and sequence name, which differ between the two saves.
  const std::set<std::string> volatile_info = {"created_utc", "sequence"};
  const auto rows_first = test::mapFileRows(first, volatile_info), rows_second = test::mapFileRows(second, volatile_info);
  EXPECT_GT(rows_first.at("keyframes").size(), 3u);
  EXPECT_GT(rows_first.at("bow_words").size(), 100u);
  for (const auto& [table, rows] : rows_first) EXPECT_EQ(rows, rows_second.at(table)) << table;
}

TEST(MapCli, BadMapFilesExitTwoWithOneLine) {
  const fs::path dir = test::scratchDir("map_cli_bad");
  const std::string missing = (dir / "missing.sqlite").string();
  const std::string text = (dir / "text.sqlite").string();
  std::ofstream(text) << "not a map at all, only some text that is long enough to look at\n";
  for (const std::string& command : {"map info " + quoted(missing), "map export " + quoted(text) + " --ply " +
                                                                        quoted((dir / "out.ply").string())}) {
    const test::CliOutcome outcome = vslam(command, dir);
    EXPECT_EQ(outcome.exit_code, 2) << command;
    const std::vector<std::string> lines = errorLines(outcome.err);
    ASSERT_EQ(lines.size(), 1u) << outcome.err;
    EXPECT_TRUE(contains(lines[0], "error: " + missing + ": no such map file") ||
                contains(lines[0], "error: " + text + ": corrupt map file"))
        << lines[0];
  }
  EXPECT_FALSE(fs::exists(dir / "out.ply"));
}

}  // namespace
}  // namespace vslam
