// TEMPORARY implementation on cv::ORB so that other modules can build against
// the interface; replaced by our own extractor (even spread, fallback FAST).
#include "vslam/feature/orb_extractor.hpp"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace vslam {

OrbExtractor::OrbExtractor(const OrbParams& params) : params_(params) {
  double scale = 1.0;
  for (int l = 0; l < params_.n_levels; ++l) {
    scale_factors_.push_back(scale);
    level_sigma2_.push_back(scale * scale);
    inv_level_sigma2_.push_back(1.0 / (scale * scale));
    scale *= params_.scale_factor;
  }
}

ImagePyramid OrbExtractor::buildPyramid(const cv::Mat& gray) const {
  ImagePyramid pyramid;
  pyramid.levels.push_back(gray);
  pyramid.scales = scale_factors_;
  for (int l = 1; l < params_.n_levels; ++l) {
    cv::Mat level;
    cv::resize(gray, level, cv::Size(), 1.0 / scale_factors_[l], 1.0 / scale_factors_[l], cv::INTER_LINEAR);
    pyramid.levels.push_back(level);
  }
  return pyramid;
}

void OrbExtractor::extract(const ImagePyramid& pyramid, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                           const cv::Rect& roi, int n_features) const {
  const int n = n_features < 0 ? params_.n_features : n_features;
  auto orb = cv::ORB::create(n, static_cast<float>(params_.scale_factor), params_.n_levels, 19, 0, 2,
                             cv::ORB::HARRIS_SCORE, 31, params_.fast_threshold);
  cv::Mat mask;
  if (!roi.empty()) {
    mask = cv::Mat::zeros(pyramid.levels[0].size(), CV_8U);
    mask(roi & cv::Rect(cv::Point(), mask.size())).setTo(255);
  }
  orb->detectAndCompute(pyramid.levels[0], mask, keypoints, descriptors);
}

}  // namespace vslam
