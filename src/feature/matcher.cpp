#include "vslam/feature/matcher.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "vslam/core/error.hpp"

// The brute-force loops are dominated by hammingDistance. Unless the whole build
// targets a CPU with POPCNT (-mpopcnt, -march=x86-64-v2), GCC expands
// __builtin_popcountll to ~12 bit operations; cloning these functions for POPCNT
// (picked at load time, with a plain fallback) makes them ~5x faster.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && !defined(__POPCNT__)
#define VSLAM_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define VSLAM_POPCNT_CLONES
#endif

namespace vslam {
namespace {

const std::uint8_t* row(const cv::Mat& descriptors, int index) { return descriptors.ptr<std::uint8_t>(index); }

void checkDescriptors(const cv::Mat& descriptors, std::size_t expected_rows, const char* what) {
  if (descriptors.empty() && expected_rows == 0) return;
  if (descriptors.type() != CV_8U || descriptors.cols != 32 || descriptors.rows != static_cast<int>(expected_rows))
    throw InputError(std::string(what) + ": descriptors must be CV_8U, 32 columns, one row per keypoint");
}

void checkView(const FeatureView& view, const char* what) {
  if (view.points.size() != view.keypoints.size())
    throw InputError(std::string(what) + ": keypoints and undistorted points differ in number");
  checkDescriptors(view.descriptors, view.keypoints.size(), what);
}

// Null vector of the 3x3 matrix m (unit norm), from its SVD.
cv::Vec3d nullVector(const cv::Matx33d& m) {
  cv::Matx33d u, vt;
  cv::Matx31d w;
  cv::SVD::compute(m, w, u, vt, cv::SVD::FULL_UV);
  return cv::Vec3d(vt(2, 0), vt(2, 1), vt(2, 2));
}

}  // namespace

cv::Rect2f undistortedImageBounds(const PinholeCamera& camera) {
  const float w = static_cast<float>(camera.width), h = static_cast<float>(camera.height);
  if (!camera.hasDistortion()) return cv::Rect2f(0.f, 0.f, w, h);
  // Corners and edge midpoints: barrel distortion moves the corners most, pincushion the midpoints.
  const std::vector<cv::Point2f> border = {{0, 0}, {w / 2, 0}, {w, 0}, {w, h / 2}, {w, h}, {w / 2, h}, {0, h}, {0, h / 2}};
  const std::vector<cv::Point2f> undistorted = camera.undistort(border);
  float x0 = undistorted[0].x, x1 = x0, y0 = undistorted[0].y, y1 = y0;
  for (const cv::Point2f& p : undistorted) {
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  return cv::Rect2f(x0, y0, x1 - x0, y1 - y0);
}

VSLAM_POPCNT_CLONES NearestTwo nearestTwo(const std::uint8_t* descriptor, const cv::Mat& descriptors,
                                          const std::vector<int>& candidates) {
  NearestTwo result;
  for (int index : candidates) {
    const int d = hammingDistance(descriptor, row(descriptors, index));
    if (result.index < 0 || d < result.distance) {
      result.second_index = result.index, result.second_distance = result.distance;
      result.index = index, result.distance = d;
    } else if (result.second_index < 0 || d < result.second_distance) {
      result.second_index = index, result.second_distance = d;
    }
  }
  return result;
}

// ---------------------------------------------------------------- FeatureGrid

FeatureGrid::FeatureGrid(std::vector<cv::Point2f> points, std::vector<int> levels, const cv::Rect2f& bounds, int cols,
                         int rows)
    : points_(std::move(points)), levels_(std::move(levels)), bounds_(bounds), cols_(cols), rows_(rows) {
  if (!levels_.empty() && levels_.size() != points_.size())
    throw InputError("FeatureGrid: levels must be empty or one per point");
  if (cols_ < 1 || rows_ < 1 || !(bounds_.width > 0) || !(bounds_.height > 0))
    throw InputError("FeatureGrid: need a non-empty bounds rectangle and at least one cell");
  // Counting sort into cells: compact, and each cell lists its features by index.
  std::vector<int> cell_of(points_.size());
  cell_begin_.assign(static_cast<std::size_t>(cols_) * rows_ + 1, 0);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    cell_of[i] = cellRow(points_[i].y) * cols_ + cellCol(points_[i].x);
    ++cell_begin_[cell_of[i] + 1];
  }
  std::partial_sum(cell_begin_.begin(), cell_begin_.end(), cell_begin_.begin());
  cell_items_.resize(points_.size());
  std::vector<int> fill(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < points_.size(); ++i) cell_items_[fill[cell_of[i]]++] = static_cast<int>(i);
}

int FeatureGrid::cellCol(float x) const {
  const float c = std::floor((x - bounds_.x) * static_cast<float>(cols_) / bounds_.width);
  if (!(c >= 0.f)) return 0;  // also NaN
  return static_cast<int>(std::min(c, static_cast<float>(cols_ - 1)));
}

int FeatureGrid::cellRow(float y) const {
  const float r = std::floor((y - bounds_.y) * static_cast<float>(rows_) / bounds_.height);
  if (!(r >= 0.f)) return 0;
  return static_cast<int>(std::min(r, static_cast<float>(rows_ - 1)));
}

std::vector<int> FeatureGrid::featuresInArea(float x, float y, float radius, int min_level, int max_level) const {
  std::vector<int> found;
  if (points_.empty() || !(radius >= 0) || !std::isfinite(x) || !std::isfinite(y)) return found;
  // Clamping maps out-of-bounds points to border cells, so clamped query cells cover them too.
  const int c0 = cellCol(x - radius), c1 = cellCol(x + radius);
  const int r0 = cellRow(y - radius), r1 = cellRow(y + radius);
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const int cell = r * cols_ + c;
      for (int k = cell_begin_[cell]; k < cell_begin_[cell + 1]; ++k) {
        const int i = cell_items_[k];
        const int lvl = level(i);
        if ((min_level >= 0 && lvl < min_level) || (max_level >= 0 && lvl > max_level)) continue;
        if (std::abs(points_[i].x - x) <= radius && std::abs(points_[i].y - y) <= radius) found.push_back(i);
      }
    }
  }
  return found;
}

