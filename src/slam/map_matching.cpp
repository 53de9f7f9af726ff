#include "vslam/slam/map_matching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vslam/feature/matcher.hpp"

namespace vslam {
namespace {

// Wider windows for points seen obliquely: their appearance is less stable.
double radiusByViewingCos(double view_cos) { return view_cos > 0.998 ? 2.5 : 4.0; }

struct BestTwo {
  int best_distance = std::numeric_limits<int>::max();
  int second_distance = std::numeric_limits<int>::max();
  int best_index = -1;
  int best_level = -1, second_level = -1;
  void offer(int distance, int index, int level) {
    if (distance < best_distance) {
      second_distance = best_distance;
      second_level = best_level;
      best_distance = distance;
      best_index = index;
      best_level = level;
    } else if (distance < second_distance) {
      second_distance = distance;
      second_level = level;
    }
  }
};

}  // namespace

int searchByProjection(Frame& current, const Frame& last, double radius_px, bool check_orientation) {
  const PinholeCamera& camera = *current.camera;
  const ScalePyramid& pyramid = *current.pyramid;
  RotationHistogram rotation;
  int matches = 0;
  for (size_t i = 0; i < last.size(); ++i) {
    MapPoint* point = last.map_points[i];
    if (!point || point->isBad() || last.outlier[i]) continue;
    const Vec3 p_c = current.T_cw * point->position();
    if (p_c.z() <= 0) continue;
    const Vec2 px = camera.project(p_c);
    if (!camera.inImage(px)) continue;
    const int last_level = last.keypoints[i].octave;
    const double radius = radius_px * pyramid.scale[last_level];
    const std::vector<int> candidates =
        current.grid.featuresInArea(px.x(), px.y(), radius, std::max(0, last_level - 1), last_level + 1);
    if (candidates.empty()) continue;
    const uint8_t* descriptor = point->descriptor().ptr<uint8_t>();
    BestTwo best;
    for (int j : candidates) {
      if (current.map_points[j] && current.map_points[j]->observationCount() > 0) continue;
      best.offer(hammingDistance(descriptor, current.descriptors.ptr<uint8_t>(j)), j, current.keypoints[j].octave);
    }
    if (best.best_index < 0 || best.best_distance > kHammingThresholdHigh) continue;
    current.map_points[best.best_index] = point;
    ++matches;
    if (check_orientation)
      rotation.add(last.keypoints[i].angle, current.keypoints[best.best_index].angle, best.best_index);
  }
  if (check_orientation)
    for (int j : rotation.rejectedMatches()) {
      current.map_points[j] = nullptr;
      --matches;
    }
  return matches;
}

bool isInFrustum(MapPoint* point, const Frame& frame, double min_view_cos) {
  point->track_in_view = false;
  const Vec3 p_w = point->position();
  const Vec3 p_c = frame.T_cw * p_w;
  if (p_c.z() <= 0) return false;
  const Vec2 px = frame.camera->project(p_c);
  if (!frame.camera->inImage(px)) return false;
  const Vec3 ray = p_w - frame.cameraCentre();
  const double distance = ray.norm();
  if (distance < point->minDistance() || distance > point->maxDistance()) return false;
  const double view_cos = ray.dot(point->normal()) / distance;
  if (view_cos < min_view_cos) return false;
  point->track_in_view = true;
  point->track_proj_x = px.x();
  point->track_proj_y = px.y();
  point->track_level = point->predictLevel(distance, *frame.pyramid);
  point->track_view_cos = view_cos;
  return true;
}

int searchLocalPoints(Frame& frame, const std::vector<MapPoint*>& points, double radius_factor) {
  const ScalePyramid& pyramid = *frame.pyramid;
  int matches = 0;
  for (MapPoint* point : points) {
    if (!point->track_in_view || point->isBad()) continue;
    const int level = point->track_level;
    const double radius = radius_factor * radiusByViewingCos(point->track_view_cos) * pyramid.scale[level];
    const std::vector<int> candidates =
        frame.grid.featuresInArea(point->track_proj_x, point->track_proj_y, radius, level - 1, level);
    if (candidates.empty()) continue;
    const uint8_t* descriptor = point->descriptor().ptr<uint8_t>();
    BestTwo best;
    for (int j : candidates) {
      if (frame.map_points[j] && frame.map_points[j]->observationCount() > 0) continue;
      best.offer(hammingDistance(descriptor, frame.descriptors.ptr<uint8_t>(j)), j, frame.keypoints[j].octave);
    }
    if (best.best_index < 0 || best.best_distance > kHammingThresholdHigh) continue;
    // Ambiguous when the runner-up at the same level is nearly as close.
    if (best.best_level == best.second_level && best.best_distance > 0.8 * best.second_distance) continue;
    frame.map_points[best.best_index] = point;
    ++matches;
  }
  return matches;
}

int searchByProjection(Frame& frame, const KeyFrame& keyframe, const std::vector<MapPoint*>& already_found,
                       double radius_px, int max_descriptor_distance) {
  const PinholeCamera& camera = *frame.camera;
  const ScalePyramid& pyramid = *frame.pyramid;
  const Vec3 centre = frame.cameraCentre();
  RotationHistogram rotation;
  int matches = 0;
  for (size_t i = 0; i < keyframe.size(); ++i) {
    MapPoint* point = keyframe.mapPoint(i);
    if (!point || point->isBad()) continue;
    if (std::find(already_found.begin(), already_found.end(), point) != already_found.end()) continue;
    const Vec3 p_c = frame.T_cw * point->position();
    if (p_c.z() <= 0) continue;
    const Vec2 px = camera.project(p_c);
    if (!camera.inImage(px)) continue;
    const double distance = (point->position() - centre).norm();
    if (distance < point->minDistance() || distance > point->maxDistance()) continue;
    const int level = point->predictLevel(distance, pyramid);
    const std::vector<int> candidates =
        frame.grid.featuresInArea(px.x(), px.y(), radius_px * pyramid.scale[level], level - 1, level + 1);
    BestTwo best;
    for (int j : candidates) {
      if (frame.map_points[j]) continue;
      best.offer(hammingDistance(point->descriptor().ptr<uint8_t>(), frame.descriptors.ptr<uint8_t>(j)), j,
                 frame.keypoints[j].octave);
    }
    if (best.best_index < 0 || best.best_distance > max_descriptor_distance) continue;
    frame.map_points[best.best_index] = point;
    ++matches;
    rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.best_index].angle, best.best_index);
  }
  for (int j : rotation.rejectedMatches()) {
    frame.map_points[j] = nullptr;
    --matches;
  }
  return matches;
}

