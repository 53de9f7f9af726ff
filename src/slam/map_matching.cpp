#include "vslam/slam/map_matching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "vslam/feature/matcher.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {
namespace {

// Wider windows for points seen obliquely: their appearance is less stable.
double radiusByViewingCos(double view_cos) { return view_cos > 0.998 ? 2.5 : 4.0; }

// Nearest and second-nearest to `descriptor` among the `candidates` that
// `usable` accepts (feature::nearestTwo on the survivors; `scratch` is reused
// across calls so that no search allocates per point).
template <typename Usable>
NearestTwo nearestUsable(const uint8_t* descriptor, const cv::Mat& descriptors, const std::vector<int>& candidates,
                         Usable usable, std::vector<int>& scratch) {
  scratch.clear();
  for (int j : candidates)
    if (usable(j)) scratch.push_back(j);
  return nearestTwo(descriptor, descriptors, scratch);
}

}  // namespace

int searchByProjection(Frame& current, const Frame& last, double radius_px, bool check_orientation) {
  const PinholeCamera& camera = *current.camera;
  const ScalePyramid& pyramid = *current.pyramid;
  RotationHistogram rotation;
  std::vector<int> usable;
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
    const NearestTwo best = nearestUsable(
        descriptor, current.descriptors, candidates,
        [&](int j) { return !(current.map_points[j] && current.map_points[j]->observationCount() > 0); }, usable);
    if (best.index < 0 || best.distance > kHammingThresholdHigh) continue;
    current.map_points[best.index] = point;
    ++matches;
    if (check_orientation)
      rotation.add(last.keypoints[i].angle, current.keypoints[best.index].angle, best.index);
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
  std::vector<int> usable;
  int matches = 0;
  for (MapPoint* point : points) {
    if (!point->track_in_view || point->isBad()) continue;
    const int level = point->track_level;
    const double radius = radius_factor * radiusByViewingCos(point->track_view_cos) * pyramid.scale[level];
    const std::vector<int> candidates =
        frame.grid.featuresInArea(point->track_proj_x, point->track_proj_y, radius, level - 1, level);
    if (candidates.empty()) continue;
    const uint8_t* descriptor = point->descriptor().ptr<uint8_t>();
    const NearestTwo best = nearestUsable(
        descriptor, frame.descriptors, candidates,
        [&](int j) { return !(frame.map_points[j] && frame.map_points[j]->observationCount() > 0); }, usable);
    if (best.index < 0 || best.distance > kHammingThresholdHigh) continue;
    // Ambiguous when the runner-up at the same level is nearly as close.
    if (best.second_index >= 0 && frame.keypoints[best.index].octave == frame.keypoints[best.second_index].octave &&
        best.distance > 0.8 * best.second_distance)
      continue;
    frame.map_points[best.index] = point;
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
  std::vector<int> usable;
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
    const NearestTwo best = nearestUsable(point->descriptor().ptr<uint8_t>(), frame.descriptors, candidates,
                                          [&](int j) { return !frame.map_points[j]; }, usable);
    if (best.index < 0 || best.distance > max_descriptor_distance) continue;
    frame.map_points[best.index] = point;
    ++matches;
    rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.index].angle, best.index);
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
  std::vector<int> every_feature(frame.size());
  std::iota(every_feature.begin(), every_feature.end(), 0);
  RotationHistogram rotation;
  int count = 0;
  for (size_t i = 0; i < keyframe.size(); ++i) {
    MapPoint* point = keyframe.mapPoint(i);
    if (!point || point->isBad()) continue;
    const uint8_t* descriptor = keyframe.descriptors.ptr<uint8_t>(i);
    const NearestTwo best = nearestTwo(descriptor, frame.descriptors, every_feature);
    if (best.index < 0 || best.distance > kHammingThresholdGuided) continue;
    if (best.second_index >= 0 && best.distance >= ratio * best.second_distance) continue;
    if (best.distance >= best_distance_at[best.index]) continue;
    if (!matches[best.index]) ++count;
    matches[best.index] = point;
    best_distance_at[best.index] = best.distance;
    rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.index].angle, best.index);
  }
  for (int j : rotation.rejectedMatches())
    if (matches[j]) {
      matches[j] = nullptr;
      --count;
    }
  return count;
}

namespace {

// Walks two direct indices node by node (both ordered by node id) and calls
// visit(i, second_indices) for every feature i of the first image with the
// features of the second image under the same node.
template <typename Visit>
void forEachSharedNode(const FeatureVector& first, const FeatureVector& second, Visit visit) {
  auto a = first.begin();
  auto b = second.begin();
  while (a != first.end() && b != second.end()) {
    if (a->first < b->first) {
      a = first.lower_bound(b->first);
    } else if (b->first < a->first) {
      b = second.lower_bound(a->first);
    } else {
      for (int i : a->second) visit(i, b->second);
      ++a;
      ++b;
    }
  }
}

}  // namespace

