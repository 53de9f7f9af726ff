#include "vslam/detect/keypoint_filter.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <tuple>

namespace vslam {
namespace {

bool inside(const cv::Rect& box, const cv::Point2f& point) {
  return point.x >= box.x && point.x < box.x + box.width && point.y >= box.y && point.y < box.y + box.height;
}

// A used static box with the label it gives.
struct LabelBox {
  cv::Rect box;
  KeypointLabel label;
};

// Smallest used box containing `point`, or none.
KeypointLabel labelAt(const std::vector<LabelBox>& boxes, const cv::Point2f& point) {
  KeypointLabel label;
  int smallest_area = -1;
  for (const LabelBox& candidate : boxes) {
    if (!inside(candidate.box, point)) continue;
    if (smallest_area < 0 || candidate.box.area() < smallest_area) {
      smallest_area = candidate.box.area();
      label = candidate.label;
    }
  }
  return label;
}

using KeypointKey = std::tuple<float, float, int>;
KeypointKey keyOf(const cv::KeyPoint& keypoint) { return {keypoint.pt.x, keypoint.pt.y, keypoint.octave}; }

}  // namespace

cv::Rect clipToImage(const cv::Rect2f& box, const cv::Size& image_size) {
  const int x0 = static_cast<int>(std::lround(box.x)), y0 = static_cast<int>(std::lround(box.y));
  const int x1 = static_cast<int>(std::lround(box.x + box.width)), y1 = static_cast<int>(std::lround(box.y + box.height));
  const cv::Rect rounded(cv::Point(x0, y0), cv::Point(std::max(x0, x1), std::max(y0, y1)));
  return rounded & cv::Rect(cv::Point(0, 0), image_size);
}

KeypointFilterStats applyKeypointFilter(const cv::Size& image_size, const std::vector<Detection>& detections,
                                        int min_box_px, const std::vector<int>& dynamic_class_ids,
                                        const BoxExtractor& extract_in_box, std::vector<cv::KeyPoint>& keypoints,
                                        cv::Mat& descriptors, std::vector<KeypointLabel>& labels) {
  if (labels.empty()) labels.resize(keypoints.size());
  if (labels.size() != keypoints.size() || (!keypoints.empty() && descriptors.rows != static_cast<int>(keypoints.size())))
    throw std::invalid_argument("applyKeypointFilter: keypoints, descriptor rows and labels must have the same count");

  KeypointFilterStats stats;
  std::vector<cv::Rect> dynamic_boxes;
  std::vector<LabelBox> used_boxes;
  for (const Detection& detection : detections) {
    const cv::Rect box = clipToImage(detection.box, image_size);
    const bool dynamic = std::find(dynamic_class_ids.begin(), dynamic_class_ids.end(), detection.class_id) !=
                         dynamic_class_ids.end();
    if (dynamic) {
      if (!box.empty()) dynamic_boxes.push_back(box);
    } else if (box.width < min_box_px || box.height < min_box_px) {
      ++stats.boxes_skipped_small;
    } else {
      used_boxes.push_back({box, {detection.class_id, detection.id}});
    }
  }
  auto inDynamicBox = [&](const cv::Point2f& point) {
    return std::any_of(dynamic_boxes.begin(), dynamic_boxes.end(), [&](const cv::Rect& box) { return inside(box, point); });
  };

  // The frame's own keypoints: drop those on dynamic objects, label the rest.
  std::vector<cv::KeyPoint> kept_keypoints;
  std::vector<KeypointLabel> kept_labels;
  cv::Mat kept_descriptors;
  std::set<KeypointKey> present;
  for (size_t i = 0; i < keypoints.size(); ++i) {
    if (inDynamicBox(keypoints[i].pt)) {
      ++stats.keypoints_removed_dynamic;
      continue;
    }
    const KeypointLabel box_label = labelAt(used_boxes, keypoints[i].pt);
    kept_keypoints.push_back(keypoints[i]);
    kept_labels.push_back(box_label.class_id >= 0 ? box_label : labels[i]);
    kept_descriptors.push_back(descriptors.row(static_cast<int>(i)));
    present.insert(keyOf(keypoints[i]));
  }

  // ORB inside every used box, appended unless already there.
  for (const LabelBox& used : used_boxes) {
    ++stats.boxes_used;
    std::vector<cv::KeyPoint> box_keypoints;
    cv::Mat box_descriptors;
    extract_in_box(used.box, box_keypoints, box_descriptors);
    if (!box_keypoints.empty() && box_descriptors.rows != static_cast<int>(box_keypoints.size()))
      throw std::invalid_argument("applyKeypointFilter: the box extractor returned a descriptor count that differs");
    for (size_t i = 0; i < box_keypoints.size(); ++i) {
      const cv::KeyPoint& keypoint = box_keypoints[i];
      if (inDynamicBox(keypoint.pt)) {
        ++stats.keypoints_removed_dynamic;
        continue;
      }
      if (!present.insert(keyOf(keypoint)).second) {
        ++stats.duplicates_dropped;
        continue;
      }
      const KeypointLabel at = labelAt(used_boxes, keypoint.pt);
      kept_keypoints.push_back(keypoint);
      kept_labels.push_back(at.class_id >= 0 ? at : used.label);
      kept_descriptors.push_back(box_descriptors.row(static_cast<int>(i)));
      ++stats.keypoints_added;
    }
  }

  keypoints = std::move(kept_keypoints);
  labels = std::move(kept_labels);
  // Keep the descriptor type of an empty input when nothing survives.
  if (kept_descriptors.empty()) kept_descriptors = cv::Mat(0, descriptors.cols, descriptors.type());
  descriptors = kept_descriptors;
  return stats;
}

BoxExtractor orbBoxExtractor(const OrbExtractor& extractor, const ImagePyramid& pyramid, int features_per_box) {
  return [&extractor, &pyramid, features_per_box](const cv::Rect& box, std::vector<cv::KeyPoint>& keypoints,
                                                   cv::Mat& descriptors) {
    extractor.extract(pyramid, keypoints, descriptors, box, features_per_box);
  };
}

BoxExtractor cornerBoxExtractor(const OrbExtractor& extractor, const ImagePyramid& pyramid, OrbCorners& corners,
                                int features_per_box, int* frame_winners) {
  return [&extractor, &pyramid, &corners, features_per_box, frame_winners](
             const cv::Rect& box, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) {
    int reused = 0;
    extractor.extractFromCorners(pyramid, corners, box, features_per_box, keypoints, descriptors, &reused);
    if (frame_winners) *frame_winners += reused;
  };
}

}  // namespace vslam
