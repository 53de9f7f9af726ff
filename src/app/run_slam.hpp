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
  int max_frames = 0;         // 0 = all
  int start_frame = 0;
  bool no_render = false;     // true: no PNGs at the end (renderRunFolder)
};

// Returns the process exit status.
int runSlam(const Sequence& sequence, const RunOptions& options);

}  // namespace vslam::app
