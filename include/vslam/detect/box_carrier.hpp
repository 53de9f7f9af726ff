#pragma once
// Carries detection boxes to the frames the network did not see (issue 15).
//
// A box moves with the keypoints inside it: the frame's own ORB keypoints are
// matched to those of the frame the box was last placed on (same pyramid
// level, within a window, Hamming distance and ratio test), and the box
// follows the median motion of the matches, a scale and a translation. Each box
// counts the frames since the network saw it; past max_box_age it expires, and
// a box whose matches are too few to move it is dropped rather than left
// behind.
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/detect/detector.hpp"

namespace vslam {

// A frame's own keypoints and descriptors (one row each): what boxes are carried by.
struct FeatureSnapshot {
  int frame_index = -1;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

// p' = scale * p + translation, for every point of the box.
struct BoxMotion {
  float scale = 1.f;
  cv::Point2f translation;
  int support = 0;  // matches it was fitted to
};

struct CarriedBox {
  Detection detection;  // box in the current frame's pixels
  int age = 0;          // frames since the network saw it (0: this frame's own detection)
};

struct BoxCarrierParams {
  int max_age = 30;                 // older boxes expire
  float search_radius_px = 24.f;    // window per frame of gap, at level 0 (scaled by the keypoint's level)
  float max_search_radius_px = 96.f;
  int max_hamming = 50;             // ORB-SLAM's TH_LOW
  float ratio = 0.8f;               // best / second best Hamming distance
  int min_support = 3;              // matches needed to move a box
  float max_scale_step = 1.5f;      // a fitted scale beyond [1/x, x] is a bad fit: the box is dropped
};

// Median fit: the scale is the median ratio of distances between matches i
// and i + n/2 (pairs closer than 1 px left out), the translation the median of
// after - scale * before per axis. Exact for points related by a scale and a
// translation, and a minority of wrong matches does not move it; nullopt
// when there are fewer than `min_support` matches.
std::optional<BoxMotion> fitBoxMotion(const std::vector<cv::Point2f>& before, const std::vector<cv::Point2f>& after,
                                      int min_support);

cv::Rect2f moveBox(const cv::Rect2f& box, const BoxMotion& motion);

// Pairs (position in `from`, position in `to`) for the keypoints of `from`
// inside `box`, matched to keypoints of `to` at the same level within
// `radius_px` (level 0 pixels, times the level's scale). A `to` keypoint is used once.
void matchInsideBox(const FeatureSnapshot& from, const FeatureSnapshot& to, const cv::Rect2f& box, float radius_px,
                    const BoxCarrierParams& params, std::vector<cv::Point2f>& before, std::vector<cv::Point2f>& after);

class BoxCarrier {
 public:
  explicit BoxCarrier(const BoxCarrierParams& params) : params_(params) {}

  // Moves the boxes from the last frame to `frame` and ages them by the frames
  // between the two (by index); expired boxes and boxes that cannot be moved are
  // dropped. `frame` becomes the last frame.
  void advance(const FeatureSnapshot& frame);

  // New detections of the network on `detected` (an earlier frame or the
  // current one), moved from it to the last frame advanced to; they replace
  // every carried box (they are newer). Detections older than max_age, or
  // that cannot be moved, are dropped.
  void replace(const std::vector<Detection>& detections, const FeatureSnapshot& detected);

  // Forgets every box and the last frame (e.g. the map was reset).
  void clear();

  const std::vector<CarriedBox>& boxes() const { return boxes_; }
  // The boxes as detections for the keypoint filter, ids renumbered 0.. in order.
  std::vector<Detection> detections() const;
  const BoxCarrierParams& params() const { return params_; }
  int lastFrameIndex() const { return last_.frame_index; }
  int expired() const { return expired_; }    // boxes dropped for age so far
  int unmoved() const { return unmoved_; }    // boxes dropped for too few matches so far

 private:
  // `box` moved from `from` to `to`, or nullopt.
  std::optional<cv::Rect2f> carry(const cv::Rect2f& box, const FeatureSnapshot& from, const FeatureSnapshot& to) const;

  BoxCarrierParams params_;
  FeatureSnapshot last_;
  std::vector<CarriedBox> boxes_;
  int expired_ = 0, unmoved_ = 0;
};

}  // namespace vslam
