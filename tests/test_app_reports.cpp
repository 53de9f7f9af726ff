// The report side of `vslam run` end to end: the PNG renders at the end of a
// run (and --no-render), the run folder's own groundtruth.txt (TUM format,
// also for KITTI, so `vslam render` works on a copied folder), RPE in
// report.json, and tools/batch_eval.sh on short runs.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

const char* const kPngs[] = {"trajectory_top.png", "trajectory_3d.png", "map_colour.png", "map_classes.png",
                             "map_top.png"};

using test::contains;
using test::quoted;
using test::slurp;

// Runs `command` from the project root; stdout and stderr go to files in `dir`.
int runFromRoot(const std::string& command, const fs::path& dir) {
  const std::string line = "cd " + quoted(test::sourceDir().string()) + " && env -u VSLAM_DATA " + command + " > " +
                           quoted((dir / "stdout").string()) + " 2> " + quoted((dir / "stderr").string());
  const int status = std::system(line.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string vslamBinary() { return quoted(std::string(VSLAM_BINARY_DIR) + "/vslam"); }

TEST(RunRenders, ShortFr1XyzRunWritesEveryPngAndItsGroundTruth) {
  const fs::path dir = test::scratchDir("reports_run_renders");
  const fs::path out = dir / "run";
  ASSERT_EQ(runFromRoot(vslamBinary() + " run --seq tum/fr1_xyz --max-frames 40 --detector none --out " +
                            quoted(out.string()),
                        dir),
            0)
      << slurp(dir / "stderr");
  for (const char* png : kPngs) {
    ASSERT_TRUE(fs::exists(out / png)) << png;
    EXPECT_GT(fs::file_size(out / png), 1000u) << png;
  }
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["groundtruth_file"], "groundtruth.txt");
  EXPECT_TRUE(contains(report["groundtruth_source"].get<std::string>(), "rgbd_dataset_freiburg1_xyz/groundtruth.txt"));
  ASSERT_TRUE(report["ate"].is_object());
  ASSERT_TRUE(report["rpe"].is_object());
  EXPECT_GT(report["rpe"]["frames"]["pairs"].get<int>(), 0);
  EXPECT_TRUE(std::isfinite(report["rpe"]["frames"]["trans_rmse"].get<double>()));
  EXPECT_EQ(report["rpe"]["frames"]["trans_units"], "m/s");

  // The ground truth of the run's time span only (100 Hz motion capture over 40 frames at 30 Hz).
  const std::vector<StampedPose> groundtruth = readTumTrajectory((out / "groundtruth.txt").string());
  const std::vector<StampedPose> trajectory = readTumTrajectory((out / "trajectory.txt").string());
  ASSERT_FALSE(trajectory.empty());
  ASSERT_GT(groundtruth.size(), 100u);
  EXPECT_LT(groundtruth.size(), 200u);
  EXPECT_LE(groundtruth.front().timestamp, trajectory.front().timestamp);
  EXPECT_GE(groundtruth.back().timestamp, trajectory.back().timestamp);
}

TEST(RunRenders, NoRenderWritesNoPng) {
  const fs::path dir = test::scratchDir("reports_no_render");
  const fs::path out = dir / "run";
  ASSERT_EQ(runFromRoot(vslamBinary() + " run --seq tum/fr1_xyz --max-frames 40 --detector none --no-render --out " +
                            quoted(out.string()),
                        dir),
            0)
      << slurp(dir / "stderr");
  EXPECT_TRUE(fs::exists(out / "report.json"));
  EXPECT_TRUE(fs::exists(out / "trajectory.txt"));
  for (const char* png : kPngs) EXPECT_FALSE(fs::exists(out / png)) << png;
}

TEST(RunRenders, HelpDocumentsNoRender) {
  const fs::path dir = test::scratchDir("reports_run_help");
  ASSERT_EQ(runFromRoot(vslamBinary() + " run --help", dir), 0);
  EXPECT_TRUE(contains(slurp(dir / "stdout"), "--no-render")) << slurp(dir / "stdout");
}

TEST(RunRenders, RenderFailureIsAWarningAndKeepsTheRun) {
  const fs::path dir = test::scratchDir("reports_render_fails");
  const fs::path out = dir / "run";
  fs::create_directories(out / "trajectory_top.png");  // a folder where the PNG should go: imwrite fails
  ASSERT_EQ(runFromRoot(vslamBinary() + " run --seq tum/fr1_xyz --max-frames 40 --detector none --out " +
                            quoted(out.string()),
                        dir),
            0)
      << slurp(dir / "stderr");
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "render failed")) << slurp(dir / "stderr");
  for (const char* file : {"report.json", "trajectory.txt", "keyframes.txt", "map.ply", "groundtruth.txt"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
}

TEST(RunRenders, KittiGroundTruthIsWrittenInTumFormatAndRendersFromACopiedFolder) {
  const fs::path dir = test::scratchDir("reports_kitti");
  const fs::path out = dir / "run";
  ASSERT_EQ(runFromRoot(vslamBinary() + " run --seq kitti/00 --max-frames 30 --detector none --no-render --out " +
                            quoted(out.string()),
                        dir),
            0)
      << slurp(dir / "stderr");
  const std::vector<StampedPose> groundtruth = readTumTrajectory((out / "groundtruth.txt").string());
  ASSERT_EQ(groundtruth.size(), 30u);
  const std::vector<StampedPose> official =
      readKittiTrajectory((test::sharedData() / "kitti" / "poses" / "00.txt").string());
  for (size_t i : {size_t{0}, size_t{29}}) {
    EXPECT_NEAR(groundtruth[i].timestamp, 0.1 * static_cast<double>(i), 1e-6);
    EXPECT_LT((groundtruth[i].T_wc.t - official[i].T_wc.t).norm(), 1e-6) << i;
  }

  // A copy of the run folder elsewhere still renders against its ground truth.
  const fs::path copy = dir / "copied";
  fs::copy(out, copy, fs::copy_options::recursive);
  ASSERT_EQ(runFromRoot(vslamBinary() + " render " + quoted(copy.string()), dir), 0) << slurp(dir / "stderr");
  const std::string log = slurp(dir / "stderr");
  EXPECT_FALSE(contains(log, "plotting the estimate alone")) << log;
  for (const char* png : kPngs) EXPECT_TRUE(fs::exists(copy / png)) << png;
}

// CSV rows as lists of fields (no quoted commas in these tests).
std::vector<std::vector<std::string>> readCsv(const fs::path& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> fields;
    std::stringstream stream(line);
    for (std::string field; std::getline(stream, field, ',');) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    rows.push_back(fields);
  }
  return rows;
}

