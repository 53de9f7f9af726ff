#include "vslam/map/object_map.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>
#include <utility>

namespace vslam {
namespace {

// Union-find over point positions in one class.
class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), size_t{0}); }
  size_t find(size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  // The smaller root wins, so the result does not depend on the order of joins.
  void join(size_t a, size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<size_t> parent_;
};

using Cell = std::tuple<long, long, long>;

// Single-linkage groups of `members` (indices into points): close points, and
// less close ones sharing a detection box, are joined. A grid of cells one link
// distance wide means only the 27 surrounding cells can hold neighbours.
std::vector<std::vector<size_t>> linkGroups(const std::vector<LabelledPoint>& points, const std::vector<size_t>& members,
                                            double link_distance, double box_link_distance) {
  auto cellOf = [&](const Vec3& p) {
    return Cell{static_cast<long>(std::floor(p.x() / link_distance)), static_cast<long>(std::floor(p.y() / link_distance)),
                static_cast<long>(std::floor(p.z() / link_distance))};
  };
  std::map<Cell, std::vector<size_t>> grid;  // cell -> positions in `members`
  for (size_t m = 0; m < members.size(); ++m) grid[cellOf(points[members[m]].position)].push_back(m);

  DisjointSets sets(members.size());
  const double limit2 = link_distance * link_distance;
  for (size_t m = 0; m < members.size(); ++m) {
    const Vec3& p = points[members[m]].position;
    const auto [cx, cy, cz] = cellOf(p);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          const auto cell = grid.find({cx + dx, cy + dy, cz + dz});
          if (cell == grid.end()) continue;
          for (size_t other : cell->second)
            if (other > m && (points[members[other]].position - p).squaredNorm() <= limit2) sets.join(m, other);
        }
  }
  std::map<std::pair<long, int>, std::vector<size_t>> in_box;  // (keyframe, detection) -> members seen in it
  for (size_t m = 0; m < members.size(); ++m)
    for (const auto& box : points[members[m]].detections) in_box[box].push_back(m);
  const double box_limit2 = box_link_distance * box_link_distance;
  for (const auto& [box, seen] : in_box)
    for (size_t i = 0; i < seen.size(); ++i)
      for (size_t j = i + 1; j < seen.size(); ++j)
        if ((points[members[seen[i]]].position - points[members[seen[j]]].position).squaredNorm() <= box_limit2)
          sets.join(seen[i], seen[j]);
  std::map<size_t, std::vector<size_t>> by_root;  // root -> point indices, in member order
  for (size_t m = 0; m < members.size(); ++m) by_root[sets.find(m)].push_back(members[m]);
  std::vector<std::vector<size_t>> groups;
  for (auto& [root, group] : by_root) groups.push_back(std::move(group));
  return groups;
}

ObjectLandmark describe(const std::vector<LabelledPoint>& points, const std::vector<size_t>& group, int class_id,
                        const ObjectMapParams& params, const std::vector<std::string>& class_names) {
  ObjectLandmark object;
  object.class_id = class_id;
  object.class_name = class_id < static_cast<int>(class_names.size()) ? class_names[class_id] : std::to_string(class_id);
  std::vector<double> axis[3];
  std::vector<long> keyframes;
  for (size_t i : group) {
    const LabelledPoint& point = points[i];
    object.point_ids.push_back(point.id);
    object.centroid += point.position;
    object.confidence += point.confidence;
    for (int a = 0; a < 3; ++a) axis[a].push_back(point.position[a]);
    keyframes.insert(keyframes.end(), point.keyframe_ids.begin(), point.keyframe_ids.end());
  }
  const double n = static_cast<double>(group.size());
  object.centroid /= n;
  object.confidence /= n;
  // Percentiles rather than min/max: one mismatched point must not stretch the box.
  for (int a = 0; a < 3; ++a) {
    object.box_min[a] = percentile(axis[a], params.box_percentile);
    object.box_max[a] = percentile(axis[a], 1.0 - params.box_percentile);
  }
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
  object.keyframe_ids = std::move(keyframes);
  return object;
}

}  // namespace

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, values.size() - 1);
  const double t = position - static_cast<double>(below);
  return values[below] * (1.0 - t) + values[above] * t;
}

std::vector<ObjectLandmark> buildObjectMap(const std::vector<LabelledPoint>& points, double link_distance,
                                           const ObjectMapParams& params, const std::vector<std::string>& class_names) {
  std::vector<ObjectLandmark> objects;
  if (!(link_distance > 0.0)) return objects;
  // Members of each class ordered by point id, so the input order does not matter.
  std::map<int, std::vector<size_t>> by_class;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].class_id >= 0 && points[i].position.allFinite()) by_class[points[i].class_id].push_back(i);
  for (auto& [class_id, members] : by_class) {
    std::sort(members.begin(), members.end(), [&](size_t a, size_t b) { return points[a].id < points[b].id; });
    for (const std::vector<size_t>& group : linkGroups(points, members, link_distance, params.box_link_factor * link_distance))
      if (static_cast<int>(group.size()) >= params.min_points)
        objects.push_back(describe(points, group, class_id, params, class_names));
  }
  return objects;
}

}  // namespace vslam
