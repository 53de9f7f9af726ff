#include "vslam/map/map_point.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vslam/feature/matcher.hpp"
#include "vslam/map/keyframe.hpp"

namespace vslam {

MapPoint::MapPoint(long id, const Vec3& position_w, KeyFrame* reference, long first_keyframe_id)
    : id_(id), first_keyframe_id_(first_keyframe_id), position_w_(position_w), reference_(reference) {}

void MapPoint::addObservation(KeyFrame* keyframe, int keypoint) {
  auto [it, inserted] = observations_.try_emplace(keyframe, keypoint);
  if (!inserted) {
    observation_weight_ -= keyframe->observationWeight(it->second);
    it->second = keypoint;
  }
  observation_weight_ += keyframe->observationWeight(keypoint);
}

MapPoint::SavedState MapPoint::savedState() const {
  SavedState state;
  state.descriptor = descriptor_;
  state.normal = normal_;
  state.min_distance = min_distance_;
  state.max_distance = max_distance_;
  state.visible = visible_;
  state.found = found_;
  state.class_id = class_id_;
  state.class_confidence = class_confidence_;
  state.colour = colour_;
  state.confirmed_min_observations = confirmed_min_observations_;
  return state;
}

void MapPoint::restoreState(const SavedState& state) {
  descriptor_ = state.descriptor.clone();
  normal_ = state.normal;
  min_distance_ = state.min_distance;
  max_distance_ = state.max_distance;
  visible_ = state.visible;
  found_ = state.found;
  class_id_ = state.class_id;
  class_confidence_ = state.class_confidence;
  colour_ = state.colour;
  confirmed_min_observations_ = state.confirmed_min_observations;
}

void MapPoint::eraseObservation(KeyFrame* keyframe) {
  auto it = observations_.find(keyframe);
  if (it == observations_.end()) return;
  observation_weight_ -= keyframe->observationWeight(it->second);
  observations_.erase(it);
  if (reference_ == keyframe && !observations_.empty()) reference_ = observations_.begin()->first;
  // A point seen from one keyframe without depth carries no depth information;
  // a confirmed one must keep the map's minimum of observers.
  const int needed = std::max(2, confirmed_min_observations_);
  if (observation_weight_ < needed) setBad();
}

int MapPoint::keypointIn(const KeyFrame* keyframe) const {
  auto it = observations_.find(const_cast<KeyFrame*>(keyframe));
  return it == observations_.end() ? -1 : it->second;
}

void MapPoint::setBad() {
  if (bad_) return;
  bad_ = true;
  for (auto& [keyframe, index] : observations_) keyframe->setMapPoint(index, nullptr);
  observations_.clear();
  observation_weight_ = 0;
}

void MapPoint::replaceWith(MapPoint* other) {
  if (other == this || bad_) return;
  for (auto& [keyframe, index] : observations_) {
    if (other->keypointIn(keyframe) < 0) {
      keyframe->setMapPoint(index, other);
      other->addObservation(keyframe, index);
    } else {
      keyframe->setMapPoint(index, nullptr);
    }
  }
  other->increaseFound(found_);
  other->increaseVisible(visible_);
  observations_.clear();
  observation_weight_ = 0;
  bad_ = true;
  replaced_by_ = other;
  other->updateDescriptor();
}

void MapPoint::updateDescriptor() {
  std::vector<const uint8_t*> descriptors;
  descriptors.reserve(observations_.size());
  for (const auto& [keyframe, index] : observations_)
    if (!keyframe->isBad()) descriptors.push_back(keyframe->descriptors.ptr<uint8_t>(index));
  if (descriptors.empty()) return;
  // The most distinctive descriptor: least median distance to the others.
  const size_t n = descriptors.size();
  std::vector<int> distances(n * n, 0);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      distances[i * n + j] = distances[j * n + i] = hammingDistance(descriptors[i], descriptors[j]);
  int best_median = std::numeric_limits<int>::max();
  size_t best = 0;
  std::vector<int> row(n);
  for (size_t i = 0; i < n; ++i) {
    std::copy(distances.begin() + i * n, distances.begin() + (i + 1) * n, row.begin());
    std::nth_element(row.begin(), row.begin() + (n - 1) / 2, row.end());
    if (row[(n - 1) / 2] < best_median) {
      best_median = row[(n - 1) / 2];
      best = i;
    }
  }
  descriptor_ = cv::Mat(1, 32, CV_8U);
  std::copy(descriptors[best], descriptors[best] + 32, descriptor_.ptr<uint8_t>());
}

void MapPoint::updateNormalAndDepth(const ScalePyramid& pyramid) {
  if (observations_.empty() || !reference_) return;
  Vec3 normal = Vec3::Zero();
  int n = 0;
  for (const auto& [keyframe, index] : observations_) {
    normal += (position_w_ - keyframe->cameraCentre()).normalized();
    ++n;
  }
  const int ref_index = keypointIn(reference_);
  if (ref_index < 0) return;
  const double distance = (position_w_ - reference_->cameraCentre()).norm();
  const int level = reference_->keypoints[ref_index].octave;
  // The point could have been seen at any level: scale the observed distance to the pyramid's ends.
  max_distance_ = distance * pyramid.scale[level];
  min_distance_ = max_distance_ / pyramid.scale[pyramid.levels - 1];
  normal_ = normal / n;
}

int MapPoint::predictLevel(double distance, const ScalePyramid& pyramid) const {
  const double ratio = max_distance_ / distance;
  int level = static_cast<int>(std::ceil(std::log(ratio) / pyramid.logScaleFactor()));
  return std::clamp(level, 0, pyramid.levels - 1);
}

void MapPoint::updateClass() {
  std::map<int, int> votes;
  for (const auto& [keyframe, index] : observations_) {
    const int cls = keyframe->labels[index].class_id;
    if (cls >= 0) {
      ++votes[cls];
    }
  }
  class_id_ = -1;
  class_confidence_ = 0.0;
  int best_votes = 0;
  for (const auto& [cls, count] : votes)
    if (count > best_votes) {
      best_votes = count;
      class_id_ = cls;
    }
  // Majority of all observations, so a point seen mostly outside boxes stays unlabelled.
  if (2 * best_votes <= static_cast<int>(observations_.size())) class_id_ = -1;
  if (class_id_ >= 0) class_confidence_ = static_cast<double>(best_votes) / observations_.size();
}

}  // namespace vslam