TEST(BatchEval, ShortRunsGiveTablesAndAFailedRunIsARow) {
  const fs::path dir = test::scratchDir("reports_batch_eval");
  const fs::path out = dir / "eval";
  const std::string script = quoted((test::sourceDir() / "tools" / "batch_eval.sh").string());
  // fr1_xyz runs; a sequence folder that does not exist fails: the batch says so (exit 1) but still writes the
  // tables.
  const std::string missing = (dir / "no_such_sequence").string();
  const std::string args = " --seqs tum/fr1_xyz," + quoted(missing) + " --modes mono --detectors off --jobs 1 --vslam " +
                           vslamBinary() + " --out " + quoted(out.string()) + " -- --max-frames 40";
  EXPECT_EQ(runFromRoot(script + args, dir), 1) << slurp(dir / "stderr");

  const auto rows = readCsv(out / "results.csv");
  ASSERT_EQ(rows.size(), 3u) << slurp(out / "results.csv");
  const std::vector<std::string> header = {"sequence", "mode", "detector", "status", "ate_rmse_m",
                                           "rpe_trans_m_per_s", "rpe_rot_deg_per_s", "frames_tracked",
                                           "frames_total", "fps", "peak_mb", "run_dir"};
  EXPECT_EQ(rows[0], header);
  ASSERT_EQ(rows[1].size(), header.size());
  EXPECT_EQ(rows[1][0], "tum/fr1_xyz");
  EXPECT_EQ(rows[1][1], "mono");
  EXPECT_EQ(rows[1][2], "off");
  EXPECT_EQ(rows[1][3], "ok");
  const double ate = std::stod(rows[1][4]);
  EXPECT_TRUE(std::isfinite(ate) && ate >= 0 && ate < 0.5) << rows[1][4];
  EXPECT_GE(std::stod(rows[1][5]), 0.0);
  EXPECT_GT(std::stoi(rows[1][7]), 0);
  EXPECT_EQ(rows[1][8], "40");
  EXPECT_GT(std::stod(rows[1][9]), 0.0);
  EXPECT_GT(std::stod(rows[1][10]), 0.0);
  EXPECT_TRUE(fs::exists(out / rows[1][11] / "trajectory_top.png"));
  ASSERT_EQ(rows[2].size(), header.size());
  EXPECT_EQ(rows[2][0], missing);
  EXPECT_EQ(rows[2][2], "off");
  EXPECT_TRUE(contains(rows[2][3], "failed (exit ")) << rows[2][3];
  EXPECT_EQ(rows[2][4], "");

  const std::string table = slurp(out / "results.md");
  EXPECT_TRUE(contains(table, "| sequence | mode | detector | status | ATE RMSE (m) |")) << table;
  EXPECT_TRUE(contains(table, "| tum/fr1_xyz | mono | off | ok | ")) << table;

  // --collect rebuilds the same tables from the run folders.
  const std::string csv = slurp(out / "results.csv");
  fs::remove(out / "results.csv");
  EXPECT_EQ(runFromRoot(script + " --collect " + quoted(out.string()), dir), 1) << slurp(dir / "stderr");
  EXPECT_EQ(slurp(out / "results.csv"), csv);
}

