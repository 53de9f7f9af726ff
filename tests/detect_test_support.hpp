#pragma once
// The photo the detector tests run on (read from ../shared at run time): a
// dog, a bicycle and a car, 768x576; and its frame as the ORB extractor sees
// it, for the keypoint-filter tests.
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam::test {

inline std::string dogImagePath() { return (sharedData() / "images/dog.jpg").string(); }

// As cv::imread reads it with `flags`: empty when the file is missing, which
// the tests check.
inline cv::Mat dogImage(int flags = cv::IMREAD_COLOR) { return cv::imread(dogImagePath(), flags); }

// The grey photo through the default ORB extractor: its pyramid, the frame's
// own keypoints and descriptors, and the FAST corners the extraction kept
// (which change nothing about the frame's keypoints).
struct DogFrame {
  cv::Mat image;
  OrbExtractor extractor{OrbParams{}};
  ImagePyramid pyramid;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  OrbCorners corners;
};

// Only the (empty) image when the photo cannot be read.
inline DogFrame dogFrame() {
  DogFrame frame;
  frame.image = dogImage(cv::IMREAD_GRAYSCALE);
  if (frame.image.empty()) return frame;
  frame.pyramid = frame.extractor.buildPyramid(frame.image);
  frame.extractor.extract(frame.pyramid, frame.keypoints, frame.descriptors, cv::Rect(), -1, &frame.corners);
  return frame;
}

}  // namespace vslam::test
