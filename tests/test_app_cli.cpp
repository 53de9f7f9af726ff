// The `vslam` binary end to end: `run` (stage 1) on the shared data, fetching a
// missing TUM sequence through tools/fetch_dataset.sh, and `eval`, including
// exit status 2 with a one-line message on bad input.
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

using test::contains;
using test::errorLines;
using test::quoted;
using test::slurp;
using Outcome = test::CliOutcome;

// Runs `env vslam args` from the project root (as a user would), with no $VSLAM_DATA.
Outcome vslam(const std::string& args, const std::string& env = "") {
  return test::runFromProjectRoot(env + " " + test::vslamBinary() + " " + args, test::callDir("cli_io_"));
}

TEST(CliRun, FindsFr1XyzInTheSharedDataAndReportsIt) {
  const Outcome run = vslam("run --seq tum/fr1_xyz --info");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "sequence: tum/fr1_xyz\n")) << run.out;
  EXPECT_TRUE(contains(run.out, "\nframes: 798\n")) << run.out;
  EXPECT_TRUE(contains(run.out, "camera: tum_fr1 640x480 fx 517.306408 fy 516.469215")) << run.out;
  EXPECT_TRUE(contains(run.out, "depth: 792 of 798 frames paired")) << run.out;
  EXPECT_TRUE(contains(run.out, "groundtruth: 3000 poses, 1305031098.665900 .. 1305031128.755500 s")) << run.out;
  EXPECT_TRUE(contains(run.out, "rgbd_dataset_freiburg1_xyz/groundtruth.txt")) << run.out;
}

TEST(CliRun, KittiAndMaxFramesAndOutputFolder) {
  const fs::path out = test::scratchDir("cli_run_out") / "run";
  const Outcome run = vslam("run --seq kitti/00 --max-frames 10 --detector none --out " + quoted(out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "\nframes: 10 (first 10 of 200)\n")) << run.out;
  EXPECT_TRUE(contains(run.out, "camera: kitti_00-02 1241x376 fx 718.856")) << run.out;
  EXPECT_TRUE(contains(run.out, "groundtruth: 200 poses")) << run.out;
  EXPECT_TRUE(contains(run.out, "detector: none")) << run.out;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["frames_total"], 10);
  EXPECT_EQ(report["camera"], "kitti_00-02");
  EXPECT_EQ(report["sequence"], "kitti/00");
  // Every frame but the first is extracted ahead, on the extraction thread,
  // except the one after the map starts: it was submitted with the count of
  // a monocular start (twice the features) and is extracted again.
  const int started_at = report["initialised_at_frame"].get<int>();
  ASSERT_GE(started_at, 1);
  EXPECT_EQ(report["frames_extracted_ahead"], started_at < 9 ? 8 : 9);
}