TEST(BatchEval, DryRunAndEmitJobsListEverySequenceModeAndDetector) {
  const fs::path dir = test::scratchDir("reports_batch_jobs");
  const std::string script = quoted((test::sourceDir() / "tools" / "batch_eval.sh").string());
  const std::string args = " --seqs tum/fr3_teddy,kitti/00 --modes mono,rgbd --detectors on,off --out " +
                           quoted((dir / "eval").string());
  ASSERT_EQ(runFromRoot(script + args + " --dry-run", dir), 0) << slurp(dir / "stderr");
  const std::string jobs = slurp(dir / "stdout");
  EXPECT_EQ(std::count(jobs.begin(), jobs.end(), '\n'), 8) << jobs;
  EXPECT_TRUE(contains(jobs, "--seq 'kitti/00' --mode rgbd --detector none --out '" + (dir / "eval").string() +
                                 "/runs/kitti-00_rgbd_off'"))
      << jobs;
  EXPECT_FALSE(fs::exists(dir / "eval"));  // a dry run writes nothing

  const fs::path list = dir / "jobs.list";
  ASSERT_EQ(runFromRoot(script + args + " --emit-jobs " + quoted(list.string()), dir), 0) << slurp(dir / "stderr");
  EXPECT_EQ(slurp(list), jobs);
  EXPECT_TRUE(fs::exists(dir / "eval" / "jobs.tsv"));
  // Before any task ran, --collect lists every run as not run.
  EXPECT_EQ(runFromRoot(script + " --collect " + quoted((dir / "eval").string()), dir), 1);
  const std::string csv = slurp(dir / "eval" / "results.csv");
  size_t not_run = 0;
  for (size_t at = csv.find(",not run,"); at != std::string::npos; at = csv.find(",not run,", at + 1)) ++not_run;
  EXPECT_EQ(not_run, 8u) << csv;
}

