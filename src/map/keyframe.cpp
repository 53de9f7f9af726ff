#include "vslam/map/keyframe.hpp"

#include <algorithm>

#include "vslam/map/map_point.hpp"

namespace vslam {

KeyFrame::KeyFrame(long id, const Frame& frame)
    : keypoints(frame.keypoints),
      points(frame.points),
      descriptors(frame.descriptors.clone()),
      labels(frame.labels),
      colours(frame.colours),
      depth(frame.depth),
      u_right(frame.u_right),
      grid(frame.grid),
      id_(id),
      frame_id_(frame.id),
      frame_index_(frame.index),
      timestamp_(frame.timestamp),
      camera_(frame.camera),
      pyramid_(frame.pyramid),
      T_cw_(frame.T_cw),
      map_points_(frame.map_points) {
  for (size_t i = 0; i < map_points_.size(); ++i)
    if (i < frame.outlier.size() && frame.outlier[i]) map_points_[i] = nullptr;
}

Vec3 KeyFrame::unprojectToWorld(size_t i) const {
  const Vec3 p_c = camera_->unproject(point(i)) * static_cast<double>(depth[i]);
  return T_cw_.R.transpose() * (p_c - T_cw_.t);
}

void KeyFrame::eraseMapPoint(MapPoint* point) {
  const int index = point->keypointIn(this);
  if (index >= 0 && map_points_[index] == point) map_points_[index] = nullptr;
}

int KeyFrame::trackedMapPoints(int min_observations) const {
  int count = 0;
  for (MapPoint* point : map_points_)
    if (point && !point->isBad() && point->observationWeight() >= min_observations) ++count;
  return count;
}

MapPointSet KeyFrame::goodMapPoints() const {
  MapPointSet result;
  for (MapPoint* point : map_points_)
    if (point && !point->isBad()) result.insert(point);
  return result;
}

void KeyFrame::addConnection(KeyFrame* other, int weight) {
  connection_weights_[other] = weight;
  updateOrder();
}

void KeyFrame::eraseConnection(KeyFrame* other) {
  if (connection_weights_.erase(other)) updateOrder();
}

void KeyFrame::updateOrder() {
  std::vector<std::pair<int, KeyFrame*>> sorted;
  sorted.reserve(connection_weights_.size());
  for (const auto& [keyframe, weight] : connection_weights_) sorted.emplace_back(weight, keyframe);
  // Heaviest first; ties by id so the order never depends on pointer values.
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second->id() < b.second->id();
  });
  ordered_covisibles_.clear();
  ordered_weights_.clear();
  for (const auto& [weight, keyframe] : sorted) {
    ordered_covisibles_.push_back(keyframe);
    ordered_weights_.push_back(weight);
  }
}

void KeyFrame::updateConnections() {
  KeyFrameMap<int> counts;
  for (MapPoint* point : map_points_) {
    if (!point || point->isBad()) continue;
    for (const auto& [keyframe, index] : point->observations())
      if (keyframe != this && !keyframe->isBad()) ++counts[keyframe];
  }
  if (counts.empty()) {
    // No shared point yet: keep the tree connected through the fallback parent.
    if (!parent_ && id_ != 0 && !bad_) {
      KeyFrame* fallback = fallback_parent_;
      while (fallback && fallback->isBad()) fallback = fallback->parent();
      if (fallback && fallback != this) {
        changeParent(fallback);
        parent_is_fallback_ = true;
      }
    }
    return;
  }
  // Edges need at least 15 shared points; keep the strongest one regardless so the graph stays connected.
  constexpr int kMinWeight = 15;
  KeyFrame* strongest = nullptr;
  int strongest_weight = 0;
  for (const auto& [keyframe, weight] : counts)
    if (weight > strongest_weight || (weight == strongest_weight && strongest && keyframe->id() < strongest->id())) {
      strongest = keyframe;
      strongest_weight = weight;
    }
  connection_weights_.clear();
  for (const auto& [keyframe, weight] : counts) {
    if (weight >= kMinWeight || keyframe == strongest) {
      connection_weights_[keyframe] = weight;
      keyframe->addConnection(this, weight);
    }
  }
  updateOrder();
  // The parent is chosen once, at the first real link (a fallback parent gives way to it).
  if ((!parent_ || parent_is_fallback_) && id_ != 0 && !bad_ && !isDescendant(strongest)) {
    changeParent(strongest);
    parent_is_fallback_ = false;
  }
}

