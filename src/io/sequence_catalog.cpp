#include "vslam/io/sequence_catalog.hpp"

namespace vslam {
namespace {

// Only counts checked against a full copy of the sequence are listed (the rest
// are 0, unknown): a wrong count would raise a false "incomplete" warning.
int knownFrameCount(const std::string& short_name) {
  if (short_name == "fr1_xyz") return 798;
  if (short_name == "fr3_long_office_household") return 2585;
  return 0;
}

std::vector<TumSequenceInfo> buildTumTable() {
  // Names as listed on the benchmark's download page, per Kinect.
  const std::vector<std::pair<int, std::vector<const char*>>> by_camera = {
      {1, {"360", "desk", "desk2", "floor", "plant", "room", "rpy", "teddy", "xyz"}},
      {2,
       {"360_hemisphere", "360_kidnap", "coke", "desk", "desk_with_person", "dishes", "flowerbouquet",
        "flowerbouquet_brownbackground", "large_no_loop", "large_with_loop", "metallic_sphere", "metallic_sphere2",
        "pioneer_360", "pioneer_slam", "pioneer_slam2", "pioneer_slam3", "rpy", "teddy", "xyz"}},
      {3,
       {"cabinet",
        "large_cabinet",
        "long_office_household",
        "nostructure_notexture_far",
        "nostructure_notexture_near_withloop",
        "nostructure_texture_far",
        "nostructure_texture_near_withloop",
        "sitting_halfsphere",
        "sitting_rpy",
        "sitting_static",
        "sitting_xyz",
        "structure_notexture_far",
        "structure_notexture_near",
        "structure_texture_far",
        "structure_texture_near",
        "teddy",
        "walking_halfsphere",
        "walking_rpy",
        "walking_static",
        "walking_xyz"}},
  };
  std::vector<TumSequenceInfo> table;
  for (const auto& [freiburg, names] : by_camera) {
    for (const char* name : names) {
      TumSequenceInfo info;
      info.freiburg = freiburg;
      info.short_name = "fr" + std::to_string(freiburg) + "_" + name;
      info.archive_name = "rgbd_dataset_freiburg" + std::to_string(freiburg) + "_" + name;
      info.camera = "tum_fr" + std::to_string(freiburg);
      info.frames = knownFrameCount(info.short_name);
      table.push_back(info);
    }
  }
  return table;
}

}  // namespace

const std::vector<TumSequenceInfo>& tumSequences() {
  static const std::vector<TumSequenceInfo> table = buildTumTable();  // immutable after first use
  return table;
}

std::optional<TumSequenceInfo> findTumSequence(const std::string& name) {
  for (const TumSequenceInfo& info : tumSequences()) {
    const std::string long_name = info.archive_name.substr(std::string("rgbd_dataset_").size());
    if (name == info.short_name || name == long_name || name == info.archive_name) return info;
  }
  return std::nullopt;
}

std::string tumArchiveUrl(const TumSequenceInfo& sequence) {
  return "https://cvg.cit.tum.de/rgbd/dataset/freiburg" + std::to_string(sequence.freiburg) + "/" +
         sequence.archive_name + ".tgz";
}

std::string kittiCameraFor(int sequence_number) {
  if (sequence_number <= 2) return "kitti_00-02";
  if (sequence_number == 3) return "kitti_03";
  return "kitti_04-12";
}

int kittiFrameCount(int sequence_number) {
  // The odometry benchmark's devkit (readme.txt): frames per sequence 00-10.
  static const int kFrames[] = {4541, 1101, 4661, 801, 271, 2761, 1101, 1101, 4071, 1591, 1201};
  return sequence_number >= 0 && sequence_number <= 10 ? kFrames[sequence_number] : 0;
}

}  // namespace vslam