int searchByDescriptor(const KeyFrame& keyframe, const Frame& frame, std::vector<MapPoint*>& matches, double ratio) {
  matches.assign(frame.size(), nullptr);
  std::vector<int> best_distance_at(frame.size(), std::numeric_limits<int>::max());
  RotationHistogram rotation;
  int count = 0;
  for (size_t i = 0; i < keyframe.size(); ++i) {
    MapPoint* point = keyframe.mapPoint(i);
    if (!point || point->isBad()) continue;
    const uint8_t* descriptor = keyframe.descriptors.ptr<uint8_t>(i);
    BestTwo best;
    for (size_t j = 0; j < frame.size(); ++j)
      best.offer(hammingDistance(descriptor, frame.descriptors.ptr<uint8_t>(j)), static_cast<int>(j), 0);
    if (best.best_index < 0 || best.best_distance > kHammingThresholdLow) continue;
    if (best.best_distance >= ratio * best.second_distance) continue;
    if (best.best_distance >= best_distance_at[best.best_index]) continue;
    if (!matches[best.best_index]) ++count;
    matches[best.best_index] = point;
    best_distance_at[best.best_index] = best.best_distance;
    rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.best_index].angle, best.best_index);
  }
  for (int j : rotation.rejectedMatches())
    if (matches[j]) {
      matches[j] = nullptr;
      --count;
    }
  return count;
}

namespace {

// Walks two direct indices node by node (both ordered by node id) and, for
// every pair of features under the same node, lets `match` compare them.
// `candidate_of(i)` says whether feature i of the first image takes part.
template <typename Offer, typename Accept>
void forEachSharedNode(const FeatureVector& first, const FeatureVector& second, Offer offer, Accept accept) {
  auto a = first.begin();
  auto b = second.begin();
  while (a != first.end() && b != second.end()) {
    if (a->first < b->first) {
      a = first.lower_bound(b->first);
    } else if (b->first < a->first) {
      b = second.lower_bound(a->first);
    } else {
      for (int i : a->second) {
        BestTwo best;
        if (!offer(i, b->second, best)) continue;
        accept(i, best);
      }
      ++a;
      ++b;
    }
  }
}

}  // namespace

int searchByBoW(const KeyFrame& keyframe, const Frame& frame, const FeatureVector& frame_features,
                std::vector<MapPoint*>& matches, double ratio) {
  matches.assign(frame.size(), nullptr);
  std::vector<int> best_distance_at(frame.size(), std::numeric_limits<int>::max());
  RotationHistogram rotation;
  int count = 0;
  forEachSharedNode(
      keyframe.bow_features, frame_features,
      [&](int i, const std::vector<int>& frame_indices, BestTwo& best) {
        MapPoint* point = keyframe.mapPoint(i);
        if (!point || point->isBad()) return false;
        const uint8_t* descriptor = keyframe.descriptors.ptr<uint8_t>(i);
        for (int j : frame_indices)
          if (!matches[j]) best.offer(hammingDistance(descriptor, frame.descriptors.ptr<uint8_t>(j)), j, 0);
        return true;
      },
      [&](int i, const BestTwo& best) {
        if (best.best_index < 0 || best.best_distance > kHammingThresholdLow) return;
        if (best.best_distance >= ratio * best.second_distance) return;
        if (matches[best.best_index]) return;
        matches[best.best_index] = keyframe.mapPoint(i);
        best_distance_at[best.best_index] = best.best_distance;
        rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.best_index].angle, best.best_index);
        ++count;
      });
  for (int j : rotation.rejectedMatches())
    if (matches[j]) {
      matches[j] = nullptr;
      --count;
    }
  return count;
}

