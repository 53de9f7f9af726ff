#pragma once
// Names of the public benchmark sequences: "tum/<short name>" for every TUM
// RGB-D sequence, "kitti/<NN>" for KITTI odometry, each mapped to its folder
// name and to its camera file config/<camera>.yaml.
#include <optional>
#include <string>
#include <vector>

namespace vslam {

struct TumSequenceInfo {
  std::string short_name;    // "fr1_xyz"
  int freiburg = 0;          // 1, 2 or 3: which Kinect recorded it
  std::string archive_name;  // "rgbd_dataset_freiburg1_xyz" (folder and .tgz name)
  std::string camera;        // "tum_fr1"
  int frames = 0;            // colour frames (lines of rgb.txt) of the full sequence; 0 = not in this catalogue
};

// Every sequence of the TUM RGB-D benchmark (validation and calibration ones excluded).
const std::vector<TumSequenceInfo>& tumSequences();

// Accepts "fr1_xyz", "freiburg1_xyz" or "rgbd_dataset_freiburg1_xyz".
std::optional<TumSequenceInfo> findTumSequence(const std::string& name);

// https://cvg.cit.tum.de/rgbd/dataset/freiburgN/<archive>.tgz
std::string tumArchiveUrl(const TumSequenceInfo& sequence);

// KITTI odometry has sequences 00-21 (ground truth for 00-10).
constexpr int kKittiSequenceCount = 22;
// Camera file for a KITTI odometry sequence: kitti_00-02, kitti_03 or kitti_04-12
// (13-21 were recorded with the 04-12 calibration day's setup; calib.txt's P0 overrides the intrinsics anyway).
std::string kittiCameraFor(int sequence_number);
// Frames of KITTI odometry sequence 00-10 (the ones with ground truth); 0 for the others (not in this catalogue).
int kittiFrameCount(int sequence_number);

}  // namespace vslam
