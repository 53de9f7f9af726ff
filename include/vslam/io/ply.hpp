#pragma once
// The run folder's map.ply: one vertex per map point.
//
// Written as binary little-endian PLY with, per vertex,
//   float x, y, z; uchar red, green, blue; int class_id   (class_id -1 = none)
// (colours are stored red, green, blue as PLY viewers expect; PlyPoint holds
// them in OpenCV's BGR order). The reader also takes ASCII and big-endian
// files and the x y z [red green blue] vertices other tools write
// (CloudCompare, MeshLab, Open3D): extra properties and elements are skipped,
// float colours in [0, 1] are scaled to 0..255, a missing colour is black and a
// missing class_id is -1.
#include <istream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"

namespace vslam {

struct PlyPoint {
  Vec3 position = Vec3::Zero();
  cv::Vec3b bgr = cv::Vec3b(0, 0, 0);
  int class_id = -1;
};

// Throws std::runtime_error naming the file when it cannot be written.
void writeMapPly(const std::string& path, const std::vector<PlyPoint>& points);

// Throws InputError naming the file (and the header line or vertex) on a
// missing file, a malformed header, a vertex without x/y/z, or truncated data.
std::vector<PlyPoint> readMapPly(const std::string& path);
// The same from a stream opened in binary mode; `name` is the file named in errors.
std::vector<PlyPoint> readMapPly(std::istream& in, const std::string& name);

}  // namespace vslam
