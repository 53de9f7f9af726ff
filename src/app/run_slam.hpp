#pragma once
// The SLAM part of `vslam run`: feeds a sequence through the System and
// writes the run folder (trajectory, keyframes, map, report).
#include <string>

#include "vslam/io/sequence.hpp"

namespace vslam::app {

struct RunOptions {
  std::string mode = "mono";  // mono | rgbd
  std::string out_dir;        // "" = runs/<sequence>-<time>
  bool deterministic = false;
  // Play the sequence at its timestamps, as a live camera: a frame that arrives
  // while Tracking is still busy with an earlier one is dropped (counted in
  // report.json's frames_dropped), and keyframes are skipped while Local Mapping
  // is busy. Off (the default): every frame is processed, and Tracking waits for
  // Local Mapping rather than drop a keyframe.
  bool realtime = false;
  int max_frames = 0;         // 0 = all
  int start_frame = 0;
  bool no_render = false;     // true: no PNGs at the end (renderRunFolder)
  bool strict = false;        // an unreadable frame fails the run instead of being skipped
  std::string save_map;       // "": none; else the map is saved there (SQLite, docs/MAPS.md), interrupted runs too
  std::string load_map;       // "": start with an empty map; else start in this saved map
  bool localize = false;      // with load_map: localisation only, the map is not changed
};

// Returns the process exit status: 0 completed; 130 / 143 stopped by SIGINT /
// SIGTERM; 2 failed after work had started. Whatever happened, the outputs
// hold what was computed and report.json's "status" says which it was.
// Throws InputError for bad input found before any work (e.g. a missing image).
int runSlam(const Sequence& sequence, const RunOptions& options);

}  // namespace vslam::app