// ---------------------------------------------------------- RotationHistogram

RotationHistogram::RotationHistogram(int bins) : bins_(static_cast<std::size_t>(std::max(1, bins))) {}

int RotationHistogram::binOf(float angle1_deg, float angle2_deg) const {
  const int n = static_cast<int>(bins_.size());
  if (!std::isfinite(angle1_deg) || !std::isfinite(angle2_deg)) return 0;
  double difference = std::fmod(static_cast<double>(angle1_deg) - angle2_deg, 360.0);
  if (difference < 0) difference += 360.0;
  const int bin = static_cast<int>(std::floor(difference * n / 360.0 + 0.5));
  return bin % n;
}

void RotationHistogram::add(float angle1_deg, float angle2_deg, int match_index) {
  bins_[binOf(angle1_deg, angle2_deg)].push_back(match_index);
}

std::vector<int> RotationHistogram::keptBins() const {
  std::vector<int> order(bins_.size());
  std::iota(order.begin(), order.end(), 0);
  // Fullest first; stable, so equal bins keep ascending index order.
  std::stable_sort(order.begin(), order.end(), [this](int a, int b) { return bins_[a].size() > bins_[b].size(); });
  std::vector<int> kept;
  if (order.empty() || bins_[order[0]].empty()) return kept;
  const std::size_t fullest = bins_[order[0]].size();
  kept.push_back(order[0]);
  for (std::size_t k = 1; k < std::min<std::size_t>(3, order.size()); ++k) {
    const std::size_t count = bins_[order[k]].size();
    if (count > 0 && 10 * count >= fullest) kept.push_back(order[k]);
  }
  return kept;
}

std::vector<int> RotationHistogram::rejectedMatches() const {
  const std::vector<int> kept = keptBins();
  std::vector<int> rejected;
  for (int b = 0; b < static_cast<int>(bins_.size()); ++b)
    if (std::find(kept.begin(), kept.end(), b) == kept.end())
      rejected.insert(rejected.end(), bins_[b].begin(), bins_[b].end());
  std::sort(rejected.begin(), rejected.end());
  return rejected;
}

std::vector<int> RotationHistogram::consistentMatches() const {
  std::vector<int> consistent;
  for (int b : keptBins()) consistent.insert(consistent.end(), bins_[b].begin(), bins_[b].end());
  std::sort(consistent.begin(), consistent.end());
  return consistent;
}

// -------------------------------------------------------------- matchInWindow

