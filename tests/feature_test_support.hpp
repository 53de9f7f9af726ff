#pragma once
// Frames of the TUM sequences for the feature tests and benchmarks (read from
// ../shared at run time).
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/types.hpp"

namespace vslam::test {

struct TumListEntry {
  double stamp = 0;
  std::string path;  // absolute
};

// The `timestamp path` lines of rgb.txt or depth.txt.
inline std::vector<TumListEntry> tumList(const std::string& sequence, const std::string& file) {
  const auto dir = tumSequence(sequence);
  std::ifstream list(dir / file);
  if (!list) throw std::runtime_error("cannot open " + (dir / file).string());
  std::vector<TumListEntry> entries;
  std::string line;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    TumListEntry entry;
    fields >> entry.stamp >> entry.path;
    entry.path = (dir / entry.path).string();
    entries.push_back(entry);
  }
  return entries;
}

// Path of the `index`-th colour image listed in the sequence's rgb.txt.
inline std::string tumRgbPath(const std::string& sequence, int index) {
  const std::vector<TumListEntry> rgb = tumList(sequence, "rgb.txt");
  if (index < 0 || index >= static_cast<int>(rgb.size()))
    throw std::runtime_error("rgb.txt of " + sequence + " has no frame " + std::to_string(index));
  return rgb[index].path;
}

inline double tumRgbStamp(const std::string& sequence, int index) { return tumList(sequence, "rgb.txt").at(index).stamp; }

// The depth image (CV_16U, 5000 per metre) nearest in time to `stamp`.
inline cv::Mat tumDepthNear(const std::string& sequence, double stamp) {
  const std::vector<TumListEntry> depth = tumList(sequence, "depth.txt");
  const TumListEntry* best = nullptr;
  for (const TumListEntry& e : depth)
    if (!best || std::abs(e.stamp - stamp) < std::abs(best->stamp - stamp)) best = &e;
  if (!best || std::abs(best->stamp - stamp) > 0.02) throw std::runtime_error("no depth within 20 ms of the frame");
  cv::Mat image = cv::imread(best->path, cv::IMREAD_UNCHANGED);
  if (image.type() != CV_16U) throw std::runtime_error("cannot read 16-bit depth " + best->path);
  return image;
}

// Ground-truth camera-to-world pose at `stamp`, interpolated (slerp) between
// the motion-capture samples around it.
inline SE3 tumPoseAt(const std::string& sequence, double stamp) {
  std::ifstream file(tumSequence(sequence) / "groundtruth.txt");
  if (!file) throw std::runtime_error("cannot open groundtruth.txt of " + sequence);
  std::string line;
  double t_prev = 0;
  Vec3 p_prev;
  Quat q_prev;
  bool have_prev = false;
  while (std::getline(file, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    double t, x, y, z, qx, qy, qz, qw;
    f >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
    const Vec3 p(x, y, z);
    const Quat q(qw, qx, qy, qz);
    if (t >= stamp) {
      if (!have_prev || t - t_prev > 0.05) throw std::runtime_error("no ground truth around the frame");
      const double a = (stamp - t_prev) / (t - t_prev);
      return SE3(q_prev.slerp(a, q), (1 - a) * p_prev + a * p);
    }
    t_prev = t, p_prev = p, q_prev = q, have_prev = true;
  }
  throw std::runtime_error("no ground truth after the frame");
}

inline cv::Mat tumGray(const std::string& sequence, int index) {
  const std::string path = tumRgbPath(sequence, index);
  cv::Mat gray = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (gray.empty()) throw std::runtime_error("cannot read " + path);
  return gray;
}

}  // namespace vslam::test
