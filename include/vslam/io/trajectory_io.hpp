#pragma once
// Trajectory files (camera-to-world poses T_wc):
//  - TUM:   one pose a line, "timestamp tx ty tz qx qy qz qw", '#' comments.
//  - KITTI: one pose a line, the 12 numbers of the 3x4 matrix [R|t], row-major;
//           line i belongs to frame i.
// Readers throw InputError "FILE:LINE: what is wrong" on a malformed line,
// a timestamp that does not increase, or a rotation that is not one.
#include <istream>
#include <string>
#include <vector>

#include "vslam/core/types.hpp"

namespace vslam {

std::vector<StampedPose> readTumTrajectory(const std::string& path);
// From a stream; `name` is the file named in errors.
std::vector<StampedPose> readTumTrajectory(std::istream& in, const std::string& name);

// Timestamps with 6 decimals ("%.6f", microseconds as the benchmark writes them),
// every other number with 9 significant digits.
void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses);

// `timestamps`: one per line (e.g. times.txt); empty means timestamp = line index.
// A count that differs from the number of poses is an error.
std::vector<StampedPose> readKittiTrajectory(const std::string& path, const std::vector<double>& timestamps = {});
std::vector<StampedPose> readKittiTrajectory(std::istream& in, const std::string& name,
                                             const std::vector<double>& timestamps = {});

// 12 numbers a line with 9 significant digits; timestamps are not written.
void writeKittiTrajectory(const std::string& path, const std::vector<StampedPose>& poses);

// A KITTI file holds no frame numbers: line i is frame i. A trajectory with lost
// frames has fewer lines, and its frame index file says which frame each line is:
// one 0-based frame index a line (the line of poses/NN.txt), increasing, no header.
// The index file of "DIR/NAME.txt" is "DIR/NAME_frames.txt".
std::string kittiFrameIndexPath(const std::string& trajectory_path);
// Throws InputError naming the line of an entry that is not a non-negative
// integer or does not increase.
std::vector<int> readFrameIndexFile(const std::string& path);
void writeFrameIndexFile(const std::string& path, const std::vector<int>& frames);

}  // namespace vslam
