#pragma once
// ORB features: FAST corners spread evenly over every pyramid level, oriented by
// intensity centroid, described by standard ORB descriptors (256-bit rotated
// BRIEF with ORB's learned pattern, bit for bit as cv::ORB computes them).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"

namespace vslam {

// Image pyramid, built once per frame and shared by whole-frame and per-box
// extraction (the keypoint filter extracts inside detection boxes).
struct ImagePyramid {
  std::vector<cv::Mat> levels;   // levels[0] is the input image (CV_8UC1)
  std::vector<double> scales;    // scales[l] = scale_factor^l
  std::vector<cv::Mat> blurred;  // levels[l] smoothed 7x7, sigma 2: what BRIEF samples
};

// One BRIEF test: bit = I(p1) < I(p2), offsets in pixels from the keypoint
// before rotation.
struct BriefPair {
  std::int8_t x1, y1, x2, y2;
};

// The 256 tests of standard ORB (Rublee et al., ICCV 2011), in order: the
// learned pattern cv::ORB and ORB-SLAM use, so that our descriptors are the
// ones other tools compute and ORB vocabularies quantise. Coordinates lie in
// [-13, 12]; rotated, a point stays within 18.4 px of the centre.
std::vector<BriefPair> standardOrbPattern();

constexpr int kOrbDescriptorBytes = 32;

// A FAST corner a whole-frame extraction found, kept so that extraction in a
// sub-window (a detection box) can reuse it instead of running FAST again.
struct OrbCorner {
  cv::KeyPoint keypoint;   // level pixels, response = FAST score
  cv::Point2f level0;      // its level-0 position
  bool in_frame = false;   // chosen by the frame's own quota (already a frame keypoint)
};

// Every FAST corner of a frame's extraction, per pyramid level.
struct OrbCorners {
  std::vector<std::vector<OrbCorner>> levels;
};

class OrbExtractor {
 public:
  // Keypoints stay this many pixels inside every level, so the rotated test
  // points (|offset| <= 18.4, at most 18 px after rounding) never leave the image.
  static constexpr int kEdgeBorder = 19;
  static constexpr int kPatchRadius = 15;
  static constexpr int kCellSize = 30;  // FAST cells, in level pixels

  explicit OrbExtractor(const OrbParams& params);

  // Levels resized from the previous one (bilinear), sizes round(W / scale^l);
  // also the blurred copies BRIEF samples. Accepts CV_8UC1 or BGR CV_8UC3;
  // throws InputError for an empty image or another type.
  ImagePyramid buildPyramid(const cv::Mat& gray) const;

  // Keypoints come back in level-0 pixel coordinates (raw, i.e. still
  // distorted), with octave = pyramid level, angle in degrees [0, 360),
  // size = 31 * scale and response = FAST score; descriptors are rows of 32
  // bytes (CV_8U) in the same order. `roi` (level-0 pixels) restricts where
  // keypoints may lie (empty: the whole image) and only the ROI is scanned;
  // `n_features` (< 0: params().n_features) is spread over the levels of the
  // ROI like the whole-image quota. const and stateless: safe from several threads.
  // With `corners`, every FAST corner considered (chosen or not) is kept there.
  void extract(const ImagePyramid& pyramid, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
               const cv::Rect& roi = cv::Rect(), int n_features = -1, OrbCorners* corners = nullptr) const;
  void extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
    extract(buildPyramid(gray), keypoints, descriptors);
  }

  // Extraction inside `roi` from the corners a whole-frame extract() kept: the
  // same level quotas and quadtree as extract(roi, n_features), but no FAST
  // run, and orientation and descriptor only for the winners the frame did not
  // already have. Those are returned and marked in_frame in `corners` (they
  // join the frame's keypoints), so an overlapping ROI after this one does not
  // describe them again; `frame_winners` (when given) counts the winners that
  // were in_frame already.
  void extractFromCorners(const ImagePyramid& pyramid, OrbCorners& corners, const cv::Rect& roi, int n_features,
                          std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors, int* frame_winners = nullptr) const;

  const OrbParams& params() const { return params_; }
  int levels() const { return params_.n_levels; }
  const std::vector<double>& scaleFactors() const { return scale_factors_; }
  const std::vector<double>& levelSigma2() const { return level_sigma2_; }          // scale^2
  const std::vector<double>& invLevelSigma2() const { return inv_level_sigma2_; }
  // Features each level should receive out of n_features: a geometric series
  // with ratio 1/scale_factor (finer levels get more), summing to n_features.
  std::vector<int> levelQuotas(int n_features) const;
  const std::vector<BriefPair>& pattern() const { return pattern_; }

  // Descriptors of keypoints given in one level's pixels (pt rounded to the
  // nearest pixel, angle in degrees), sampled on that level's blurred image
  // (ImagePyramid::blurred): what extract() computes for its keypoints, and
  // what cv::ORB::compute gives for the same keypoints on the unblurred level.
  // Throws InputError for a keypoint closer than kEdgeBorder to the border.
  void describe(const cv::Mat& blurred_level, const std::vector<cv::KeyPoint>& level_keypoints,
                cv::Mat& descriptors) const;

 private:
  OrbParams params_;
  std::vector<double> scale_factors_;
  std::vector<double> level_sigma2_;
  std::vector<double> inv_level_sigma2_;
  std::vector<BriefPair> pattern_;
  std::vector<float> pattern_x_, pattern_y_;  // the 512 test points, pair i = points 2i and 2i+1
  std::vector<int> circle_half_width_;  // per row v of the radius-15 disc: largest |u| inside

  // The ROI of level `level` in its own pixels, kept kEdgeBorder inside it (may be empty).
  cv::Rect levelRegion(const ImagePyramid& pyramid, int level, const cv::Rect& area) const;
  // Octave, size and intensity-centroid angle of a chosen corner of level `level`.
  void orient(const ImagePyramid& pyramid, int level, OrbCorner& corner) const;
  // Rotated BRIEF of oriented corners, in order; keypoints get their level-0 positions.
  void describe(const ImagePyramid& pyramid, const std::vector<OrbCorner>& kept, std::vector<cv::KeyPoint>& keypoints,
                cv::Mat& descriptors) const;
};

}  // namespace vslam