// --realtime plays the frames at their timestamps: the run lasts at least as
// long as the sequence, and every frame is either processed or counted as
// dropped (it arrived while Tracking was busy with an earlier one).
TEST(CliRun, RealtimePlaysAtTheTimestampsAndCountsDroppedFrames) {
  const fs::path out = test::scratchDir("cli_run_realtime") / "run";
  const Outcome run = vslam("run --seq tum/fr3_teddy --max-frames 60 --detector none --no-render --realtime --out " +
                            quoted(out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["realtime"], true);
  EXPECT_EQ(report["frames_total"].get<int>() + report["frames_dropped"].get<int>(), 60);
  // 60 frames at 30 Hz: the last arrives 59 / 30 s after the first.
  EXPECT_GE(report["wall_s"].get<double>(), 59.0 / 30.0 - 0.05);
  EXPECT_EQ(report["frames_extracted_ahead"], 0);  // which frame comes next is not known

  const Outcome both = vslam("run --seq tum/fr3_teddy --max-frames 5 --realtime --deterministic --out " +
                             quoted((out.parent_path() / "both").string()));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_TRUE(contains(both.err, "--realtime and --deterministic")) << both.err;
}

// RGB-D is scored as the metric map it is: SE(3) alignment, with the scale a
// Sim(3) alignment would find beside it; a monocular run only ever by Sim(3).
TEST(CliRun, RgbdReportsSe3AteWithTheSim3ScaleAndMonoOnlySim3) {
  const fs::path dir = test::scratchDir("cli_run_rgbd");
  const Outcome rgbd = vslam("run --seq tum/fr3_teddy --max-frames 100 --mode rgbd --detector none --no-render --out " +
                             quoted((dir / "rgbd").string()));
  ASSERT_EQ(rgbd.exit_code, 0) << rgbd.err;
  EXPECT_TRUE(contains(rgbd.out, "SE(3) alignment; Sim(3) would scale by")) << rgbd.out;
  const nlohmann::json report = nlohmann::json::parse(slurp(dir / "rgbd" / "report.json"));
  EXPECT_EQ(report["mode"], "rgbd");
  EXPECT_EQ(report["frames_without_depth"], 0);
  EXPECT_EQ(report["initialised_at_frame"], 0);  // one frame with depth is enough
  for (const char* part : {"keyframes", "frames"}) {
    const nlohmann::json& ate = report["ate"][part];
    EXPECT_EQ(ate["alignment"], "se3") << part;
    EXPECT_EQ(ate["scale"], 1.0) << part;
    EXPECT_NEAR(ate["sim3_scale"].get<double>(), 1.0, 0.05) << part;
    EXPECT_LT(ate["rmse_m"].get<double>(), 0.03) << part;
  }

  const Outcome mono = vslam("run --seq tum/fr3_teddy --max-frames 100 --detector none --no-render --out " +
                             quoted((dir / "mono").string()));
  ASSERT_EQ(mono.exit_code, 0) << mono.err;
  const nlohmann::json mono_report = nlohmann::json::parse(slurp(dir / "mono" / "report.json"));
  EXPECT_EQ(mono_report["ate"]["keyframes"]["alignment"], "sim3");
  EXPECT_FALSE(mono_report["ate"]["keyframes"].contains("sim3_scale"));
  EXPECT_FALSE(mono_report.contains("frames_without_depth"));
}

TEST(CliRun, RgbdWithoutCameraBfExitsTwoNamingTheKey) {
  const fs::path dir = test::scratchDir("cli_run_rgbd_nobf");
  const fs::path settings = dir / "TUM3.yaml";
  std::ofstream(settings) << "%YAML:1.0\nCamera.fx: 535.4\nCamera.fy: 539.2\nCamera.cx: 320.1\nCamera.cy: 247.6\n";
  const Outcome run = vslam("run --seq tum/fr3_teddy --max-frames 5 --mode rgbd --config " + quoted(settings.string()) +
                            " --out " + quoted((dir / "run").string()));
  EXPECT_EQ(run.exit_code, 2);
  const std::vector<std::string> lines = errorLines(run.err);
  ASSERT_EQ(lines.size(), 1u) << run.err;
  EXPECT_TRUE(contains(lines[0], settings.string() + ": missing required key 'Camera.bf' for RGB-D")) << lines[0];
}

TEST(CliRun, HelpListsEveryOptionAndItsDefault) {
  const Outcome help = vslam("run --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--seq", "--config", "--data-root", "--mode", "--out", "--detector", "--deterministic", "--realtime",
                             "--no-fetch", "--max-frames", "--info", "=mono", "INT:NONNEGATIVE=0", "default: the config's",
                             "'auto' (whenever the detection thread is free, never waited for; the default, but 1 with --moving-classes",
                             "label (the default)"})
    EXPECT_TRUE(contains(help.out, option)) << option << "\n" << help.out;
}

