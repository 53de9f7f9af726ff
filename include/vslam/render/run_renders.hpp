#pragma once
// The figures of a run folder, as `vslam render RUN_DIR` and the end of
// `vslam run` write them. Reads whichever of these exist:
//   trajectory.txt  estimate, TUM format (timestamp tx ty tz qx qy qz qw, T_wc)
//   report.json     {"sequence", "mode", "ate", "groundtruth_file"}
//   keyframes.txt   keyframe poses, TUM format
//   map.ply         map points (io/ply.hpp)
//   objects.json    [{"class", "confidence", "centroid", "box_min", "box_max", "points", "keyframes"}]
// and writes trajectory_top.png, trajectory_3d.png (with trajectory.txt) and
// map_colour.png, map_classes.png, map_top.png (with map.ply or keyframes or objects).
#include <string>
#include <vector>

#include "vslam/core/types.hpp"

namespace vslam {

// Returns the paths written. Throws InputError naming the file for unreadable
// or malformed inputs; a missing optional file only skips its part.
std::vector<std::string> renderRunFolder(const std::string& run_dir, const std::string& out_dir);

}  // namespace vslam
