#include "vslam/map/object_map.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <string>
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

std::string nameOf(int class_id, const std::vector<std::string>& class_names) {
  return class_id < static_cast<int>(class_names.size()) ? class_names[class_id] : std::to_string(class_id);
}

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

// Tukey's fences "far out": values below the first quartile or above the
// third by more than `factor` x the interquartile range (at least `min_range`).
// Fences from the quartiles rather than the median tolerate a skewed spread:
// keypoints gather on texture, and a dense core must not make an object's
// plainer end an outlier (fr1_xyz's keyboard lost its right end to a
// median-absolute-deviation gate).
std::pair<double, double> farOutFences(const std::vector<double>& values, double factor, double min_range) {
  const double q1 = percentile(values, 0.25), q3 = percentile(values, 0.75);
  const double margin = factor * std::max(q3 - q1, min_range);
  return {q1 - margin, q3 + margin};
}

// Which points of `group` agree with the rest: near the group's median
// position, and at its depth along their own viewing rays. A point seen
// through a detection box on the wall behind the object is off in depth only.
std::vector<bool> inliersOf(const std::vector<LabelledPoint>& points, const std::vector<size_t>& group,
                            double link_distance, const ObjectMapParams& params) {
  Vec3 median;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> axis;
    for (size_t i : group) axis.push_back(points[i].position[a]);
    median[a] = percentile(std::move(axis), 0.5);
  }
  const double min_range = params.min_spread_ratio * link_distance;
  std::vector<bool> inlier(group.size(), true);
  // Distance from the median position: only too far is an outlier.
  std::vector<double> distances;
  for (size_t i : group) distances.push_back((points[i].position - median).norm());
  const double distance_limit = farOutFences(distances, params.outlier_iqr_factor, min_range).second;
  for (size_t k = 0; k < group.size(); ++k)
    if (distances[k] > distance_limit) inlier[k] = false;
  // Depth along each point's own ray from the median: in front or behind.
  std::vector<double> depths;
  std::vector<size_t> with_ray;
  for (size_t k = 0; k < group.size(); ++k) {
    const LabelledPoint& point = points[group[k]];
    if (point.viewing_direction.squaredNorm() == 0.0) continue;
    depths.push_back((point.position - median).dot(point.viewing_direction.normalized()));
    with_ray.push_back(k);
  }
  if (!depths.empty()) {
    const auto [low, high] = farOutFences(depths, params.outlier_iqr_factor, min_range);
    for (size_t k = 0; k < depths.size(); ++k)
      if (depths[k] < low || depths[k] > high) inlier[with_ray[k]] = false;
  }
  // Half the members lie between the quartiles of each measure, so some
  // always remain; this guards only a degenerate input.
  if (std::none_of(inlier.begin(), inlier.end(), [](bool keep) { return keep; })) inlier.assign(group.size(), true);
  return inlier;
}

ObjectLandmark describe(const std::vector<LabelledPoint>& points, const std::vector<size_t>& group, int class_id,
                        double link_distance, const ObjectMapParams& params,
                        const std::vector<std::string>& class_names) {
  ObjectLandmark object;
  object.class_id = class_id;
  object.class_name = nameOf(class_id, class_names);
  const std::vector<bool> inlier = inliersOf(points, group, link_distance, params);
  std::vector<double> axis[3];
  std::vector<long> keyframes;
  for (size_t k = 0; k < group.size(); ++k) {
    const LabelledPoint& point = points[group[k]];
    if (!inlier[k]) {
      object.rejected_point_ids.push_back(point.id);
      continue;
    }
    object.point_ids.push_back(point.id);
    object.centroid += point.position;
    object.confidence += point.confidence;
    for (int a = 0; a < 3; ++a) axis[a].push_back(point.position[a]);
    keyframes.insert(keyframes.end(), point.keyframe_ids.begin(), point.keyframe_ids.end());
  }
  const double n = static_cast<double>(object.point_ids.size());
  object.centroid /= n;
  object.confidence /= n;
  // Percentiles rather than min/max: one mismatched point left must not stretch the box.
  for (int a = 0; a < 3; ++a) {
    object.box_min[a] = percentile(axis[a], params.box_percentile);
    object.box_max[a] = percentile(axis[a], 1.0 - params.box_percentile);
  }
  std::sort(object.point_ids.begin(), object.point_ids.end());
  std::sort(object.rejected_point_ids.begin(), object.rejected_point_ids.end());
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
  object.keyframe_ids = std::move(keyframes);
  return object;
}

