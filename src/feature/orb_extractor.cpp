// ORB extraction: per level, FAST in ~30 px cells (fallback threshold where a
// cell is empty), quadtree distribution to the level's quota, intensity-centroid
// orientation, standard ORB descriptors (rotated BRIEF with ORB's learned
// pattern) on the blurred level. See docs/FEATURES.md.
#include "vslam/feature/orb_extractor.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <queue>
#include <tuple>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

constexpr int kFastMargin = 4;  // FAST's circle radius (3) + 1 so non-max suppression sees all neighbours

// A candidate corner in level pixels, with its level-0 position.
using Corner = OrbCorner;

// Level-0 position of a level pixel. cv::resize (INTER_LINEAR) maps pixel
// centres, x_prev + 0.5 = (x + 0.5) * W_prev / W, and these ratios chain, so
// level l relates to level 0 by its size ratio (ORB-SLAM's x * scale is off by
// up to ~1.3 px at the coarsest level).
cv::Point2f toLevel0(const cv::Point2f& p, double ratio_x, double ratio_y) {
  return cv::Point2f(static_cast<float>((p.x + 0.5) * ratio_x - 0.5), static_cast<float>((p.y + 0.5) * ratio_y - 0.5));
}

// FAST corners of `image` inside `region` (level pixels, already kept
// kEdgeBorder inside). Runs once at `threshold` over the region, then re-runs at
// `min_threshold` in each ~30 px cell that got nothing. Because each run scans a
// window kFastMargin wider than what it keeps, a cell's result equals what a
// whole-image FAST at that threshold would give there.
void detectCorners(const cv::Mat& image, const cv::Rect& region, int threshold, int min_threshold, int cell_size,
                   std::vector<cv::KeyPoint>& corners) {
  corners.clear();
  const auto runFast = [&image](const cv::Rect& keep, int fast_threshold, std::vector<cv::KeyPoint>& out) {
    const cv::Rect window(keep.x - kFastMargin, keep.y - kFastMargin, keep.width + 2 * kFastMargin,
                          keep.height + 2 * kFastMargin);
    std::vector<cv::KeyPoint> found;
    cv::FAST(image(window), found, fast_threshold, true);
    for (cv::KeyPoint& kp : found) {
      kp.pt.x += static_cast<float>(window.x);
      kp.pt.y += static_cast<float>(window.y);
      if (keep.contains(cv::Point(static_cast<int>(kp.pt.x), static_cast<int>(kp.pt.y)))) out.push_back(kp);
    }
  };
  runFast(region, threshold, corners);

  const int n_cols = std::max(1, static_cast<int>(std::lround(static_cast<double>(region.width) / cell_size)));
  const int n_rows = std::max(1, static_cast<int>(std::lround(static_cast<double>(region.height) / cell_size)));
  const auto cellStart = [](int origin, int length, int n, int i) { return origin + (i * length) / n; };
  // Column/row of each region pixel, so counting is one lookup per corner.
  std::vector<int> col_of(region.width), row_of(region.height);
  for (int c = 0; c < n_cols; ++c)
    for (int x = cellStart(0, region.width, n_cols, c); x < cellStart(0, region.width, n_cols, c + 1); ++x) col_of[x] = c;
  for (int r = 0; r < n_rows; ++r)
    for (int y = cellStart(0, region.height, n_rows, r); y < cellStart(0, region.height, n_rows, r + 1); ++y) row_of[y] = r;

  std::vector<int> count(n_cols * n_rows, 0);
  for (const cv::KeyPoint& kp : corners)
    ++count[row_of[static_cast<int>(kp.pt.y) - region.y] * n_cols + col_of[static_cast<int>(kp.pt.x) - region.x]];
  if (min_threshold >= threshold) return;
  // Re-run in horizontal runs of empty cells: one FAST call per run gives the
  // same corners as one per cell and saves the per-call overhead.
  for (int r = 0; r < n_rows; ++r) {
    const int y0 = cellStart(region.y, region.height, n_rows, r), y1 = cellStart(region.y, region.height, n_rows, r + 1);
    for (int c = 0; c < n_cols;) {
      if (count[r * n_cols + c] > 0) {
        ++c;
        continue;
      }
      int end = c;
      while (end < n_cols && count[r * n_cols + end] == 0) ++end;
      const int x0 = cellStart(region.x, region.width, n_cols, c), x1 = cellStart(region.x, region.width, n_cols, end);
      runFast(cv::Rect(x0, y0, x1 - x0, y1 - y0), min_threshold, corners);
      c = end;
    }
  }
}

