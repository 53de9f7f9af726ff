#pragma once
// Containers of keyframes and map points ordered by id, never by address:
// iteration order then does not depend on where the allocator put things, so
// deterministic runs repeat exactly.
#include <map>
#include <set>

namespace vslam {

class KeyFrame;
class MapPoint;

struct ById {
  template <typename T>
  bool operator()(const T* a, const T* b) const {
    return a->id() < b->id();
  }
};

template <typename Value>
using KeyFrameMap = std::map<KeyFrame*, Value, ById>;
using KeyFrameSet = std::set<KeyFrame*, ById>;
using MapPointSet = std::set<MapPoint*, ById>;

}  // namespace vslam