TEST(CliRun, HeaderNamesAnotherModelsCfgAsCustom) {
  // The header once printed the config's model name before the files were
  // located, so another model's cfg and weights ran as "yolo-fastest-1.1-xl"
  // while the summary and report.json said "custom".
  const fs::path dir = test::sharedModels() / "yolo-fastest-1.1";
  const Outcome run = vslam("run --seq tum/fr1_xyz --info --detector-cfg " + quoted((dir / "yolo-fastest-1.1.cfg").string()) +
                            " --detector-weights " + quoted((dir / "yolo-fastest-1.1.weights").string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "detector: custom\n")) << run.out;
  const Outcome own = vslam("run --seq tum/fr1_xyz --info --detector yolo-fastest-1.1 --detector-cfg " +
                            quoted((dir / "yolo-fastest-1.1.cfg").string()));
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_TRUE(contains(own.out, "detector: yolo-fastest-1.1\n")) << own.out;  // its own cfg, given by path
}

TEST(CliRun, DetectorWritesObjectsAndReport) {
  const fs::path out = test::scratchDir("cli_run_detector");
  const Outcome run =
      vslam("run --seq tum/fr1_xyz --max-frames 40 --deterministic --detect-every 1 --box-filter paper --box-features 200 --out " + quoted(out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "detector: yolo-fastest-1.1-xl")) << run.out;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["detector"]["model"], "yolo-fastest-1.1-xl");
  EXPECT_EQ(report["detector"]["input_size"], 320);
  EXPECT_EQ(report["detector"]["input_height"], 320);
  EXPECT_EQ(report["detector"]["placeholder_weights"], false);
  EXPECT_GT(report["detector"]["median_ms"].get<double>(), 0.0);
  EXPECT_GT(report["detector"]["keypoints_added_per_frame"].get<double>(), 0.0);
  for (const char* stage : {"detect", "detect_wait", "filter"}) EXPECT_EQ(report["stage_ms"][stage]["count"], 40) << stage;
  const nlohmann::json objects = nlohmann::json::parse(slurp(out / "objects.json"));
  ASSERT_TRUE(objects.is_array());
  EXPECT_EQ(report["objects"], objects.size());
  ASSERT_GE(objects.size(), 1u);
  for (const nlohmann::json& object : objects) {
    EXPECT_TRUE(object["class"].is_string());
    for (const char* key : {"centroid", "box_min", "box_max"}) EXPECT_EQ(object[key].size(), 3u) << key;
    EXPECT_GE(object["points"].get<int>(), 5);
    EXPECT_GE(object["keyframes"].size(), 1u);
    EXPECT_GT(object["confidence"].get<double>(), 0.0);
    EXPECT_GE(object["points_rejected"].get<int>(), 0);
    EXPECT_TRUE(object["merged_classes"].is_array());
  }
}

// Initialised at frame 2 with two keyframes (frame 1 untracked): too few poses
// for an aligned ATE. The run still succeeds and keeps its trajectory; the
// report says why there is no ATE instead of failing after the work is done.
TEST(CliRun, TooFewPosesForAnAteGiveANullAteAndExitZero) {
  const fs::path out = test::scratchDir("cli_run_too_few_poses");
  const Outcome run =
      vslam("run --seq tum/fr1_xyz --max-frames 3 --detector none --deterministic --no-render --out " +
            quoted(out.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["keyframes"], 2);
  EXPECT_TRUE(report["ate"].is_null());
  EXPECT_TRUE(report["rpe"].is_null());
  EXPECT_FALSE(report.contains("ate_before_final_ba"));
  ASSERT_TRUE(report.contains("ate_unavailable"));
  EXPECT_TRUE(contains(report["ate_unavailable"].get<std::string>(), "at least 3")) << report["ate_unavailable"];
  EXPECT_TRUE(contains(run.out, "ATE: none")) << run.out;
  EXPECT_EQ(readTumTrajectory((out / "keyframes.txt").string()).size(), 2u);
}

TEST(CliRun, DetectorNoneAndBadDetectorFiles) {
  const fs::path out = test::scratchDir("cli_run_detector_none");
  const Outcome none = vslam("run --seq tum/fr1_xyz --max-frames 30 --detector none --out " + quoted(out.string()));
  ASSERT_EQ(none.exit_code, 0) << none.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(out / "report.json"));
  EXPECT_EQ(report["detector"]["model"], "none");
  EXPECT_EQ(report["objects"], 0);
  EXPECT_FALSE(report["stage_ms"].contains("detect_wait"));

  const Outcome bad = vslam("run --seq tum/fr1_xyz --max-frames 10 --detector-cfg /nonexistent/x.cfg --out " +
                            quoted((out / "bad").string()));
  EXPECT_EQ(bad.exit_code, 2);
  const auto lines = errorLines(bad.err);
  ASSERT_EQ(lines.size(), 1u) << bad.err;
  EXPECT_TRUE(contains(lines[0], "/nonexistent/x.cfg")) << lines[0];

  const Outcome typo = vslam("run --seq tum/fr1_xyz --max-frames 10 --dynamic-classes persn --out " +
                             quoted((out / "typo").string()));
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_TRUE(contains(typo.err, "persn")) << typo.err;
}

