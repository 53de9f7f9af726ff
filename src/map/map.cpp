#include "vslam/map/map.hpp"

#include <algorithm>
#include <stdexcept>

namespace vslam {

KeyFrame* Map::createKeyFrame(const Frame& frame) {
  keyframes_.push_back(std::make_unique<KeyFrame>(next_keyframe_id_++, frame));
  return keyframes_.back().get();
}

MapPoint* Map::createMapPoint(const Vec3& position_w, KeyFrame* reference) {
  map_points_.push_back(std::make_unique<MapPoint>(next_map_point_id_++, position_w, reference, reference->id()));
  return map_points_.back().get();
}

KeyFrame* Map::restoreKeyFrame(long id, const Frame& frame) {
  // keyFrameById's binary search needs the keyframes in id order.
  if (id < next_keyframe_id_) throw std::logic_error("Map::restoreKeyFrame: keyframe ids must increase");
  keyframes_.push_back(std::make_unique<KeyFrame>(id, frame));
  next_keyframe_id_ = id + 1;
  return keyframes_.back().get();
}

MapPoint* Map::restoreMapPoint(long id, const Vec3& position_w, KeyFrame* reference, long first_keyframe_id) {
  if (id < next_map_point_id_) throw std::logic_error("Map::restoreMapPoint: map point ids must increase");
  map_points_.push_back(std::make_unique<MapPoint>(id, position_w, reference, first_keyframe_id));
  next_map_point_id_ = id + 1;
  return map_points_.back().get();
}

std::vector<KeyFrame*> Map::keyframes() const {
  std::vector<KeyFrame*> result;
  result.reserve(keyframes_.size());
  for (const auto& keyframe : keyframes_)
    if (!keyframe->isBad()) result.push_back(keyframe.get());
  return result;
}

std::vector<MapPoint*> Map::mapPoints() const {
  std::vector<MapPoint*> result;
  result.reserve(map_points_.size());
  for (const auto& point : map_points_)
    if (!point->isBad()) result.push_back(point.get());
  return result;
}

KeyFrame* Map::keyFrameById(long id) const {
  // Ids grow with creation order, so the vector is sorted by id.
  auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), id,
                             [](const std::unique_ptr<KeyFrame>& keyframe, long value) { return keyframe->id() < value; });
  return it != keyframes_.end() && (*it)->id() == id ? it->get() : nullptr;
}

void Map::clear() {
  keyframes_.clear();
  map_points_.clear();
  // A new map starts again at keyframe 0: the first keyframe anchors the gauge
  // and roots the spanning tree, and is recognised by its id.
  next_keyframe_id_ = 0;
  next_map_point_id_ = 0;
}

size_t Map::keyframeCount() const {
  size_t n = 0;
  for (const auto& keyframe : keyframes_) n += keyframe->isBad() ? 0 : 1;
  return n;
}

size_t Map::mapPointCount() const {
  size_t n = 0;
  for (const auto& point : map_points_) n += point->isBad() ? 0 : 1;
  return n;
}

}  // namespace vslam