// Keeps at most `quota` corners spread over `area`: splits the area into
// quadtree nodes, always splitting the largest node that still holds more than
// one corner (ties: the fuller node, then the older), until there are `quota`
// non-empty nodes; each node then contributes its strongest corner (ties: the
// first found). Splitting by size rather than by count is what spreads the
// corners: a sparse region gets as many nodes as a dense one of the same size.
// Returns indices into `corners`, ascending.
std::vector<int> distributeQuadtree(const std::vector<Corner>& corners, const cv::Rect2f& area, int quota) {
  std::vector<int> selected;
  if (quota <= 0 || corners.empty()) return selected;
  if (static_cast<int>(corners.size()) <= quota) {
    for (int i = 0; i < static_cast<int>(corners.size()); ++i) selected.push_back(i);
    return selected;
  }

  // A node owns the range [begin, end) of `order`; splitting partitions the
  // range in place, so the tree needs no allocation per node.
  struct Node {
    float x0, y0, x1, y1;
    int begin, end;
    bool split;
  };
  std::vector<int> order(corners.size());
  std::iota(order.begin(), order.end(), 0);
  std::vector<Node> nodes;
  // Roughly square roots: one per (width / height), as a wide image would otherwise start with flat nodes.
  const int n_roots = std::max(1, static_cast<int>(std::lround(area.width / std::max(1.f, area.height))));
  const float root_width = area.width / static_cast<float>(n_roots);
  const auto rootOf = [&](int i) {
    return std::clamp(static_cast<int>((corners[i].keypoint.pt.x - area.x) / root_width), 0, n_roots - 1);
  };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return rootOf(a) < rootOf(b); });
  for (int r = 0, begin = 0; r < n_roots; ++r) {
    int end = begin;
    while (end < static_cast<int>(order.size()) && rootOf(order[end]) == r) ++end;
    if (end > begin)
      nodes.push_back(Node{area.x + r * root_width, area.y, area.x + (r + 1) * root_width, area.y + area.height, begin, end, false});
    begin = end;
  }

  // Priority: larger area first, then more members, then lower index.
  using Entry = std::tuple<float, int, int>;  // area, members, -index
  std::priority_queue<Entry> queue;
  const auto pushIfSplittable = [&](int index) {
    const Node& n = nodes[index];
    if (n.end - n.begin > 1) queue.emplace((n.x1 - n.x0) * (n.y1 - n.y0), n.end - n.begin, -index);
  };
  for (int i = 0; i < static_cast<int>(nodes.size()); ++i) pushIfSplittable(i);

  int n_leaves = static_cast<int>(nodes.size());
  while (n_leaves < quota && !queue.empty()) {
    const int index = -std::get<2>(queue.top());
    queue.pop();
    const Node parent = nodes[index];
    nodes[index].split = true;
    const float xm = 0.5f * (parent.x0 + parent.x1), ym = 0.5f * (parent.y0 + parent.y1);
    const auto first = order.begin() + parent.begin, last = order.begin() + parent.end;
    const auto top = [&](int i) { return corners[i].keypoint.pt.y < ym; };
    const auto left = [&](int i) { return corners[i].keypoint.pt.x < xm; };
    const auto middle = std::partition(first, last, top);
    const auto top_split = std::partition(first, middle, left);
    const auto bottom_split = std::partition(middle, last, left);
    const int b = parent.begin, tl = static_cast<int>(top_split - order.begin()),
              m = static_cast<int>(middle - order.begin()), bl = static_cast<int>(bottom_split - order.begin()),
              e = parent.end;
    const Node children[4] = {{parent.x0, parent.y0, xm, ym, b, tl, false}, {xm, parent.y0, parent.x1, ym, tl, m, false},
                              {parent.x0, ym, xm, parent.y1, m, bl, false}, {xm, ym, parent.x1, parent.y1, bl, e, false}};
    --n_leaves;
    for (const Node& child : children) {
      if (child.end == child.begin) continue;
      nodes.push_back(child);
      ++n_leaves;
      pushIfSplittable(static_cast<int>(nodes.size()) - 1);
    }
  }

  // Strongest corner per leaf; ties go to the lower index so the partition order does not matter.
  const auto stronger = [&corners](int a, int b) {
    const float ra = corners[a].keypoint.response, rb = corners[b].keypoint.response;
    return ra > rb || (ra == rb && a < b);
  };
  for (const Node& node : nodes) {
    if (node.split) continue;
    int best = order[node.begin];
    for (int k = node.begin + 1; k < node.end; ++k)
      if (stronger(order[k], best)) best = order[k];
    selected.push_back(best);
  }
  // The last split may overshoot by up to 3: drop the weakest.
  if (static_cast<int>(selected.size()) > quota) {
    std::sort(selected.begin(), selected.end(), stronger);
    selected.resize(quota);
  }
  std::sort(selected.begin(), selected.end());  // back to scan order (row-major, as FAST found them)
  return selected;
}