TEST(CliRun, NotFoundWithoutFetchingExitsTwoWithOneLine) {
  const fs::path empty = test::scratchDir("cli_not_found");
  const Outcome run = vslam("run --seq tum/fr2_desk --no-fetch --data-root " + quoted(empty.string()));
  EXPECT_EQ(run.exit_code, 2);
  const auto lines = errorLines(run.err);
  ASSERT_EQ(lines.size(), 1u) << run.err;
  EXPECT_TRUE(contains(lines[0], "error: tum/fr2_desk: sequence not found; looked in " + empty.string())) << lines[0];
  EXPECT_TRUE(contains(lines[0], "tools/fetch_dataset.sh tum/fr2_desk")) << lines[0];
  EXPECT_EQ(run.out, "");
}

TEST(CliRun, BadConfigExitsTwoNamingTheKey) {
  const fs::path config = test::scratchDir("cli_bad_config") / "cam.yaml";
  std::ofstream(config)
      << "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: five hundred\n  cx: 320\n  cy: 240\n";
  const Outcome run = vslam("run --seq tum/fr1_xyz --config " + quoted(config.string()));
  EXPECT_EQ(run.exit_code, 2);
  const auto lines = errorLines(run.err);
  ASSERT_EQ(lines.size(), 1u) << run.err;
  EXPECT_EQ(lines[0], "error: " + config.string() + ":5: key 'camera.fy' has the wrong type (expected a number)");
}

TEST(CliRun, FetchFailsFastWithoutNetworkAndSaysWhereToPutTheData) {
  const fs::path empty = test::scratchDir("cli_fetch_offline");
  const auto start = std::chrono::steady_clock::now();
  // Port 9 on the loopback refuses at once: the same path as a machine without internet.
  const Outcome run =
      vslam("run --seq tum/fr2_desk --data-root " + quoted(empty.string()), "VSLAM_TUM_BASE_URL=http://127.0.0.1:9");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "download of http://127.0.0.1:9/freiburg2/rgbd_dataset_freiburg2_desk.tgz failed"))
      << run.err;
  EXPECT_TRUE(contains(run.err, "unpack it into " + empty.string() + "/tum/")) << run.err;
  EXPECT_TRUE(contains(run.err, "error: tum/fr2_desk: sequence not found; looked in")) << run.err;
  EXPECT_TRUE(contains(run.err, "(fetching it failed; see the messages above)")) << run.err;
  EXPECT_TRUE(fs::is_empty(empty));  // no partial download left behind
}

