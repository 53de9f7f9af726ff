#pragma once
// The index files of a sequence folder, parsed from their rows (text_table.hpp):
// TUM's rgb.txt / depth.txt and KITTI's times.txt and calib.txt. openSequence
// reads the files; these parsers see only their text, so the fuzz targets
// (tests/fuzz/) can feed them without a folder. Each throws InputError
// "FILE:LINE: what is wrong", FILE being the `file` passed in.
#include <string>
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/io/text_table.hpp"

namespace vslam {

// One line of rgb.txt / depth.txt: "timestamp relative/path".
struct ListedImage {
  double timestamp = 0.0;
  std::string path;  // `root` joined with the listed path, normalised
  int line = 0;
};

// Timestamps must increase; an empty list is an error.
std::vector<ListedImage> parseTumImageList(const std::vector<TextRow>& rows, const std::string& file,
                                           const std::string& root);

// One increasing timestamp a line; an empty list is an error.
std::vector<double> parseKittiTimes(const std::vector<TextRow>& rows, const std::string& file);

// The intrinsics of the "P0:" line (left grey camera) override `camera`'s;
// a "P1:" line gives bf. A missing P0 is an error.
void parseKittiCalibration(const std::vector<TextRow>& rows, const std::string& file, PinholeCamera& camera);

}  // namespace vslam
