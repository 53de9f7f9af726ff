#pragma once
// Helpers shared by the place-recognition tests: real ORB descriptors of TUM frames.
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam::test {

// Colour image paths of a TUM sequence, in rgb.txt order (frame i = entry i).
inline std::vector<std::string> tumRgbFrames(const std::string& sequence) {
  const std::filesystem::path dir = tumSequence(sequence);
  std::ifstream list(dir / "rgb.txt");
  if (!list) throw std::runtime_error("missing " + (dir / "rgb.txt").string());
  std::vector<std::string> frames;
  std::string line;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    fields >> stamp >> path;
    frames.push_back((dir / path).string());
  }
  return frames;
}

// ORB descriptors (Config{} defaults: 1000 features) of the given fr3_teddy frames.
inline std::vector<cv::Mat> teddyDescriptors(const std::vector<int>& frame_indices) {
  const std::vector<std::string> frames = tumRgbFrames("freiburg3_teddy");
  const OrbExtractor extractor(Config{}.orb);
  std::vector<cv::Mat> descriptors;
  for (int index : frame_indices) {
    const cv::Mat gray = cv::imread(frames.at(index), cv::IMREAD_GRAYSCALE);
    if (gray.empty()) throw std::runtime_error("cannot read " + frames.at(index));
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat frame_descriptors;
    extractor.extract(gray, keypoints, frame_descriptors);
    descriptors.push_back(frame_descriptors);
  }
  return descriptors;
}

}  // namespace vslam::test
