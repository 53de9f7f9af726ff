// `vslam run`: runs SLAM on a sequence: finds (or fetches) it, reports what was
// found, then runs the pipeline and writes the run folder (run_slam.cpp).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <string>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "detector_options.hpp"
#include "run_slam.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/model_locator.hpp"
#include "vslam/io/sequence.hpp"

namespace vslam::app {
namespace {

struct RunCommandOptions {
  std::string seq;
  SequenceOptions sequence;
  RunOptions pipeline;
  DetectorOptions detector;  // overrides the config's detector section
  std::string vocabulary;  // "" = the config's loop.vocabulary
  bool no_loop = false;
  bool no_final_ba = false;
  bool no_fetch = false;
  bool info_only = false;
  int max_frames = 0;
};

std::string shellQuoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// A TUM sequence that is nowhere on disk is fetched from the benchmark's
// archive by tools/fetch_dataset.sh, then looked up again.
Sequence openOrFetch(const RunCommandOptions& options) {
  try {
    return openSequence(options.seq, options.sequence);
  } catch (const SequenceNotFound& not_found) {
    if (options.no_fetch || options.seq.rfind("tum/", 0) != 0) throw;
    spdlog::warn("{}", not_found.what());
    const std::string script = std::string(VSLAM_SOURCE_DIR) + "/tools/fetch_dataset.sh";
    const std::string command = "bash " + shellQuoted(script) + " --data-root " +
                                shellQuoted(fetchDataRoot(options.sequence)) + " " + shellQuoted(options.seq) +
                                " 1>&2";  // stdout is for results only
    spdlog::info("fetching {}: {}", options.seq, command);
    if (std::system(command.c_str()) != 0)
      throw InputError(std::string(not_found.what()) + " (fetching it failed; see the messages above)");
    return openSequence(options.seq, options.sequence);
  }
}

// A named sequence whose folder holds fewer frames than the benchmark has:
// results on it are not the published sequence's, so say it out loud.
void warnIfIncomplete(const Sequence& sequence, const std::string& spec) {
  const int found = static_cast<int>(sequence.frames.size());
  if (sequence.frames_expected <= 0 || found >= sequence.frames_expected) return;
  const std::string fetch = sequence.kind == SequenceKind::Tum
                                ? "fetch the whole sequence with 'tools/fetch_dataset.sh " + spec + "'"
                                : "KITTI needs a registration at cvlibs.net: download the full sequence by hand";
  spdlog::warn("{}: {} holds {} of the sequence's {} frames; results are for those {} only ({})", spec, sequence.root,
               found, sequence.frames_expected, found, fetch);
}

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

int run(RunCommandOptions options) {
  Sequence sequence = openOrFetch(options);
  const size_t total_frames = sequence.frames.size();
  warnIfIncomplete(sequence, options.seq);
  if (options.pipeline.start_frame > 0 && static_cast<size_t>(options.pipeline.start_frame) >= total_frames)
    throw InputError(sequence.root, 0,
                     "--start-frame " + std::to_string(options.pipeline.start_frame) + " is past the sequence's " +
                         std::to_string(total_frames) + " frames");
  const size_t first_frame = static_cast<size_t>(options.pipeline.start_frame);
  if (options.max_frames > 0 && first_frame + options.max_frames < total_frames)
    sequence.frames.resize(first_frame + options.max_frames);
  applyDetectorOptions(options.detector, sequence.config.detector);
  if (!options.vocabulary.empty()) sequence.config.loop.vocabulary = options.vocabulary;
  if (options.no_loop) sequence.config.loop.enabled = false;
  if (options.no_final_ba) sequence.config.loop.final_ba = false;

  if (options.pipeline.mode == "rgbd") {
    if (sequence.kind == SequenceKind::Kitti)
      throw InputError(sequence.root, 0, "--mode rgbd needs depth images, and KITTI sequences have none");
    if (sequence.framesWithDepth() == 0)
      throw InputError(sequence.root + "/depth.txt", 0, "no depth images paired (--mode rgbd needs depth.txt)");
    requireDepthCamera(sequence.config);
    if (!sequence.hasDepth())
      spdlog::warn("--mode rgbd: {} of {} frames have no depth image and are tracked as monocular frames",
                   sequence.frames.size() - sequence.framesWithDepth(), sequence.frames.size());
    sequence.config.sensor = SensorMode::RgbD;
  }

  const PinholeCamera& c = sequence.config.camera;
  std::cout << "sequence: " << sequence.name << "\n";
  std::cout << "root: " << sequence.root << "\n";
  std::cout << "kind: " << (sequence.kind == SequenceKind::Tum ? "tum" : "kitti") << "\n";
  std::cout << "frames: " << sequence.frames.size() - first_frame;
  if (first_frame > 0)
    std::cout << " (" << first_frame << " to " << sequence.frames.size() - 1 << " of " << total_frames << ")";
  else if (sequence.frames.size() != total_frames)
    std::cout << " (first " << sequence.frames.size() << " of " << total_frames << ")";
  std::cout << "\n";
  const double first_t = sequence.frames[first_frame].timestamp, last_t = sequence.frames.back().timestamp;
  std::cout << "time span: " << fixed(first_t, 6) << " .. " << fixed(last_t, 6) << " s (" << fixed(last_t - first_t, 3)
            << " s)\n";
  std::cout << std::setprecision(10) << "camera: " << c.name << " " << c.width << "x" << c.height << " fx " << c.fx
            << " fy " << c.fy << " cx " << c.cx << " cy " << c.cy << " k1 " << c.k1 << " k2 " << c.k2 << " p1 " << c.p1
            << " p2 " << c.p2 << " k3 " << c.k3 << " fps " << c.fps;
  if (c.bf > 0) std::cout << " bf " << c.bf << " (baseline " << c.baseline() << " m, close below " << c.closeDepth() << " m)";
  std::cout << " (" << sequence.config.source << ")\n";
  std::cout << "depth: " << sequence.framesWithDepth() << " of " << sequence.frames.size() << " frames paired\n";
  if (sequence.hasGroundTruth()) {
    const auto& gt = sequence.groundtruth;
    std::cout << "groundtruth: " << gt.size() << " poses, " << fixed(gt.front().timestamp, 6) << " .. "
              << fixed(gt.back().timestamp, 6) << " s (" << fixed(gt.back().timestamp - gt.front().timestamp, 3)
              << " s), path length " << fixed(pathLength(gt), 3) << " m (" << sequence.groundtruth_path << ")\n";
  } else {
    std::cout << "groundtruth: none\n";
  }
  std::cout << "mode: " << options.pipeline.mode << "\n";
  std::cout << "detector: " << runModelName(sequence.config.detector) << "\n";
  std::cout << "deterministic: " << (options.pipeline.deterministic ? "yes" : "no") << "\n";

  std::cout.flush();
  if (options.info_only) return 0;
  return runSlam(sequence, options.pipeline);
}

}  // namespace

Command addRunCommand(CLI::App& app) {
  auto options = std::make_shared<RunCommandOptions>();
  Command command;
  CLI::App* cli = app.add_subcommand("run", "Run SLAM on a sequence");
  cli->add_option("--seq", options->seq,
                  "Sequence: tum/<name> (e.g. tum/fr1_xyz), kitti/<NN> (e.g. kitti/00), bonn/<name> (e.g. "
                  "bonn/crowd), or a folder in TUM or KITTI layout")
      ->required();
  cli->add_option("--config", options->sequence.config_path,
                  "Camera and pipeline YAML (ours or an ORB-SLAM2 settings file) (default: config/<camera>.yaml "
                  "chosen from the sequence name)");
  cli->add_option("--data-root", options->sequence.data_root,
                  "Folder searched first for named sequences (then $VSLAM_DATA, ./data, ../shared/data) (default: "
                  "none)");
  cli->add_option("--mode", options->pipeline.mode, "Sensor mode")
      ->check(CLI::IsMember({"mono", "rgbd"}))
      ->capture_default_str();
  cli->add_option("--out", options->pipeline.out_dir, "Output folder (default: runs/<sequence>-<date>-<time>)");
  addDetectorOptions(*cli, options->detector);
  cli->add_option("--vocabulary", options->vocabulary,
                  "Place-recognition vocabulary (ours or DBoW2's ORBvoc.txt) for relocalisation and loop closing "
                  "(default: the config's loop.vocabulary, vocab/orbvoc_k10_L6.bin, which tools/setup.sh trains where "
                  "the training images are, else the committed vocab/orbvoc.bin)");
  cli->add_flag("--no-loop", options->no_loop, "Disable loop closing (relocalisation stays on)");
  cli->add_flag("--no-final-ba", options->no_final_ba, "Skip the full bundle adjustment after the last frame");
  cli->add_flag("--deterministic", options->pipeline.deterministic,
                "Run the threads in lock-step so that repeated runs give identical results (default: off)");
  cli->add_flag("--realtime", options->pipeline.realtime,
                "Play the sequence at its timestamps like a live camera: frames that arrive while Tracking is busy "
                "are dropped (report.json frames_dropped) and keyframes are skipped while Local Mapping is busy "
                "(default: off, every frame is processed and no keyframe is dropped)");
  cli->add_flag("--no-fetch", options->no_fetch,
                "Do not download a TUM sequence that is not found (default: fetch with tools/fetch_dataset.sh)");
  cli->add_option("--max-frames", options->max_frames, "Process only N frames (the first N, or N from --start-frame); 0 = all")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli->add_flag("--strict", options->pipeline.strict,
                "Fail the run on an unreadable frame, keeping what was computed (default: skip it with a warning; "
                "report.json frames_skipped)");
  cli->add_flag("--no-render", options->pipeline.no_render,
                "Write no PNG figures at the end (default: render them into the output folder, as `vslam render`)");
  cli->add_option("--start-frame", options->pipeline.start_frame,
                  "Start at this frame (0-based position in the sequence); --max-frames counts from it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli->add_option("--load-map", options->pipeline.load_map,
                  "Start in a map saved by `--save-map` (refused when made with another camera, mode or vocabulary): "
                  "the first frame relocalises in it, then mapping continues in it (default: none)");
  cli->add_flag("--localize", options->pipeline.localize,
                "With --load-map: localisation only, as ORB-SLAM2's localisation mode: no keyframe is made and the "
                "map is not changed (report.json frames_localised_in_loaded_map)");
  cli->add_option("--save-map", options->pipeline.save_map,
                  "Save the map at the end (also when interrupted) to this SQLite file, written whole or not at all "
                  "(docs/MAPS.md) (default: none)");
  cli->add_flag("--info", options->info_only,
                "Only find the sequence and print what it holds (frames, camera, ground truth); run nothing "
                "(default: off)");
  command.cli = cli;
  command.run = [options] { return run(*options); };
  return command;
}

}  // namespace vslam::app