TEST(BatchEval, HelpDocumentsEveryOptionAndBadUsageExitsTwo) {
  const fs::path dir = test::scratchDir("reports_batch_help");
  const std::string script = quoted((test::sourceDir() / "tools" / "batch_eval.sh").string());
  ASSERT_EQ(runFromRoot(script + " --help", dir), 0);
  const std::string help = slurp(dir / "stdout");
  for (const char* option : {"--seqs", "--out", "--modes", "--detectors", "--jobs", "--vslam", "--dry-run",
                             "--emit-jobs", "--collect", "--help", "distorts"})
    EXPECT_TRUE(contains(help, option)) << option;
  EXPECT_EQ(runFromRoot(script + " --seqs tum/fr1_xyz", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "--out is required")) << slurp(dir / "stderr");
  EXPECT_EQ(runFromRoot(script + " --seqs tum/fr1_xyz --out x --modes stereo --dry-run", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "unknown mode 'stereo'")) << slurp(dir / "stderr");
  EXPECT_EQ(runFromRoot(script + " --seqs tum/fr1_xyz --out x --jobs 0 --dry-run", dir), 2);
}

// tools/bench.sh: a figure a run cannot give (the keyframe ATE of a
// 2-keyframe map) is nan in its row and left out of the median, which an
// empty field used to turn into 0.
TEST(BenchScript, FiguresARunCannotGiveAreNanNotZero) {
  const fs::path dir = test::scratchDir("reports_bench_script");
  const fs::path out = dir / "bench";
  const std::string script = quoted((test::sourceDir() / "tools" / "bench.sh").string());
  ASSERT_EQ(runFromRoot(script + " --runs 1 --out " + quoted(out.string()) + " --bin " + vslamBinary() +
                            " -- --seq tum/fr1_xyz --max-frames 30 --mode rgbd --detector none --no-render",
                        dir),
            0)
      << slurp(dir / "stderr");
  const std::string rows = slurp(out / "runs.tsv");
  EXPECT_EQ(rows.rfind("run\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_kf\ttrack_median_ms\ttrack_p95_ms\t"
                       "wall_s\tfps\tpeak_mb\tsim3_scale_frames\telapsed_s\tcpu_s\n",
                       0),
            0u)
      << rows;
  EXPECT_TRUE(contains(rows, "\n1\t30\tnan\t")) << rows;
  EXPECT_EQ(slurp(out / "median.tsv").rfind("median\t30\tnan\t", 0), 0u) << slurp(out / "median.tsv");
  EXPECT_EQ(runFromRoot(script + " --runs 0 -- --seq x", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "--runs takes a positive integer")) << slurp(dir / "stderr");
}