// Confusable group of each class id named in `params.confusable_classes`.
std::map<int, size_t> confusableGroups(const ObjectMapParams& params, const std::vector<std::string>& class_names) {
  std::map<int, size_t> group_of;
  for (size_t g = 0; g < params.confusable_classes.size(); ++g)
    for (const std::string& name : params.confusable_classes[g])
      for (size_t id = 0; id < class_names.size(); ++id)
        if (class_names[id] == name) group_of.emplace(static_cast<int>(id), g);
  return group_of;
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

bool boxesOverlap(const Vec3& a_min, const Vec3& a_max, const Vec3& b_min, const Vec3& b_max, double margin,
                  double fraction) {
  double shared = 1.0, a_volume = 1.0, b_volume = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double low = std::max(a_min[k], b_min[k]) - margin, high = std::min(a_max[k], b_max[k]) + margin;
    shared *= std::max(0.0, high - low);
    a_volume *= a_max[k] - a_min[k] + 2.0 * margin;
    b_volume *= b_max[k] - b_min[k] + 2.0 * margin;
  }
  const double smaller = std::min(a_volume, b_volume);
  return smaller > 0.0 && shared >= fraction * smaller;
}

std::vector<ObjectLandmark> buildObjectMap(const std::vector<LabelledPoint>& points, double link_distance,
                                           const ObjectMapParams& params, const std::vector<std::string>& class_names) {
  std::vector<ObjectLandmark> objects;
  if (!(link_distance > 0.0)) return objects;
  // Members of each class ordered by point id, so the input order does not matter.
  std::map<int, std::vector<size_t>> by_class;
  for (size_t i = 0; i < points.size(); ++i)
    if (points[i].class_id >= 0 && points[i].position.allFinite()) by_class[points[i].class_id].push_back(i);
  std::vector<std::vector<size_t>> groups;  // of `objects`, index for index
  for (auto& [class_id, members] : by_class) {
    std::sort(members.begin(), members.end(), [&](size_t a, size_t b) { return points[a].id < points[b].id; });
    for (std::vector<size_t>& group : linkGroups(points, members, link_distance, params.box_link_factor * link_distance))
      if (static_cast<int>(group.size()) >= params.min_points) {
        ObjectLandmark object = describe(points, group, class_id, link_distance, params, class_names);
        if (static_cast<int>(object.point_ids.size()) < params.min_points) continue;  // too few agree
        objects.push_back(std::move(object));
        groups.push_back(std::move(group));
      }
  }

  // Overlapping objects of one confusable group join (transitively).
  const std::map<int, size_t> group_of = confusableGroups(params, class_names);
  auto confusable = [&](int a, int b) {
    const auto ga = group_of.find(a), gb = group_of.find(b);
    return a != b && ga != group_of.end() && gb != group_of.end() && ga->second == gb->second;
  };
  DisjointSets sets(objects.size());
  for (size_t i = 0; i < objects.size(); ++i)
    for (size_t j = i + 1; j < objects.size(); ++j)
      if (confusable(objects[i].class_id, objects[j].class_id) &&
          boxesOverlap(objects[i].box_min, objects[i].box_max, objects[j].box_min, objects[j].box_max,
                       0.5 * link_distance, params.merge_overlap))
        sets.join(i, j);
  std::map<size_t, std::vector<size_t>> merged;  // root -> objects, ascending
  for (size_t i = 0; i < objects.size(); ++i) merged[sets.find(i)].push_back(i);

  std::vector<std::pair<long, ObjectLandmark>> ordered;  // (smallest linked point id, object)
  for (const auto& [root, members] : merged) {
    std::vector<size_t> linked;
    std::map<int, size_t> support;  // class -> points (outliers excluded)
    for (size_t i : members) {
      linked.insert(linked.end(), groups[i].begin(), groups[i].end());
      support[objects[i].class_id] += objects[i].point_ids.size();
    }
    ObjectLandmark object = std::move(objects[members.front()]);
    if (members.size() > 1) {
      // The class with more support wins; on a tie, the smaller class id (the map is ordered).
      int winner = support.begin()->first;
      for (const auto& [class_id, count] : support)
        if (count > support[winner]) winner = class_id;
      object = describe(points, linked, winner, link_distance, params, class_names);
      for (const auto& [class_id, count] : support)
        if (class_id != winner) object.merged_classes.push_back(nameOf(class_id, class_names));
      std::sort(object.merged_classes.begin(), object.merged_classes.end());
    }
    long first_id = points[linked.front()].id;
    for (size_t i : linked) first_id = std::min(first_id, points[i].id);
    ordered.emplace_back(first_id, std::move(object));
  }
  std::sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) {
    return std::tie(a.second.class_id, a.first) < std::tie(b.second.class_id, b.first);
  });
  objects.clear();
  for (auto& [first_id, object] : ordered) objects.push_back(std::move(object));
  return objects;
}

}  // namespace vslam