// Orientation (degrees, [0, 360)) of the intensity centroid of the radius-15
// disc around `p`: atan2(m01, m10).
float centroidAngle(const cv::Mat& image, const cv::Point& p, const std::vector<int>& half_width) {
  const uchar* centre = image.ptr<uchar>(p.y) + p.x;
  const int step = static_cast<int>(image.step1());
  int m10 = 0, m01 = 0;
  for (int u = -half_width[0]; u <= half_width[0]; ++u) m10 += u * centre[u];
  for (int v = 1; v < static_cast<int>(half_width.size()); ++v) {
    int row_difference = 0;  // sum over the row pair of I(u, v) - I(u, -v)
    const int w = half_width[v];
    for (int u = -w; u <= w; ++u) {
      const int below = centre[u + v * step], above = centre[u - v * step];
      row_difference += below - above;
      m10 += u * (below + above);
    }
    m01 += v * row_difference;
  }
  double angle = std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * (180.0 / CV_PI);
  if (angle < 0) angle += 360.0;
  if (angle >= 360.0) angle -= 360.0;
  return static_cast<float>(angle);
}

// Standard ORB's rotated BRIEF, computed as cv::ORB computes it so that the
// bits are the same: the angle to radians in float, its cosine and sine rounded
// to float, each test point rotated in float and rounded half to even (cvRound),
// then I(p1) < I(p2) on the blurred level. `points_x/y` hold the 512 test points
// (pair i = points 2i, 2i+1).
void computeDescriptor(const cv::Mat& blurred, const cv::Point& p, float angle_deg, const float* points_x,
                       const float* points_y, uchar* out) {
  const uchar* centre = blurred.ptr<uchar>(p.y) + p.x;
  const int step = static_cast<int>(blurred.step1());
  const float angle = angle_deg * static_cast<float>(CV_PI / 180.0);
  const float c = static_cast<float>(std::cos(static_cast<double>(angle)));
  const float s = static_cast<float>(std::sin(static_cast<double>(angle)));
  // The 512 rotated pattern points, four at a time: the same products, sums
  // and round-half-to-even as cvRound, so the same bits as OpenCV's ORB.
  alignas(16) int offsets[2 * 256];
  const cv::v_float32x4 cos4 = cv::v_setall_f32(c), sin4 = cv::v_setall_f32(s);
  const cv::v_int32x4 step4 = cv::v_setall_s32(step);
  for (int i = 0; i < 2 * 256; i += 4) {
    const cv::v_float32x4 px = cv::v_load(points_x + i), py = cv::v_load(points_y + i);
    const cv::v_int32x4 x = cv::v_round(px * cos4 - py * sin4);
    const cv::v_int32x4 y = cv::v_round(px * sin4 + py * cos4);
    cv::v_store_aligned(offsets + i, y * step4 + x);
  }
  for (int byte = 0; byte < kOrbDescriptorBytes; ++byte) {
    const int* o = offsets + 16 * byte;
    unsigned value = 0;
    for (int bit = 0; bit < 8; ++bit) value |= static_cast<unsigned>(centre[o[2 * bit]] < centre[o[2 * bit + 1]]) << bit;
    out[byte] = static_cast<uchar>(value);
  }
}

}  // namespace