VSLAM_POPCNT_CLONES WindowMatches matchInWindow(const FeatureView& frame1, const FeatureView& frame2, const FeatureGrid& grid2,
                            std::vector<cv::Point2f>& prev_matched, const WindowMatchParams& params) {
  checkView(frame1, "matchInWindow (frame 1)");
  checkView(frame2, "matchInWindow (frame 2)");
  const int n1 = static_cast<int>(frame1.keypoints.size());
  const int n2 = static_cast<int>(frame2.keypoints.size());
  if (static_cast<int>(prev_matched.size()) != n1)
    throw InputError("matchInWindow: prev_matched needs one point per frame-1 feature");
  if (grid2.size() != n2) throw InputError("matchInWindow: grid2 was not built from frame 2's features");

  WindowMatches result;
  result.matches12.assign(n1, -1);
  std::vector<int> matches21(n2, -1);
  std::vector<int> distance21(n2, std::numeric_limits<int>::max());

  for (int i1 = 0; i1 < n1; ++i1) {
    const int level = frame1.keypoints[i1].octave;
    if (level > params.max_level) continue;
    const std::vector<int> candidates =
        grid2.featuresInArea(prev_matched[i1].x, prev_matched[i1].y, params.window, level, level);
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), best_i2 = -1;
    for (int i2 : candidates) {
      const int d = hammingDistance(row(frame1.descriptors, i1), row(frame2.descriptors, i2));
      if (distance21[i2] <= d) continue;  // already taken by a closer frame-1 feature
      if (d < best) {
        second = best, best = d, best_i2 = i2;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_i2 < 0 || best > params.max_distance) continue;
    if (static_cast<float>(best) >= params.ratio * static_cast<float>(second)) continue;
    // A frame-2 feature claimed before by a worse match moves to this one.
    if (matches21[best_i2] >= 0) {
      result.matches12[matches21[best_i2]] = -1;
      --result.count;
    }
    result.matches12[i1] = best_i2;
    matches21[best_i2] = i1;
    distance21[best_i2] = best;
    ++result.count;
  }

  if (params.check_orientation) {
    RotationHistogram histogram;
    for (int i1 = 0; i1 < n1; ++i1)
      if (result.matches12[i1] >= 0)
        histogram.add(frame1.keypoints[i1].angle, frame2.keypoints[result.matches12[i1]].angle, i1);
    for (int i1 : histogram.rejectedMatches()) {
      result.matches12[i1] = -1;
      --result.count;
    }
  }

  for (int i1 = 0; i1 < n1; ++i1)
    if (result.matches12[i1] >= 0) prev_matched[i1] = frame2.points[result.matches12[i1]];
  return result;
}

// --------------------------------------------------------------- matchByRatio

VSLAM_POPCNT_CLONES std::vector<cv::DMatch> matchByRatio(const cv::Mat& descriptors1, const cv::Mat& descriptors2, float ratio,
                                     int max_distance) {
  checkDescriptors(descriptors1, static_cast<std::size_t>(descriptors1.rows), "matchByRatio (set 1)");
  checkDescriptors(descriptors2, static_cast<std::size_t>(descriptors2.rows), "matchByRatio (set 2)");
  std::vector<int> matches21(descriptors2.rows, -1);
  std::vector<cv::DMatch> matches;
  for (int i1 = 0; i1 < descriptors1.rows; ++i1) {
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), best_i2 = -1;
    for (int i2 = 0; i2 < descriptors2.rows; ++i2) {
      const int d = hammingDistance(row(descriptors1, i1), row(descriptors2, i2));
      if (d < best) {
        second = best, best = d, best_i2 = i2;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_i2 < 0 || best > max_distance) continue;
    if (static_cast<float>(best) >= ratio * static_cast<float>(second)) continue;
    const int previous = matches21[best_i2];
    if (previous >= 0) {
      if (matches[previous].distance <= static_cast<float>(best)) continue;
      matches[previous].queryIdx = -1;  // displaced; removed below
    }
    matches21[best_i2] = static_cast<int>(matches.size());
    matches.emplace_back(i1, best_i2, static_cast<float>(best));
  }
  matches.erase(std::remove_if(matches.begin(), matches.end(), [](const cv::DMatch& m) { return m.queryIdx < 0; }),
                matches.end());
  return matches;
}

// ---------------------------------------------------------- epipolar geometry

cv::Matx33d fundamentalFromPoses(const SE3& T_1w, const SE3& T_2w, const Mat3& K1, const Mat3& K2) {
  const SE3 T_21 = T_2w * T_1w.inverse();
  Mat3 t_cross;
  t_cross << 0, -T_21.t.z(), T_21.t.y(), T_21.t.z(), 0, -T_21.t.x(), -T_21.t.y(), T_21.t.x(), 0;
  const Mat3 essential = t_cross * T_21.R;  // x2n^T E x1n = 0 for normalised coordinates
  const Mat3 F = K2.inverse().transpose() * essential * K1.inverse();
  cv::Matx33d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = F(r, c);
  return out;
}

double epipolarDistanceSquared(const cv::Matx33d& F21, const cv::Point2f& p1, const cv::Point2f& p2) {
  const cv::Vec3d line = F21 * cv::Vec3d(p1.x, p1.y, 1.0);
  const double norm2 = line[0] * line[0] + line[1] * line[1];
  if (norm2 <= 0) return std::numeric_limits<double>::infinity();
  const double residual = line[0] * p2.x + line[1] * p2.y + line[2];
  return residual * residual / norm2;
}

// ---------------------------------------------------- searchForTriangulation