// A mirror holding a tiny stand-in for rgbd_dataset_freiburg2_xyz.tgz.
fs::path makeMirror(const std::string& scratch, bool corrupt) {
  const fs::path dir = test::scratchDir(scratch);
  const fs::path sequence = dir / "staging" / "rgbd_dataset_freiburg2_xyz";
  fs::create_directories(sequence);
  std::ofstream(sequence / "rgb.txt") << "# color images\n1311867170.462290 rgb/1311867170.462290.png\n"
                                         "1311867170.494303 rgb/1311867170.494303.png\n";
  std::ofstream(sequence / "groundtruth.txt") << "1311867170.4622 0 0 0 0 0 0 1\n1311867170.4722 0.01 0 0 0 0 0 1\n";
  fs::create_directories(dir / "mirror" / "freiburg2");
  const fs::path archive = dir / "mirror" / "freiburg2" / "rgbd_dataset_freiburg2_xyz.tgz";
  if (corrupt) {
    std::ofstream(archive) << "<html>404 not found</html>\n";
  } else {
    const std::string tar = "tar -czf " + quoted(archive.string()) + " -C " + quoted((dir / "staging").string()) +
                            " rgbd_dataset_freiburg2_xyz";
    EXPECT_EQ(std::system(tar.c_str()), 0);
  }
  return dir;
}

