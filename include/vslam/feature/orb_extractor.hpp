#pragma once
// ORB features: FAST corners spread evenly over every pyramid level, oriented by
// intensity centroid, described by 256-bit rotated BRIEF.
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"

namespace vslam {

// Image pyramid, built once per frame and shared by whole-frame and per-box
// extraction (the keypoint filter extracts inside detection boxes).
struct ImagePyramid {
  std::vector<cv::Mat> levels;  // levels[0] is the input image (CV_8UC1)
  std::vector<double> scales;   // scales[l] = scale_factor^l
};

class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbParams& params);

  ImagePyramid buildPyramid(const cv::Mat& gray) const;

  // Keypoints come back in level-0 pixel coordinates, with octave = pyramid
  // level and angle in degrees; descriptors are rows of 32 bytes (CV_8U).
  // `roi` (level-0 pixels) restricts where keypoints may lie (empty: the whole
  // image); `n_features` < 0 means params().n_features.
  void extract(const ImagePyramid& pyramid, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
               const cv::Rect& roi = cv::Rect(), int n_features = -1) const;
  void extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
    extract(buildPyramid(gray), keypoints, descriptors);
  }

  const OrbParams& params() const { return params_; }
  int levels() const { return params_.n_levels; }
  const std::vector<double>& scaleFactors() const { return scale_factors_; }
  const std::vector<double>& levelSigma2() const { return level_sigma2_; }          // scale^2
  const std::vector<double>& invLevelSigma2() const { return inv_level_sigma2_; }

 private:
  OrbParams params_;
  std::vector<double> scale_factors_;
  std::vector<double> level_sigma2_;
  std::vector<double> inv_level_sigma2_;
};

}  // namespace vslam