OrbExtractor::OrbExtractor(const OrbParams& params) : params_(params), pattern_(standardOrbPattern()) {
  if (params_.n_levels < 1 || params_.scale_factor <= 1.0 || params_.n_features < 0)
    throw InputError("orb: need n_levels >= 1, scale_factor > 1 and n_features >= 0");
  double scale = 1.0;
  for (int l = 0; l < params_.n_levels; ++l) {
    scale_factors_.push_back(scale);
    level_sigma2_.push_back(scale * scale);
    inv_level_sigma2_.push_back(1.0 / (scale * scale));
    scale *= params_.scale_factor;
  }
  for (const BriefPair& t : pattern_) {
    pattern_x_.push_back(t.x1), pattern_y_.push_back(t.y1);
    pattern_x_.push_back(t.x2), pattern_y_.push_back(t.y2);
  }
  // Integer disc u^2 + v^2 <= r^2: symmetric under 90-degree rotations and
  // transposition, so orientation is exactly rotation-covariant on the grid.
  for (int v = 0; v <= kPatchRadius; ++v) {
    int u = 0;
    while ((u + 1) * (u + 1) + v * v <= kPatchRadius * kPatchRadius) ++u;
    circle_half_width_.push_back(u);
  }
}

std::vector<int> OrbExtractor::levelQuotas(int n_features) const {
  const int n_levels = params_.n_levels;
  const double ratio = 1.0 / params_.scale_factor;
  // First term of the series sum_{l<L} a * ratio^l = n_features.
  const double first = n_features * (1.0 - ratio) / (1.0 - std::pow(ratio, n_levels));
  std::vector<int> quotas(n_levels, 0);
  int assigned = 0;
  double term = first;
  for (int l = 0; l + 1 < n_levels; ++l) {
    // Capped: for small n, rounding every term up could exceed n.
    quotas[l] = std::min(static_cast<int>(std::lround(term)), n_features - assigned);
    assigned += quotas[l];
    term *= ratio;
  }
  quotas[n_levels - 1] = std::max(0, n_features - assigned);
  return quotas;
}

ImagePyramid OrbExtractor::buildPyramid(const cv::Mat& image) const {
  if (image.empty()) throw InputError("OrbExtractor::buildPyramid: empty image");
  cv::Mat gray;
  if (image.type() == CV_8UC1)
    gray = image;
  else if (image.type() == CV_8UC3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    throw InputError("OrbExtractor::buildPyramid: expected an 8-bit grey or BGR image");

  ImagePyramid pyramid;
  pyramid.scales = scale_factors_;
  pyramid.levels.resize(params_.n_levels);
  pyramid.blurred.resize(params_.n_levels);
  pyramid.levels[0] = gray;
  for (int l = 1; l < params_.n_levels; ++l) {
    // Each level from the previous one (cheaper than from level 0; sizes from level 0 so they do not drift).
    const cv::Size size(std::max(1, static_cast<int>(std::lround(gray.cols / scale_factors_[l]))),
                        std::max(1, static_cast<int>(std::lround(gray.rows / scale_factors_[l]))));
    cv::resize(pyramid.levels[l - 1], pyramid.levels[l], size, 0, 0, cv::INTER_LINEAR);
  }
  // Blurred as cv::ORB blurs its levels, so that the descriptors are its bit for
  // bit: in place, in a view into a copy with a reflected border. OpenCV blurs a
  // view with a float kernel but a whole 8-bit image with a fixed-point one, and
  // the two round differently.
  constexpr int kBlurRadius = 3;
  for (int l = 0; l < params_.n_levels; ++l) {
    const cv::Mat& level = pyramid.levels[l];
    cv::Mat padded;
    cv::copyMakeBorder(level, padded, kBlurRadius, kBlurRadius, kBlurRadius, kBlurRadius, cv::BORDER_REFLECT_101);
    cv::Mat view = padded(cv::Rect(kBlurRadius, kBlurRadius, level.cols, level.rows));
    cv::GaussianBlur(view, view, cv::Size(7, 7), 2.0, 2.0, cv::BORDER_REFLECT_101);
    pyramid.blurred[l] = view;
  }
  return pyramid;
}

cv::Rect OrbExtractor::levelRegion(const ImagePyramid& pyramid, int level_index, const cv::Rect& area) const {
  const cv::Mat& base = pyramid.levels[0];
  const cv::Mat& level = pyramid.levels[level_index];
  const double ratio_x = static_cast<double>(base.cols) / level.cols;
  const double ratio_y = static_cast<double>(base.rows) / level.rows;
  // The area in level pixels (inverse of toLevel0, rounded outwards), inside the border.
  const int x0 = static_cast<int>(std::floor((area.x + 0.5) / ratio_x - 0.5));
  const int y0 = static_cast<int>(std::floor((area.y + 0.5) / ratio_y - 0.5));
  const int x1 = static_cast<int>(std::ceil((area.x + area.width - 0.5) / ratio_x - 0.5)) + 1;
  const int y1 = static_cast<int>(std::ceil((area.y + area.height - 0.5) / ratio_y - 0.5)) + 1;
  const cv::Rect inner(kEdgeBorder, kEdgeBorder, level.cols - 2 * kEdgeBorder, level.rows - 2 * kEdgeBorder);
  return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1)) & inner;
}