TEST(CliRun, FetchesAMissingTumSequenceAndRetries) {
  const fs::path dir = makeMirror("cli_fetch_ok", false);
  const fs::path data = dir / "data";
  const Outcome run = vslam("run --seq tum/fr2_xyz --info --data-root " + quoted(data.string()),
                            "VSLAM_TUM_BASE_URL=" + quoted("file://" + (dir / "mirror").string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(contains(run.out, "\nframes: 2\n")) << run.out;
  EXPECT_TRUE(contains(run.out, "camera: tum_fr2")) << run.out;
  EXPECT_TRUE(contains(run.out, "groundtruth: 2 poses")) << run.out;
  EXPECT_TRUE(fs::exists(data / "tum" / "rgbd_dataset_freiburg2_xyz" / "rgb.txt"));
  EXPECT_FALSE(fs::exists(data / "tum" / "rgbd_dataset_freiburg2_xyz.tgz.part"));
  EXPECT_EQ(std::distance(fs::directory_iterator(data / "tum"), fs::directory_iterator()), 1);  // archive removed
}

TEST(CliRun, FetchRejectsACorruptArchive) {
  const fs::path dir = makeMirror("cli_fetch_corrupt", true);
  const fs::path data = dir / "data";
  const Outcome run = vslam("run --seq tum/fr2_xyz --data-root " + quoted(data.string()),
                            "VSLAM_TUM_BASE_URL=" + quoted("file://" + (dir / "mirror").string()));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(contains(run.err, "is not a valid gzip archive (truncated or corrupted download)")) << run.err;
  EXPECT_FALSE(fs::exists(data));  // nothing half-unpacked
}

TEST(CliEval, WritesJsonWithTheFiguresOfComputeAte) {
  const fs::path dir = test::scratchDir("cli_eval");
  const std::string gt = (test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string();
  std::vector<StampedPose> estimate = readTumTrajectory(gt);
  const Sim3 S(0.25, Eigen::AngleAxisd(1.0, Vec3(0, 1, 1).normalized()).toRotationMatrix(), Vec3(5, 0, -1));
  for (StampedPose& pose : estimate) pose.T_wc = SE3(S.R * pose.T_wc.R, S * pose.T_wc.t);
  const std::string est = (dir / "est.txt").string();
  writeTumTrajectory(est, estimate);
  const std::string json_path = (dir / "ate.json").string();

  const Outcome eval =
      vslam("eval --est " + quoted(est) + " --gt " + quoted(gt) + " --align sim3 --json " + quoted(json_path));
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_TRUE(contains(eval.out, "ATE (sim3 alignment, 3000 pairs of 3000 estimated poses): rmse 0.000000 m"))
      << eval.out;
  EXPECT_TRUE(contains(eval.out, "scale 4.000000")) << eval.out;
  EXPECT_TRUE(contains(eval.out, "RPE (interval 1.000000 s")) << eval.out;
  const nlohmann::json json = nlohmann::json::parse(slurp(json_path));
  for (const char* key : {"rmse_m", "mean_m", "median_m", "std_m", "min_m", "max_m", "scale", "pairs"})
    EXPECT_TRUE(json.contains(key)) << key;
  EXPECT_LT(json["rmse_m"].get<double>(), 1e-7);  // only the file's 9 significant digits remain
  EXPECT_NEAR(json["scale"].get<double>(), 4.0, 1e-7);
  EXPECT_EQ(json["pairs"].get<int>(), 3000);
  EXPECT_EQ(json["alignment"], "sim3");
  EXPECT_LT(json["rpe"]["trans_rmse"].get<double>(), 1e-6);

  // Same files, SE(3): the figures are those of computeAte in this process.
  const Outcome rigid = vslam("eval --est " + quoted(est) + " --gt " + quoted(gt) + " --json " + quoted(json_path));
  ASSERT_EQ(rigid.exit_code, 0) << rigid.err;
  const AteResult expected = computeAte(readTumTrajectory(est), readTumTrajectory(gt), AteOptions());
  const nlohmann::json rigid_json = nlohmann::json::parse(slurp(json_path));
  EXPECT_DOUBLE_EQ(rigid_json["rmse_m"].get<double>(), expected.rmse_m);
  EXPECT_DOUBLE_EQ(rigid_json["median_m"].get<double>(), expected.median_m);
  EXPECT_DOUBLE_EQ(rigid_json["scale"].get<double>(), 1.0);
  EXPECT_GT(expected.rmse_m, 0.1);
}

// --offset, as evaluate_ate.py's: the ground truth restamped 0.3 s early pairs
// each pose with the one 0.3 s before it, and the offset pairs them again.
TEST(CliEval, OffsetShiftsTheEstimatesTimestamps) {
  const fs::path dir = test::scratchDir("cli_eval_offset");
  const std::string gt = (test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string();
  std::vector<StampedPose> early = readTumTrajectory(gt);
  for (StampedPose& pose : early) pose.timestamp -= 0.3;
  const std::string est = (dir / "early.txt").string();
  writeTumTrajectory(est, early);
  const std::string json_path = (dir / "ate.json").string();

  const Outcome plain = vslam("eval --est " + quoted(est) + " --gt " + quoted(gt) + " --json " + quoted(json_path));
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_GT(nlohmann::json::parse(slurp(json_path))["rmse_m"].get<double>(), 0.01);

  const Outcome shifted =
      vslam("eval --est " + quoted(est) + " --gt " + quoted(gt) + " --offset 0.3 --json " + quoted(json_path));
  ASSERT_EQ(shifted.exit_code, 0) << shifted.err;
  EXPECT_TRUE(contains(shifted.out, "estimate timestamps shifted by 0.300000 s (--offset)")) << shifted.out;
  EXPECT_TRUE(contains(shifted.out, "ATE (se3 alignment, 3000 pairs of 3000 estimated poses): rmse 0.000000 m"))
      << shifted.out;
  const nlohmann::json json = nlohmann::json::parse(slurp(json_path));
  EXPECT_LT(json["rmse_m"].get<double>(), 1e-7);
  EXPECT_DOUBLE_EQ(json["time_offset_s"].get<double>(), 0.3);

  const std::string poses = (test::sharedData() / "kitti" / "poses" / "00.txt").string();
  const Outcome kitti = vslam("eval --format kitti --offset 0.1 --est " + quoted(poses) + " --gt " + quoted(poses));
  EXPECT_EQ(kitti.exit_code, 2);
  EXPECT_TRUE(contains(kitti.err, "--offset shifts timestamps; --format kitti pairs by frame")) << kitti.err;
}

TEST(CliEval, KittiFormatPairsByLine) {
  const std::string poses = (test::sharedData() / "kitti" / "poses" / "00.txt").string();
  const Outcome eval = vslam("eval --format kitti --est " + quoted(poses) + " --gt " + quoted(poses));
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_TRUE(contains(eval.out, "ATE (se3 alignment, 200 pairs of 200 estimated poses): rmse 0.000000 m")) << eval.out;
  EXPECT_TRUE(contains(eval.out, "RPE (interval 100.000000 m")) << eval.out;
  EXPECT_TRUE(contains(eval.out, "translation rmse 0.000000 %")) << eval.out;
}

TEST(CliEval, MalformedFileExitsTwoWithOneLine) {
  const fs::path dir = test::scratchDir("cli_eval_bad");
  const std::string est = (dir / "est.txt").string();
  std::ofstream(est) << "# estimate\n1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 1\n";
  const std::string gt = (test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string();
  const Outcome eval = vslam("eval --est " + quoted(est) + " --gt " + quoted(gt));
  EXPECT_EQ(eval.exit_code, 2);
  EXPECT_EQ(eval.err, "error: " + est + ":3: expected 8 fields 'timestamp tx ty tz qx qy qz qw', found 7\n");
  EXPECT_EQ(eval.out, "");

  const Outcome missing = vslam("eval --est " + quoted(est) + " --gt /nonexistent/gt.txt");
  EXPECT_EQ(missing.exit_code, 2);

  // Trajectories that do not overlap in time: named, not a crash.
  std::ofstream(est) << "1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 0 1\n1.2 0 0 0 0 0 0 1\n";
  const Outcome apart = vslam("eval --est " + quoted(est) + " --gt " + quoted(gt));
  EXPECT_EQ(apart.exit_code, 2);
  EXPECT_TRUE(contains(apart.err, "error: " + est + ": only 0 of 3 estimated poses pair with ground truth"))
      << apart.err;
}

// A monocular run is never scored with SE(3): without --align, eval takes the
// alignment from the run's report.json (issue 13).
TEST(CliEval, AlignmentFollowsTheRunsMode) {
  const fs::path dir = test::scratchDir("cli_eval_auto");
  const std::string gt = (test::tumSequence("freiburg1_xyz") / "groundtruth.txt").string();
  // The ground truth itself, scaled by 0.5 about the first pose: a monocular map.
  const std::vector<StampedPose> truth = readTumTrajectory(gt);
  std::vector<StampedPose> half(truth.begin(), truth.begin() + 300);
  for (StampedPose& pose : half) pose.T_wc.t = truth.front().T_wc.t + 0.5 * (pose.T_wc.t - truth.front().T_wc.t);
  for (const char* mode : {"mono", "rgbd", "none"}) {
    fs::create_directories(dir / mode);
    writeTumTrajectory((dir / mode / "trajectory.txt").string(), half);
    if (std::string(mode) != "none") std::ofstream(dir / mode / "report.json") << "{\"mode\": \"" << mode << "\"}\n";
  }
  const Outcome mono = vslam("eval --est " + quoted((dir / "mono" / "trajectory.txt").string()) + " --gt " + quoted(gt));
  ASSERT_EQ(mono.exit_code, 0) << mono.err;
  EXPECT_TRUE(contains(mono.out, "alignment: sim3 (monocular run")) << mono.out;
  EXPECT_TRUE(contains(mono.out, "scale 2.000000")) << mono.out;
  const Outcome rgbd = vslam("eval --est " + quoted((dir / "rgbd" / "trajectory.txt").string()) + " --gt " + quoted(gt));
  ASSERT_EQ(rgbd.exit_code, 0) << rgbd.err;
  EXPECT_TRUE(contains(rgbd.out, "alignment: se3 (RGB-D run")) << rgbd.out;
  EXPECT_TRUE(contains(rgbd.out, "scale 1.000000")) << rgbd.out;
  const Outcome none = vslam("eval --est " + quoted((dir / "none" / "trajectory.txt").string()) + " --gt " + quoted(gt));
  ASSERT_EQ(none.exit_code, 0) << none.err;
  EXPECT_TRUE(contains(none.out, "alignment: se3 (no report.json beside the estimate")) << none.out;
  const Outcome forced = vslam("eval --est " + quoted((dir / "mono" / "trajectory.txt").string()) + " --gt " +
                               quoted(gt) + " --align se3");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_FALSE(contains(forced.out, "alignment:")) << forced.out;
}

// --config takes ground truth of another body to the camera: Bonn's markers'
// poses, scored against the camera poses they stand for, agree only with
// config/bonn.yaml's evaluation section applied.
TEST(CliEval, ConfigTakesTheGroundTruthOfAnotherBodyToTheCamera) {
  const fs::path dir = test::scratchDir("cli_eval_body");
  const std::string markers = (test::sharedData() / "bonn" / "rgbd_bonn_crowd" / "groundtruth.txt").string();
  const std::string config = projectConfigDir() + "/bonn.yaml";
  const SE3 camera_in_markers = *loadConfig(config).evaluation.groundtruth_camera_in_body;
  std::vector<StampedPose> camera = readTumTrajectory(markers);
  for (StampedPose& pose : camera) pose.T_wc = pose.T_wc * camera_in_markers;
  const std::string est = (dir / "camera.txt").string();
  writeTumTrajectory(est, camera);
  const std::string json_path = (dir / "eval.json").string();

  const Outcome raw = vslam("eval --est " + quoted(est) + " --gt " + quoted(markers) + " --json " + quoted(json_path));
  ASSERT_EQ(raw.exit_code, 0) << raw.err;
  EXPECT_GT(nlohmann::json::parse(slurp(json_path))["rpe"]["rot_rmse_deg"].get<double>(), 5.0);

  const Outcome taken = vslam("eval --est " + quoted(est) + " --gt " + quoted(markers) + " --config " +
                              quoted(config) + " --json " + quoted(json_path));
  ASSERT_EQ(taken.exit_code, 0) << taken.err;
  EXPECT_TRUE(contains(taken.out, "evaluation.groundtruth_camera_in_body")) << taken.out;
  const nlohmann::json json = nlohmann::json::parse(slurp(json_path));
  EXPECT_LT(json["rmse_m"].get<double>(), 1e-6);  // the file's 9 significant digits
  EXPECT_LT(json["rpe"]["rot_rmse_deg"].get<double>(), 1e-4);
  EXPECT_EQ(json["config"], config);
}

TEST(CliEval, HelpListsEveryOptionAndItsDefault) {
  const Outcome help = vslam("eval --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option :
       {"--est", "--gt", "--align", "=auto", "--format", "=tum", "--json", "--max-dt", "=0.02", "--rpe-delta",
        "--config"})
    EXPECT_TRUE(contains(help.out, option)) << option << "\n" << help.out;
}

}  // namespace
}  // namespace vslam

namespace vslam {
namespace {

// 30 frames at the default speed (1.2 turns in 500 frames, 0.86 degrees a frame).
TEST(CliSynth, WritesARoomSequenceThatRunTakesAndRefusesBadInput) {
  const fs::path out = test::scratchDir("cli_synth") / "room";
  const Outcome synth = vslam("synth --frames 30 --turns 0.072 --out " + quoted(out.string()));
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  EXPECT_TRUE(contains(synth.out, "--config " + out.string() + "/camera.yaml")) << synth.out;
  EXPECT_EQ(readTumTrajectory((out / "groundtruth.txt").string()).size(), 30u);

  const fs::path run_dir = test::scratchDir("cli_synth_run");
  const Outcome run = vslam("run --seq " + quoted(out.string()) + " --config " + quoted((out / "camera.yaml").string()) +
                            " --detector none --deterministic --no-render --out " + quoted(run_dir.string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json report = nlohmann::json::parse(slurp(run_dir / "report.json"));
  EXPECT_EQ(report["frames_total"], 30);
  EXPECT_GE(report["frames_tracked"].get<int>(), 25);

  for (const std::string& bad : {"--frames 1", "--turns 0", "--radius 5"}) {
    const Outcome refused = vslam("synth " + bad + " --out " + quoted((out.parent_path() / "bad").string()));
    EXPECT_EQ(refused.exit_code, 2) << bad;
    ASSERT_EQ(errorLines(refused.err).size(), 1u) << refused.err;
    EXPECT_TRUE(contains(refused.err, bad.substr(0, bad.find(' ')))) << refused.err;
    EXPECT_FALSE(fs::exists(out.parent_path() / "bad")) << bad;
  }
}

}  // namespace
}  // namespace vslam