// tools/bench_alternate.sh: every variant once a round, the order turned by
// one each round; the medians and the wall-time ratio to the first variant.
TEST(BenchAlternate, VariantsAlternateRoundByRoundAndAreSummarised) {
  const fs::path dir = test::scratchDir("reports_bench_alternate");
  const fs::path out = dir / "alt";
  const std::string script = quoted((test::sourceDir() / "tools" / "bench_alternate.sh").string());
  const std::string bin = " --bin " + vslamBinary() + " -- --seq tum/fr1_xyz --max-frames 30 --detector none --no-render";
  ASSERT_EQ(runFromRoot(script + " --rounds 2 --out " + quoted(out.string()) + " --variant mono" + bin +
                            " --variant rgbd" + bin + " --mode rgbd",
                        dir),
            0)
      << slurp(dir / "stderr");
  std::istringstream rows(slurp(out / "runs.tsv"));
  std::vector<std::string> lines;
  for (std::string line; std::getline(rows, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 5u) << slurp(out / "runs.tsv");
  EXPECT_EQ(lines[0], "round\tvariant\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_frames\twall_s\tcpu_s");
  EXPECT_EQ(lines[1].rfind("1\tmono\t", 0), 0u) << lines[1];
  EXPECT_EQ(lines[2].rfind("1\trgbd\t", 0), 0u) << lines[2];
  EXPECT_EQ(lines[3].rfind("2\trgbd\t", 0), 0u) << lines[3];  // the second round starts one variant later
  EXPECT_EQ(lines[4].rfind("2\tmono\t", 0), 0u) << lines[4];
  const auto fieldsOf = [](const std::string& line) {
    std::istringstream fields(line);
    std::vector<std::string> values;
    for (std::string value; std::getline(fields, value, '\t');) values.push_back(value);
    return values;
  };
  // Every figure is there, wall and CPU (tools/bench.sh's elapsed_s, cpu_s) included.
  for (size_t row = 1; row < lines.size(); ++row) {
    const std::vector<std::string> values = fieldsOf(lines[row]);
    ASSERT_EQ(values.size(), 8u) << lines[row];
    for (const std::string& value : values) EXPECT_FALSE(value.empty()) << lines[row];
    EXPECT_GT(std::stod(values[6]), 0.0) << lines[row];
    EXPECT_GT(std::stod(values[7]), 0.0) << lines[row];
  }
  // 30 RGB-D frames make 2 keyframes, too few for a keyframe ATE: the row
  // says nan, and so does the median, not a 0 from empty fields.
  EXPECT_EQ(fieldsOf(lines[2])[3], "nan") << lines[2];
  EXPECT_TRUE(fs::exists(out / "rgbd" / "round2" / "run1" / "report.json"));
  const std::string summary = slurp(dir / "stdout");
  EXPECT_TRUE(contains(summary, "variant\tframes_tracked\tate_kf_m\tate_frames_m\tsim3_scale_frames\twall_s\tcpu_s\twall_vs_mono"))
      << summary;
  // The first variant's ratio to itself is 1 in every round.
  const size_t mono_row = summary.find("\nmono\t");
  ASSERT_NE(mono_row, std::string::npos) << summary;
  const std::string mono_line = summary.substr(mono_row + 1, summary.find('\n', mono_row + 1) - mono_row - 1);
  EXPECT_EQ(mono_line.substr(mono_line.rfind('\t') + 1), "1") << mono_line;
  const size_t rgbd_row = summary.find("\nrgbd\t");
  ASSERT_NE(rgbd_row, std::string::npos) << summary;
  const std::vector<std::string> rgbd_medians =
      fieldsOf(summary.substr(rgbd_row + 1, summary.find('\n', rgbd_row + 1) - rgbd_row - 1));
  ASSERT_EQ(rgbd_medians.size(), 8u) << summary;
  EXPECT_EQ(rgbd_medians[2], "nan") << summary;
}

TEST(BenchAlternate, BadUsageExitsTwoAndAFailedRunOne) {
  const fs::path dir = test::scratchDir("reports_bench_alternate_usage");
  const std::string script = quoted((test::sourceDir() / "tools" / "bench_alternate.sh").string());
  const std::string out = " --out " + quoted((dir / "alt").string());
  EXPECT_EQ(runFromRoot(script + out + " --rounds 0 --variant a -- --seq x", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "--rounds takes a positive integer")) << slurp(dir / "stderr");
  EXPECT_EQ(runFromRoot(script + out + " --variant a", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "give its run arguments after --")) << slurp(dir / "stderr");
  EXPECT_EQ(runFromRoot(script + out + " --variant a -- --seq x --variant a -- --seq y", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "variant 'a' given twice")) << slurp(dir / "stderr");
  EXPECT_EQ(runFromRoot(script + out + " --variant a --bin /no/such/vslam -- --seq x", dir), 2);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "/no/such/vslam is not an executable")) << slurp(dir / "stderr");
  // A run that fails stops the benchmark and names its log.
  EXPECT_EQ(runFromRoot(script + out + " --rounds 1 --variant missing --bin " + vslamBinary() +
                            " -- --seq " + quoted((dir / "no_such_sequence").string()),
                        dir),
            1);
  EXPECT_TRUE(contains(slurp(dir / "stderr"), "variant 'missing', round 1 failed")) << slurp(dir / "stderr");
}

}  // namespace
}  // namespace vslam