int searchByBoW(const KeyFrame& kf1, const KeyFrame& kf2, std::vector<MapPoint*>& matches, double ratio) {
  matches.assign(kf1.size(), nullptr);
  std::vector<bool> taken2(kf2.size(), false);
  RotationHistogram rotation;
  int count = 0;
  forEachSharedNode(
      kf1.bow_features, kf2.bow_features,
      [&](int i, const std::vector<int>& indices2, BestTwo& best) {
        MapPoint* point1 = kf1.mapPoint(i);
        if (!point1 || point1->isBad()) return false;
        const uint8_t* descriptor = kf1.descriptors.ptr<uint8_t>(i);
        for (int j : indices2) {
          MapPoint* point2 = kf2.mapPoint(j);
          if (taken2[j] || !point2 || point2->isBad()) continue;
          best.offer(hammingDistance(descriptor, kf2.descriptors.ptr<uint8_t>(j)), j, 0);
        }
        return true;
      },
      [&](int i, const BestTwo& best) {
        if (best.best_index < 0 || best.best_distance > kHammingThresholdLow) return;
        if (best.best_distance >= ratio * best.second_distance) return;
        matches[i] = kf2.mapPoint(best.best_index);
        taken2[best.best_index] = true;
        rotation.add(kf1.keypoints[i].angle, kf2.keypoints[best.best_index].angle, i);
        ++count;
      });
  for (int i : rotation.rejectedMatches())
    if (matches[i]) {
      matches[i] = nullptr;
      --count;
    }
  return count;
}

std::optional<PredictedObservation> predictObservation(const MapPoint& point, const KeyFrame& keyframe,
                                                       const Sim3& S_cw, const Vec3& centre_w) {
  const Vec3 p_c = S_cw * point.position();
  if (p_c.z() <= 0) return std::nullopt;
  const Vec2 px = keyframe.camera().project(p_c);
  if (!keyframe.camera().inImage(px)) return std::nullopt;
  const Vec3 ray = point.position() - centre_w;
  const double distance = ray.norm();
  if (distance < point.minDistance() || distance > point.maxDistance()) return std::nullopt;
  if (ray.dot(point.normal()) < 0.5 * distance) return std::nullopt;
  return PredictedObservation{px, point.predictLevel(distance, keyframe.pyramid())};
}

int fuse(KeyFrame* keyframe, const std::vector<MapPoint*>& points, double radius_factor) {
  const ScalePyramid& pyramid = keyframe->pyramid();
  const Sim3 S_cw(keyframe->pose());
  const Vec3 centre = keyframe->cameraCentre();
  int fused = 0;
  for (MapPoint* point : points) {
    if (!point || point->isBad() || point->keypointIn(keyframe) >= 0) continue;
    const std::optional<PredictedObservation> seen = predictObservation(*point, *keyframe, S_cw, centre);
    if (!seen) continue;
    const Vec2& px = seen->pixel;
    const int level = seen->level;
    const double radius = radius_factor * pyramid.scale[level];
    const std::vector<int> candidates = keyframe->grid.featuresInArea(px.x(), px.y(), radius);
    int best_distance = std::numeric_limits<int>::max();
    int best_index = -1;
    for (int j : candidates) {
      const int kp_level = keyframe->keypoints[j].octave;
      if (kp_level < level - 1 || kp_level > level) continue;
      // Reprojection gate at the keypoint's scale (chi-square 2 dof, 95 %).
      const double e2 = (keyframe->point(j) - px).squaredNorm();
      if (e2 * pyramid.inv_sigma2[kp_level] > 5.99) continue;
      const int d = hammingDistance(point->descriptor().ptr<uint8_t>(), keyframe->descriptors.ptr<uint8_t>(j));
      if (d < best_distance) {
        best_distance = d;
        best_index = j;
      }
    }
    if (best_index < 0 || best_distance > kHammingThresholdLow) continue;
    MapPoint* existing = keyframe->mapPoint(best_index);
    if (existing && !existing->isBad()) {
      if (existing->observationCount() > point->observationCount())
        point->replaceWith(existing);
      else
        existing->replaceWith(point);
    } else {
      point->addObservation(keyframe, best_index);
      keyframe->setMapPoint(best_index, point);
    }
    ++fused;
  }
  return fused;
}

}  // namespace vslam

namespace vslam {

std::vector<std::pair<int, int>> searchForTriangulation(const KeyFrame& kf1, const KeyFrame& kf2) {
  std::vector<bool> matched1(kf1.size()), matched2(kf2.size());
  for (size_t i = 0; i < kf1.size(); ++i) matched1[i] = kf1.mapPoint(i) != nullptr;
  for (size_t i = 0; i < kf2.size(); ++i) matched2[i] = kf2.mapPoint(i) != nullptr;
  const cv::Matx33d F21 =
      fundamentalFromPoses(kf1.pose(), kf2.pose(), kf1.camera().Keigen(), kf2.camera().Keigen());
  return searchForTriangulation(kf1.view(), kf2.view(), F21, kf1.pyramid().sigma2, matched1, matched2);
}

}  // namespace vslam