VSLAM_POPCNT_CLONES std::vector<std::pair<int, int>> searchForTriangulation(const FeatureView& view1, const FeatureView& view2,
                                                        const cv::Matx33d& F21, const std::vector<double>& level_sigma2,
                                                        const std::vector<bool>& matched1,
                                                        const std::vector<bool>& matched2,
                                                        const TriangulationSearchParams& params) {
  checkView(view1, "searchForTriangulation (view 1)");
  checkView(view2, "searchForTriangulation (view 2)");
  const int n1 = static_cast<int>(view1.keypoints.size());
  const int n2 = static_cast<int>(view2.keypoints.size());
  if ((!matched1.empty() && static_cast<int>(matched1.size()) != n1) ||
      (!matched2.empty() && static_cast<int>(matched2.size()) != n2))
    throw InputError("searchForTriangulation: a matched mask must be empty or one entry per feature");
  const auto sigma2Of = [&level_sigma2](int octave) {
    if (octave < 0 || octave >= static_cast<int>(level_sigma2.size()))
      throw InputError("searchForTriangulation: keypoint octave outside level_sigma2");
    return level_sigma2[octave];
  };

  // The epipole in view 2 (image of camera 1's centre): e2^T F21 = 0.
  const cv::Vec3d e2 = nullVector(F21.t());
  const bool epipole_finite = std::abs(e2[2]) > 1e-9;
  const cv::Point2d epipole = epipole_finite ? cv::Point2d(e2[0] / e2[2], e2[1] / e2[2]) : cv::Point2d();

  // Per view-2 feature, once: may it be used at all (unmatched, not at the epipole)?
  std::vector<int> usable2;
  for (int i2 = 0; i2 < n2; ++i2) {
    if (!matched2.empty() && matched2[i2]) continue;
    if (epipole_finite) {
      const double min_distance = params.min_epipole_distance * std::sqrt(sigma2Of(view2.keypoints[i2].octave));
      const double dx = view2.points[i2].x - epipole.x, dy = view2.points[i2].y - epipole.y;
      if (dx * dx + dy * dy < min_distance * min_distance) continue;
    }
    usable2.push_back(i2);
  }
  // Their positions and squared line tolerances, contiguous for the inner loop.
  std::vector<double> usable_x, usable_y, usable_tolerance2;
  for (int i2 : usable2) {
    usable_x.push_back(view2.points[i2].x);
    usable_y.push_back(view2.points[i2].y);
    usable_tolerance2.push_back(kChi2OneDof95 * sigma2Of(view2.keypoints[i2].octave));
  }

  std::vector<int> matches12(n1, -1);
  std::vector<int> matches21(n2, -1);
  std::vector<int> distance21(n2, std::numeric_limits<int>::max());
  for (int i1 = 0; i1 < n1; ++i1) {
    if (!matched1.empty() && matched1[i1]) continue;
    const cv::Point2f& p1 = view1.points[i1];
    const cv::Vec3d line = F21 * cv::Vec3d(p1.x, p1.y, 1.0);
    const double line_norm2 = line[0] * line[0] + line[1] * line[1];
    if (line_norm2 <= 0) continue;
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), best_i2 = -1;
    const std::uint8_t* descriptor1 = row(view1.descriptors, i1);
    for (std::size_t k = 0; k < usable2.size(); ++k) {
      // The line test first: a few flops that reject almost every candidate.
      const double residual = line[0] * usable_x[k] + line[1] * usable_y[k] + line[2];
      if (residual * residual >= usable_tolerance2[k] * line_norm2) continue;
      const int i2 = usable2[k];
      const int d = hammingDistance(descriptor1, row(view2.descriptors, i2));
      if (d >= second) continue;
      if (d < best) {
        second = best, best = d, best_i2 = i2;
      } else {
        second = d;
      }
    }
    if (best_i2 < 0 || best > params.max_distance) continue;
    if (static_cast<float>(best) >= params.ratio * static_cast<float>(second)) continue;
    if (distance21[best_i2] <= best) continue;  // a closer view-1 feature has it
    if (matches21[best_i2] >= 0) matches12[matches21[best_i2]] = -1;
    matches12[i1] = best_i2;
    matches21[best_i2] = i1;
    distance21[best_i2] = best;
  }

  if (params.check_orientation) {
    RotationHistogram histogram;
    for (int i1 = 0; i1 < n1; ++i1)
      if (matches12[i1] >= 0) histogram.add(view1.keypoints[i1].angle, view2.keypoints[matches12[i1]].angle, i1);
    for (int i1 : histogram.rejectedMatches()) matches12[i1] = -1;
  }

  std::vector<std::pair<int, int>> pairs;
  for (int i1 = 0; i1 < n1; ++i1)
    if (matches12[i1] >= 0) pairs.emplace_back(i1, matches12[i1]);
  return pairs;
}

}  // namespace vslam