void OrbExtractor::orient(const ImagePyramid& pyramid, int level, OrbCorner& corner) const {
  cv::KeyPoint& kp = corner.keypoint;
  kp.octave = level;
  kp.size = static_cast<float>(2 * kPatchRadius + 1) * static_cast<float>(scale_factors_[level]);
  kp.angle = centroidAngle(pyramid.levels[level], cv::Point(cvRound(kp.pt.x), cvRound(kp.pt.y)), circle_half_width_);
}

void OrbExtractor::describe(const ImagePyramid& pyramid, const std::vector<OrbCorner>& kept,
                            std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  descriptors.create(static_cast<int>(kept.size()), kOrbDescriptorBytes, CV_8U);
  keypoints.reserve(kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const cv::KeyPoint& kp = kept[i].keypoint;
    computeDescriptor(pyramid.blurred[kp.octave], cv::Point(cvRound(kp.pt.x), cvRound(kp.pt.y)), kp.angle,
                      pattern_x_.data(), pattern_y_.data(), descriptors.ptr<uchar>(static_cast<int>(i)));
    cv::KeyPoint out = kp;
    out.pt = kept[i].level0;
    keypoints.push_back(out);
  }
}

void OrbExtractor::extract(const ImagePyramid& pyramid, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                           const cv::Rect& roi, int n_features, OrbCorners* all_corners) const {
  keypoints.clear();
  descriptors = cv::Mat();
  if (all_corners) all_corners->levels.assign(params_.n_levels, {});
  if (pyramid.levels.empty() || pyramid.levels[0].empty()) return;
  if (static_cast<int>(pyramid.levels.size()) != params_.n_levels ||
      static_cast<int>(pyramid.blurred.size()) != params_.n_levels)
    throw InputError("OrbExtractor::extract: pyramid was not built by buildPyramid with these parameters");

  const cv::Mat& base = pyramid.levels[0];
  const cv::Rect image_rect(0, 0, base.cols, base.rows);
  const cv::Rect area = roi.empty() ? image_rect : (roi & image_rect);
  const int wanted = n_features < 0 ? params_.n_features : n_features;
  if (area.empty() || wanted <= 0) return;
  const std::vector<int> quotas = levelQuotas(wanted);

  std::vector<Corner> kept;  // all levels, in level order
  std::vector<Corner> candidates;
  std::vector<cv::KeyPoint> corners;
  int carried = 0;  // quota a level could not fill passes on to the next
  for (int l = 0; l < params_.n_levels; ++l) {
    const cv::Mat& level = pyramid.levels[l];
    const double ratio_x = static_cast<double>(base.cols) / level.cols;
    const double ratio_y = static_cast<double>(base.rows) / level.rows;
    const cv::Rect region = levelRegion(pyramid, l, area);
    const int quota = quotas[l] + carried;
    if (region.width <= 0 || region.height <= 0) {
      carried = quota;
      continue;
    }

    detectCorners(level, region, params_.fast_threshold, params_.fast_min_threshold, kCellSize, corners);
    candidates.clear();
    for (const cv::KeyPoint& kp : corners) {
      const cv::Point2f p0 = toLevel0(kp.pt, ratio_x, ratio_y);
      // Exact ROI test in level-0 coordinates (the level region was rounded outwards).
      if (p0.x < area.x || p0.y < area.y || p0.x >= area.x + area.width || p0.y >= area.y + area.height) continue;
      candidates.push_back(Corner{kp, p0, false});
    }
    const std::vector<int> selected = distributeQuadtree(candidates, cv::Rect2f(region), quota);
    for (int index : selected) {
      kept.push_back(candidates[index]);
      orient(pyramid, l, kept.back());
      candidates[index].in_frame = true;
    }
    carried = quota - static_cast<int>(selected.size());
    if (all_corners) all_corners->levels[l] = candidates;
  }
  describe(pyramid, kept, keypoints, descriptors);
}

