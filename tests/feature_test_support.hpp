#pragma once
// Frames of the TUM sequences for the feature tests and benchmarks (read from
// ../shared at run time).
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"

namespace vslam::test {

// Path of the `index`-th colour image listed in the sequence's rgb.txt.
inline std::string tumRgbPath(const std::string& sequence, int index) {
  const auto dir = tumSequence(sequence);
  std::ifstream list(dir / "rgb.txt");
  if (!list) throw std::runtime_error("cannot open " + (dir / "rgb.txt").string());
  std::string line;
  int seen = 0;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (seen++ < index) continue;
    std::istringstream fields(line);
    std::string stamp, path;
    fields >> stamp >> path;
    return (dir / path).string();
  }
  throw std::runtime_error("rgb.txt of " + sequence + " has no frame " + std::to_string(index));
}

inline cv::Mat tumGray(const std::string& sequence, int index) {
  const std::string path = tumRgbPath(sequence, index);
  cv::Mat gray = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (gray.empty()) throw std::runtime_error("cannot read " + path);
  return gray;
}

}  // namespace vslam::test
