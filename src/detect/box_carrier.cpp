#include "vslam/detect/box_carrier.hpp"

#include <algorithm>
#include <cmath>

#include "vslam/feature/matcher.hpp"

namespace vslam {
namespace {

// Median of `values` (mean of the middle two for an even count); `values` is reordered.
float median(std::vector<float>& values) {
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
  const float upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  const float lower = *std::max_element(values.begin(), values.begin() + static_cast<long>(middle));
  return 0.5f * (lower + upper);
}

bool inside(const cv::Rect2f& box, const cv::Point2f& p) {
  return p.x >= box.x && p.y >= box.y && p.x < box.x + box.width && p.y < box.y + box.height;
}

}  // namespace

std::optional<BoxMotion> fitBoxMotion(const std::vector<cv::Point2f>& before, const std::vector<cv::Point2f>& after,
                                      int min_support) {
  const int n = static_cast<int>(std::min(before.size(), after.size()));
  if (n < std::max(1, min_support)) return std::nullopt;
  // Scale: median ratio of the distances within pairs (i, i + n/2), so that a
  // wrong match spoils two ratios at most.
  std::vector<float> ratios;
  for (int i = 0; n > 1 && i < n; ++i) {
    const int j = (i + n / 2) % n;
    const float from = static_cast<float>(cv::norm(before[i] - before[j]));
    if (from < 1.f) continue;  // too close together to say anything about scale
    ratios.push_back(static_cast<float>(cv::norm(after[i] - after[j])) / from);
  }
  BoxMotion motion;
  motion.scale = ratios.empty() ? 1.f : median(ratios);
  // Translation: median of what each match says once scaled.
  std::vector<float> dx, dy;
  for (int i = 0; i < n; ++i) {
    dx.push_back(after[i].x - motion.scale * before[i].x);
    dy.push_back(after[i].y - motion.scale * before[i].y);
  }
  motion.translation = {median(dx), median(dy)};
  motion.support = n;
  return motion;
}

cv::Rect2f moveBox(const cv::Rect2f& box, const BoxMotion& motion) {
  return {motion.scale * box.x + motion.translation.x, motion.scale * box.y + motion.translation.y,
          motion.scale * box.width, motion.scale * box.height};
}

void matchInsideBox(const FeatureSnapshot& from, const FeatureSnapshot& to, const cv::Rect2f& box, float radius_px,
                    const BoxCarrierParams& params, std::vector<cv::Point2f>& before, std::vector<cv::Point2f>& after) {
  before.clear();
  after.clear();
  // Candidates of `to` near the box at all (the window grows with the level).
  const float reach = radius_px * 4.f;
  const cv::Rect2f near(box.x - reach, box.y - reach, box.width + 2 * reach, box.height + 2 * reach);
  std::vector<int> candidates;
  for (int j = 0; j < static_cast<int>(to.keypoints.size()); ++j)
    if (inside(near, to.keypoints[j].pt)) candidates.push_back(j);

  std::vector<char> used(to.keypoints.size(), 0);
  for (int i = 0; i < static_cast<int>(from.keypoints.size()); ++i) {
    const cv::KeyPoint& keypoint = from.keypoints[i];
    if (!inside(box, keypoint.pt)) continue;
    // ORB's size is 31 px times the level's scale: the window grows with it.
    const float radius = radius_px * std::max(1.f, keypoint.size / 31.f);
    int best = -1, best_distance = 256, second_distance = 256;
    for (int j : candidates) {
      const cv::KeyPoint& other = to.keypoints[j];
      if (other.octave != keypoint.octave || used[j]) continue;
      if (std::abs(other.pt.x - keypoint.pt.x) > radius || std::abs(other.pt.y - keypoint.pt.y) > radius) continue;
      const int distance = hammingDistance(from.descriptors.ptr<std::uint8_t>(i), to.descriptors.ptr<std::uint8_t>(j));
      if (distance < best_distance) {
        second_distance = best_distance;
        best_distance = distance;
        best = j;
      } else if (distance < second_distance) {
        second_distance = distance;
      }
    }
    if (best < 0 || best_distance > params.max_hamming) continue;
    if (static_cast<float>(best_distance) > params.ratio * static_cast<float>(second_distance)) continue;
    used[best] = 1;
    before.push_back(keypoint.pt);
    after.push_back(to.keypoints[best].pt);
  }
}

std::optional<cv::Rect2f> BoxCarrier::carry(const cv::Rect2f& box, const FeatureSnapshot& from,
                                            const FeatureSnapshot& to) const {
  const int gap = to.frame_index - from.frame_index;
  if (gap == 0) return box;
  const float radius = std::min(params_.max_search_radius_px, params_.search_radius_px * static_cast<float>(std::abs(gap)));
  std::vector<cv::Point2f> before, after;
  matchInsideBox(from, to, box, radius, params_, before, after);
  const std::optional<BoxMotion> motion = fitBoxMotion(before, after, params_.min_support);
  if (!motion) return std::nullopt;
  if (motion->scale > params_.max_scale_step || motion->scale < 1.f / params_.max_scale_step) return std::nullopt;
  return moveBox(box, *motion);
}

void BoxCarrier::advance(const FeatureSnapshot& frame) {
  const int gap = last_.frame_index < 0 ? 0 : frame.frame_index - last_.frame_index;
  std::vector<CarriedBox> kept;
  for (CarriedBox& carried : boxes_) {
    carried.age += gap;
    if (carried.age > params_.max_age) {
      ++expired_;
      continue;
    }
    const std::optional<cv::Rect2f> moved = carry(carried.detection.box, last_, frame);
    if (!moved) {
      ++unmoved_;
      continue;
    }
    carried.detection.box = *moved;
    kept.push_back(carried);
  }
  boxes_ = std::move(kept);
  last_ = frame;
}

void BoxCarrier::replace(const std::vector<Detection>& detections, const FeatureSnapshot& detected) {
  boxes_.clear();
  const int age = last_.frame_index < 0 ? 0 : last_.frame_index - detected.frame_index;
  if (age > params_.max_age) {
    expired_ += static_cast<int>(detections.size());
    return;
  }
  for (const Detection& detection : detections) {
    const std::optional<cv::Rect2f> moved = carry(detection.box, detected, last_.frame_index < 0 ? detected : last_);
    if (!moved) {
      ++unmoved_;
      continue;
    }
    CarriedBox carried{detection, age};
    carried.detection.box = *moved;
    boxes_.push_back(carried);
  }
}

void BoxCarrier::clear() {
  boxes_.clear();
  last_ = FeatureSnapshot();
}

std::vector<Detection> BoxCarrier::detections() const {
  std::vector<Detection> detections;
  for (const CarriedBox& carried : boxes_) {
    detections.push_back(carried.detection);
    detections.back().id = static_cast<int>(detections.size()) - 1;
  }
  return detections;
}

}  // namespace vslam
