#pragma once
// Matching primitives over keypoints and 32-byte ORB descriptors, free of map
// types: Hamming distance, a grid for area queries, the rotation-consistency
// check, window matching for map initialisation, brute-force ratio matching and
// the epipolar search for triangulation. Positions are undistorted pixels.
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

constexpr int kHammingThresholdLow = 50;    // a confident match (ORB-SLAM's TH_LOW)
// A confident match of a feature that a geometric test or the vocabulary has
// already picked out: a map point projected into a keyframe (fusion, loop
// fusion), features on an epipolar line (triangulation), features sharing a
// vocabulary word (relocalisation, tracking from the reference keyframe). The
// pipeline was tuned with random BRIEF tests, whose distances are ~0.6 times
// those of standard ORB's decorrelated ones: there TH_LOW admitted 83 % of the
// ground-truth matches between fr3_teddy frames 1 apart and 66 % 10 apart,
// standard ORB admits 66 % and 36 %. 70 gives back the share of true matches
// (83 %, 59 %) and lets fewer wrong ones through (41 % of the nearest
// non-matches within 15 px, the random pattern let 54 % through). At 50, fusion
// missed duplicates: RGB-D fr3_teddy keyframe ATE 0.9-1.8 cm against
// 0.6-0.7 cm at 70 (docs/BENCHMARKS.md).
constexpr int kHammingThresholdGuided = 70;
// The window search that initialises a monocular map has no geometric test
// before it, so it stays stricter. Over fr1_xyz frames 0->1 ... 10->11 it found
// 791 matches at TH_LOW (the random pattern at 50: 927, 87.8 % within 1.96 px
// of each pair's F), 846 at 55 (91.7 %), 890 at 60 (89.0 %). The start itself
// is fragile whatever the threshold: at 60 fr3_teddy with the detector on
// started from frames 0 and 1 (1.1 deg of parallax) and ended 15.9 cm off, at
// 50 and 55 it started 1-2 frames later and ended 1.0-1.1 cm off; at 50 and
// 55 fr3_long_office_household's 16 shared frames never start (docs/BENCHMARKS.md).
constexpr int kHammingThresholdWindow = 55;
constexpr int kHammingThresholdHigh = 100;  // a loose one, for search by projection (TH_HIGH)
constexpr double kChi2OneDof95 = 3.84;      // epipolar distance^2 < 3.84 sigma^2 (95 %, 1 DoF)

// Bits that differ between two 32-byte descriptors.
inline int hammingDistance(const std::uint8_t* a, const std::uint8_t* b) {
  int distance = 0;
  for (int i = 0; i < 4; ++i) {
    std::uint64_t wa, wb;  // memcpy: descriptor rows need not be 8-byte aligned
    std::memcpy(&wa, a + 8 * i, 8);
    std::memcpy(&wb, b + 8 * i, 8);
    distance += __builtin_popcountll(wa ^ wb);
  }
  return distance;
}
// Rows of CV_8U descriptor matrices (1 x 32).
inline int hammingDistance(const cv::Mat& a_row, const cv::Mat& b_row) {
  CV_DbgAssert(a_row.type() == CV_8U && b_row.type() == CV_8U && a_row.total() == 32 && b_row.total() == 32);
  return hammingDistance(a_row.ptr<std::uint8_t>(), b_row.ptr<std::uint8_t>());
}

// Nearest and second-nearest of `candidates` (row indices of `descriptors`) to
// `descriptor`, for search-by-projection loops: built with POPCNT where the CPU
// has it (see matcher.cpp), which the inline hammingDistance in a caller's
// loop is not unless the whole build uses -mpopcnt. Ties keep the earlier
// candidate. index = -1 when there is no candidate; second_index = -1 when only one.
struct NearestTwo {
  int index = -1, distance = 256;
  int second_index = -1, second_distance = 256;
};
NearestTwo nearestTwo(const std::uint8_t* descriptor, const cv::Mat& descriptors, const std::vector<int>& candidates);

// The features of one frame or keyframe as the matchers see them.
struct FeatureView {
  const std::vector<cv::KeyPoint>& keypoints;  // octave (level) and angle are used; pt is not
  const std::vector<cv::Point2f>& points;      // undistorted positions, same order
  const cv::Mat& descriptors;                  // one 32-byte row per keypoint
};

// Image bounds of the undistorted keypoints: the box around the undistorted
// image border (wider or narrower than the image under distortion).
cv::Rect2f undistortedImageBounds(const PinholeCamera& camera);

// Features bucketed in cells over the image for fast area queries.
class FeatureGrid {
 public:
  FeatureGrid() = default;
  // `levels` may be empty (all level 0). Points outside `bounds` go to the
  // nearest border cell, so a query never misses one.
  FeatureGrid(std::vector<cv::Point2f> points, std::vector<int> levels, const cv::Rect2f& bounds, int cols = 64,
              int rows = 48);

  // Indices of the features with |x - px| <= radius and |y - py| <= radius
  // (a square, as ORB-SLAM's search window) and min_level <= level <= max_level;
  // a negative bound is no bound. Ordered by cell, then by index.
  std::vector<int> featuresInArea(float x, float y, float radius, int min_level = -1, int max_level = -1) const;

  int size() const { return static_cast<int>(points_.size()); }
  const cv::Point2f& point(int index) const { return points_[index]; }
  int level(int index) const { return levels_.empty() ? 0 : levels_[index]; }