bool KeyFrame::isDescendant(const KeyFrame* other) const {
  // Walks up from `other`: a parent link to one of our descendants would make a cycle.
  for (const KeyFrame* k = other; k; k = k->parent_)
    if (k == this) return true;
  return false;
}

std::vector<KeyFrame*> KeyFrame::bestCovisibles(size_t n) const {
  std::vector<KeyFrame*> result;
  for (KeyFrame* keyframe : ordered_covisibles_) {
    if (result.size() >= n) break;
    if (!keyframe->isBad()) result.push_back(keyframe);
  }
  return result;
}

std::vector<KeyFrame*> KeyFrame::covisiblesWithWeight(int min_weight) const {
  std::vector<KeyFrame*> result;
  for (size_t i = 0; i < ordered_covisibles_.size() && ordered_weights_[i] >= min_weight; ++i)
    if (!ordered_covisibles_[i]->isBad()) result.push_back(ordered_covisibles_[i]);
  return result;
}

int KeyFrame::weight(KeyFrame* other) const {
  auto it = connection_weights_.find(other);
  return it == connection_weights_.end() ? 0 : it->second;
}

void KeyFrame::changeParent(KeyFrame* parent) {
  if (parent_) parent_->children_.erase(this);
  parent_ = parent;
  if (parent_) parent_->children_.insert(this);
}

void KeyFrame::setBad() {
  if (!erasable() || bad_) return;
  // Without a parent the children would be cut off from the root.
  if (!parent_ || parent_->isBad()) return;
  // Copy first: erasing this keyframe's connections changes the neighbours' covisibility lists.
  const std::vector<KeyFrame*> neighbours = ordered_covisibles_;
  for (KeyFrame* keyframe : neighbours) keyframe->eraseConnection(this);
  for (size_t i = 0; i < map_points_.size(); ++i)
    if (map_points_[i]) {
      MapPoint* point = map_points_[i];
      map_points_[i] = nullptr;
      point->eraseObservation(this);
    }
  connection_weights_.clear();
  ordered_covisibles_.clear();
  ordered_weights_.clear();

  // Reattach each child to the candidate parent it shares most points with:
  // the grandparent or an already reattached sibling.
  KeyFrameSet parent_candidates = {parent_};
  KeyFrameSet orphans = children_;
  while (!orphans.empty()) {
    KeyFrame* best_child = nullptr;
    KeyFrame* best_parent = nullptr;
    int best_weight = -1;
    for (KeyFrame* child : orphans) {
      if (child->isBad()) continue;
      for (KeyFrame* candidate : parent_candidates) {
        const int w = child->weight(candidate);
        if (w > best_weight) {
          best_weight = w;
          best_child = child;
          best_parent = candidate;
        }
      }
    }
    if (!best_child || best_weight <= 0) break;
    best_child->changeParent(best_parent);
    parent_candidates.insert(best_child);
    orphans.erase(best_child);
  }
  for (KeyFrame* child : orphans) child->changeParent(parent_);
  children_.clear();
  T_c_parent_ = T_cw_ * parent_->pose().inverse();
  parent_->children_.erase(this);
  bad_ = true;
  // parent_ is kept: the trajectory of frames referring to this keyframe follows it.
}

SE3 poseThroughReference(KeyFrame* reference, SE3 T_c_ref, KeyFrame** live_reference) {
  while (reference->isBad() && reference->parent()) {
    T_c_ref = T_c_ref * reference->poseRelativeToParent();
    reference = reference->parent();
  }
  if (live_reference) *live_reference = reference;
  return T_c_ref * reference->pose();
}

double KeyFrame::medianSceneDepth() const {
  std::vector<double> depths;
  for (MapPoint* point : map_points_)
    if (point && !point->isBad()) depths.push_back((T_cw_ * point->position()).z());
  if (depths.empty()) return 1.0;
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  return depths[depths.size() / 2];
}

}  // namespace vslam