void OrbExtractor::extractFromCorners(const ImagePyramid& pyramid, OrbCorners& corners, const cv::Rect& roi,
                                      int n_features, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                                      int* frame_winners) const {
  keypoints.clear();
  descriptors = cv::Mat();
  if (frame_winners) *frame_winners = 0;
  if (pyramid.levels.empty() || pyramid.levels[0].empty()) return;
  if (static_cast<int>(corners.levels.size()) != params_.n_levels)
    throw InputError("OrbExtractor::extractFromCorners: corners were not kept by extract with these parameters");
  const cv::Rect image_rect(0, 0, pyramid.levels[0].cols, pyramid.levels[0].rows);
  const cv::Rect area = roi & image_rect;
  if (area.empty() || n_features <= 0) return;
  const std::vector<int> quotas = levelQuotas(n_features);

  std::vector<Corner> added;
  std::vector<Corner> candidates;
  std::vector<int> candidate_index;  // into corners.levels[l]
  int carried = 0;
  for (int l = 0; l < params_.n_levels; ++l) {
    const cv::Rect region = levelRegion(pyramid, l, area);
    const int quota = quotas[l] + carried;
    if (region.width <= 0 || region.height <= 0) {
      carried = quota;
      continue;
    }
    // The frame's corners inside the ROI, in the frame's scan order: the
    // quadtree then sees what a FAST run over the ROI would have found with
    // the frame's cells (it does not re-run FAST in cells empty at ROI scale).
    candidates.clear();
    candidate_index.clear();
    for (int i = 0; i < static_cast<int>(corners.levels[l].size()); ++i) {
      const Corner& corner = corners.levels[l][i];
      const cv::Point2f& p0 = corner.level0;
      if (p0.x < area.x || p0.y < area.y || p0.x >= area.x + area.width || p0.y >= area.y + area.height) continue;
      if (!region.contains(cv::Point(static_cast<int>(corner.keypoint.pt.x), static_cast<int>(corner.keypoint.pt.y))))
        continue;
      candidates.push_back(corner);
      candidate_index.push_back(i);
    }
    const std::vector<int> selected = distributeQuadtree(candidates, cv::Rect2f(region), quota);
    for (int index : selected) {
      if (candidates[index].in_frame) {
        if (frame_winners) ++*frame_winners;
        continue;
      }
      added.push_back(candidates[index]);
      orient(pyramid, l, added.back());
      corners.levels[l][candidate_index[index]].in_frame = true;
    }
    carried = quota - static_cast<int>(selected.size());
  }
  describe(pyramid, added, keypoints, descriptors);
}

void OrbExtractor::describe(const cv::Mat& blurred_level, const std::vector<cv::KeyPoint>& level_keypoints,
                            cv::Mat& descriptors) const {
  if (blurred_level.type() != CV_8UC1) throw InputError("OrbExtractor::describe: expected an 8-bit grey level image");
  const cv::Rect inside(kEdgeBorder, kEdgeBorder, blurred_level.cols - 2 * kEdgeBorder,
                        blurred_level.rows - 2 * kEdgeBorder);
  descriptors.create(static_cast<int>(level_keypoints.size()), kOrbDescriptorBytes, CV_8U);
  for (std::size_t i = 0; i < level_keypoints.size(); ++i) {
    const cv::Point p(cvRound(level_keypoints[i].pt.x), cvRound(level_keypoints[i].pt.y));
    if (!inside.contains(p)) throw InputError("OrbExtractor::describe: keypoint closer than kEdgeBorder to the border");
    computeDescriptor(blurred_level, p, level_keypoints[i].angle, pattern_x_.data(), pattern_y_.data(),
                      descriptors.ptr<uchar>(static_cast<int>(i)));
  }
}

}  // namespace vslam