 private:
  int cellCol(float x) const;
  int cellRow(float y) const;

  std::vector<cv::Point2f> points_;
  std::vector<int> levels_;
  cv::Rect2f bounds_;
  int cols_ = 0, rows_ = 0;
  std::vector<int> cell_begin_;  // features of cell c: cell_items_[cell_begin_[c], cell_begin_[c + 1])
  std::vector<int> cell_items_;
};

// Rotation consistency: true matches between two views share one in-plane
// rotation, so their angle differences pile up in one histogram bin (or its
// neighbours). Keeps the three fullest bins, the second and third only when
// they hold at least a tenth of the first (ORB-SLAM's rule); the rest are
// rejected. Bins are centred: bin 0 holds differences within +-6 degrees of 0.
class RotationHistogram {
 public:
  explicit RotationHistogram(int bins = 30);

  // Adds a match by the angles (degrees) of its two keypoints.
  void add(float angle1_deg, float angle2_deg, int match_index);
  int binOf(float angle1_deg, float angle2_deg) const;

  std::vector<int> keptBins() const;             // fullest first
  std::vector<int> rejectedMatches() const;      // match indices outside the kept bins, ascending
  std::vector<int> consistentMatches() const;    // the others, ascending

 private:
  std::vector<std::vector<int>> bins_;
};

struct WindowMatchParams {
  float window = 100.f;  // px around the previous position (ORB-SLAM initialisation: 100)
  float ratio = 0.9f;    // best < ratio * second best
  int max_distance = kHammingThresholdWindow;
  bool check_orientation = true;
  // Coarsest pyramid level searched; each feature is matched within its own
  // level. ORB-SLAM uses the finest only (0).
  int max_level = 0;
};

struct WindowMatches {
  std::vector<int> matches12;  // per frame-1 feature: index in frame 2, or -1
  int count = 0;
};

// Matching for map initialisation. For every feature of frame 1 at a level up
// to params.max_level (0: the finest only, as ORB-SLAM), candidates are the
// features of frame 2 at the same level (from grid2) within `window` of
// prev_matched[i1] (start with frame 1's own points). The best must pass the
// absolute threshold and the ratio test; a frame-2 feature claimed twice keeps
// the closer; survivors pass the rotation check. prev_matched is updated to the
// matched positions in frame 2, as ORB-SLAM does, for the next frame's search.
WindowMatches matchInWindow(const FeatureView& frame1, const FeatureView& frame2, const FeatureGrid& grid2,
                            std::vector<cv::Point2f>& prev_matched, const WindowMatchParams& params = {});

// Brute force, for small sets: each row of desc1 to its nearest row of desc2
// when the distance is <= max_distance and < ratio * second nearest; a row of
// desc2 claimed twice keeps the closer. DMatch: queryIdx in 1, trainIdx in 2.
std::vector<cv::DMatch> matchByRatio(const cv::Mat& descriptors1, const cv::Mat& descriptors2, float ratio,
                                     int max_distance);

// --- Epipolar geometry. F21 maps a point of image 1 to its epipolar line in
// image 2, l2 = F21 (x1, y1, 1)^T, so that x2^T F21 x1 = 0: the convention of
// cv::findFundamentalMat(points1, points2).

// From the world->camera poses of the two views and their intrinsics.
cv::Matx33d fundamentalFromPoses(const SE3& T_1w, const SE3& T_2w, const Mat3& K1, const Mat3& K2);

// Squared pixel distance from p2 to the epipolar line of p1 (infinite for a
// degenerate line).
double epipolarDistanceSquared(const cv::Matx33d& F21, const cv::Point2f& p1, const cv::Point2f& p2);

// The 3.84 sigma^2 rule: sigma2_level2 is the variance of p2's level (scale^2).
inline bool isEpipolarConsistent(const cv::Matx33d& F21, const cv::Point2f& p1, const cv::Point2f& p2,
                                 double sigma2_level2) {
  return epipolarDistanceSquared(F21, p1, p2) < kChi2OneDof95 * sigma2_level2;
}

struct TriangulationSearchParams {
  float ratio = 0.8f;  // among the epipolar-consistent candidates
  int max_distance = kHammingThresholdLow;  // Local Mapping passes kHammingThresholdGuided
  double min_epipole_distance = 10.0;  // px at level 0, times the level's scale
  bool check_orientation = true;
};

// Pairs (i1, i2) of features not yet matched (matched1/2 true = skip; empty =
// none matched) for triangulating new points. Brute force over all pairs,
// vocabulary-free: a candidate must lie near the epipolar line of i1 (3.84
// sigma^2 at its level) and not near the epipole of view 2 (where depth is
// ill-conditioned); the best must pass max_distance and the ratio test against
// the second-best candidate; frame-2 features claimed twice keep the closer;
// then the rotation check. level_sigma2: OrbExtractor::levelSigma2().
std::vector<std::pair<int, int>> searchForTriangulation(const FeatureView& view1, const FeatureView& view2,
                                                        const cv::Matx33d& F21, const std::vector<double>& level_sigma2,
                                                        const std::vector<bool>& matched1 = {},
                                                        const std::vector<bool>& matched2 = {},
                                                        const TriangulationSearchParams& params = {});

}  // namespace vslam
