#pragma once
// The figures of a run folder, as `vslam render RUN_DIR` and the end of
// `vslam run` write them. Reads whichever of these exist:
//   trajectory.txt  estimate, TUM format (timestamp tx ty tz qx qy qz qw, T_wc)
//   report.json     {"sequence", "mode", "ate", "groundtruth_file"}
//   keyframes.txt   keyframe poses, TUM format (a leading id column is tolerated)
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

// Local stand-ins until the eval module lands (the lead will switch to it).
// TUM trajectory file; InputError names file and line on malformed lines.
std::vector<StampedPose> readTumTrajectory(const std::string& path);
// (estimate index, ground-truth index) pairs by timestamp as TUM's associate.py
// makes them: closest pairs first, each pose used once, |dt| <= max_dt; sorted
// by estimate index. Both inputs sorted by time.
std::vector<std::pair<size_t, size_t>> associateByTimestamp(const std::vector<StampedPose>& estimate,
                                                            const std::vector<StampedPose>& groundtruth,
                                                            double max_dt = 0.02);

}  // namespace vslam