int searchByBoW(const KeyFrame& keyframe, const Frame& frame, const FeatureVector& frame_features,
                std::vector<MapPoint*>& matches, double ratio) {
  matches.assign(frame.size(), nullptr);
  std::vector<int> usable;
  RotationHistogram rotation;
  int count = 0;
  forEachSharedNode(keyframe.bow_features, frame_features, [&](int i, const std::vector<int>& frame_indices) {
    MapPoint* point = keyframe.mapPoint(i);
    if (!point || point->isBad()) return;
    const NearestTwo best = nearestUsable(keyframe.descriptors.ptr<uint8_t>(i), frame.descriptors, frame_indices,
                                          [&](int j) { return !matches[j]; }, usable);
    if (best.index < 0 || best.distance > kHammingThresholdGuided) return;
    if (best.second_index >= 0 && best.distance >= ratio * best.second_distance) return;
    matches[best.index] = point;
    rotation.add(keyframe.keypoints[i].angle, frame.keypoints[best.index].angle, best.index);
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
  std::vector<int> usable;
  RotationHistogram rotation;
  int count = 0;
  forEachSharedNode(kf1.bow_features, kf2.bow_features, [&](int i, const std::vector<int>& indices2) {
    MapPoint* point1 = kf1.mapPoint(i);
    if (!point1 || point1->isBad()) return;
    const NearestTwo best = nearestUsable(kf1.descriptors.ptr<uint8_t>(i), kf2.descriptors, indices2,
                                          [&](int j) {
                                            MapPoint* point2 = kf2.mapPoint(j);
                                            return !taken2[j] && point2 && !point2->isBad();
                                          },
                                          usable);
    if (best.index < 0 || best.distance > kHammingThresholdGuided) return;
    if (best.second_index >= 0 && best.distance >= ratio * best.second_distance) return;
    matches[i] = kf2.mapPoint(best.index);
    taken2[best.index] = true;
    rotation.add(kf1.keypoints[i].angle, kf2.keypoints[best.index].angle, i);
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

namespace {

// One direction of searchBySim3: for every map point of `from` (keypoints not
// in `skip_from`), the keypoint of `to` (not in `skip_to`) it projects onto
// under S_to_w with the nearest descriptor, or -1. Indexed by `from`'s keypoints.
std::vector<int> matchBySimilarity(const KeyFrame& from, const KeyFrame& to, const Sim3& S_to_w,
                                   const std::vector<bool>& skip_from, const std::vector<bool>& skip_to,
                                   double radius_px) {
  std::vector<int> match(from.size(), -1);
  const Vec3 centre_w = S_to_w.inverse().t;
  for (size_t i = 0; i < from.size(); ++i) {
    const MapPoint* point = from.mapPoint(i);
    if (skip_from[i] || !point || point->isBad()) continue;
    const std::optional<PredictedObservation> seen = predictObservation(*point, to, S_to_w, centre_w);
    if (!seen) continue;
    const double radius = radius_px * to.pyramid().scale[seen->level];
    int best_distance = std::numeric_limits<int>::max();
    for (int j : to.grid.featuresInArea(seen->pixel.x(), seen->pixel.y(), radius, seen->level - 1, seen->level)) {
      if (skip_to[j]) continue;
      const int d = hammingDistance(point->descriptor().ptr<uint8_t>(), to.descriptors.ptr<uint8_t>(j));
      if (d < best_distance) {
        best_distance = d;
        match[i] = j;
      }
    }
    if (best_distance > kHammingThresholdHigh) match[i] = -1;
  }
  return match;
}

}  // namespace

int searchBySim3(const KeyFrame& kf1, const KeyFrame& kf2, const Sim3& S12, std::vector<MapPoint*>& matches12,
                 double radius_px) {
  matches12.resize(kf1.size(), nullptr);
  std::vector<bool> matched1(kf1.size(), false), matched2(kf2.size(), false);
  for (size_t i = 0; i < kf1.size(); ++i) {
    if (!matches12[i]) continue;
    matched1[i] = true;
    const int j = matches12[i]->keypointIn(&kf2);
    if (j >= 0) matched2[j] = true;
  }
  // World -> camera of each keyframe as the other sees it through the similarity.
  const Sim3 S_1w = Sim3(kf1.pose());
  const Sim3 S_2w = Sim3(kf2.pose());
  const std::vector<int> match12 = matchBySimilarity(kf1, kf2, S12.inverse() * S_1w, matched1, matched2, radius_px);
  const std::vector<int> match21 = matchBySimilarity(kf2, kf1, S12 * S_2w, matched2, matched1, radius_px);
  int added = 0;
  for (size_t i = 0; i < kf1.size(); ++i) {
    const int j = match12[i];
    if (j < 0 || match21[j] != static_cast<int>(i)) continue;
    matches12[i] = kf2.mapPoint(j);
    ++added;
  }
  return added;
}

int fuse(KeyFrame* keyframe, const std::vector<MapPoint*>& points, double radius_factor, FuseKeeps keeps) {
  const ScalePyramid& pyramid = keyframe->pyramid();
  const Sim3 S_cw(keyframe->pose());
  const Vec3 centre = keyframe->cameraCentre();
  const ProjectionModel model(keyframe->camera(), keyframe->camera().bf);
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
      // Reprojection gate at the keypoint's scale (chi-square 95 %, with the
      // right coordinate where the keypoint has depth).
      const double u_right = keyframe->rightCoordinate(j);
      if (checkReprojection(model, keyframe->pose(), point->position(), keyframe->point(j), u_right,
                            pyramid.inv_sigma2[kp_level]).chi2 > chi2Bound95(u_right))
        continue;
      const int d = hammingDistance(point->descriptor().ptr<uint8_t>(), keyframe->descriptors.ptr<uint8_t>(j));
      if (d < best_distance) {
        best_distance = d;
        best_index = j;
      }
    }
    if (best_index < 0 || best_distance > kHammingThresholdGuided) continue;
    MapPoint* existing = keyframe->mapPoint(best_index);
    if (existing && !existing->isBad()) {
      if (keeps == FuseKeeps::MoreObserved && existing->observationCount() > point->observationCount())
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
  TriangulationSearchParams params;
  params.max_distance = kHammingThresholdGuided;  // the candidates lie on the epipolar line
  return searchForTriangulation(kf1.view(), kf2.view(), F21, kf1.pyramid().sigma2, matched1, matched2, params);
}

}  // namespace vslam
