#pragma once
// The paper's Algorithm 1: more ORB keypoints on detected objects.
//
// For each detection box: clip it to the image; skip it when it is narrower or
// lower than min_box_px; otherwise extract ORB inside it (same pyramid as the
// frame) and append those keypoints to the frame's own, dropping exact
// duplicates (same position and pyramid level as a keypoint already there).
// Every keypoint is labelled with the class and detection id of its box.
//
// Beyond the paper: boxes of a dynamic class (e.g. person) remove every
// keypoint inside them instead of adding any, as DS-SLAM and DynaSLAM do for
// moving objects.
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/detect/detector.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {

struct KeypointLabel {
  int class_id = -1;      // -1: not on a detected object
  int detection_id = -1;  // Detection::id of the box
};

// Extracts keypoints (level-0 pixels, octave = level) and their descriptors
// (one row each) inside `box`, which lies inside the image.
using BoxExtractor = std::function<void(const cv::Rect& box, std::vector<cv::KeyPoint>&, cv::Mat& descriptors)>;

struct KeypointFilterStats {
  int boxes_used = 0;                 // static boxes ORB was extracted in
  int boxes_skipped_small = 0;        // static boxes under min_box_px (after clipping)
  int keypoints_added = 0;            // appended from the boxes
  int duplicates_dropped = 0;         // box keypoints equal to one already there
  int keypoints_removed_dynamic = 0;  // frame or box keypoints inside a dynamic box
};

// The integer box a detection covers inside the image: edges rounded to the
// nearest pixel, then intersected with the image (may be empty).
cv::Rect clipToImage(const cv::Rect2f& box, const cv::Size& image_size);

// Applies Algorithm 1 in place. `labels` comes in with one label per keypoint
// (an empty vector is filled with "none") and leaves aligned with `keypoints`
// and the rows of `descriptors`.
//
// Choices the paper leaves open:
//  - a keypoint lies in a box when x0 <= x < x1 and y0 <= y < y1 (clipped box);
//  - labels come from the boxes used (not from skipped small ones); where used
//    boxes overlap, the smallest box containing the keypoint wins (the nearer,
//    more specific object), for the frame's own keypoints and added ones alike;
//  - dynamic boxes remove keypoints whatever their size (a small moving object
//    still moves), and keypoints extracted in a static box that fall inside a
//    dynamic box are removed too;
//  - duplicates are exact: identical float position and octave.
KeypointFilterStats applyKeypointFilter(const cv::Size& image_size, const std::vector<Detection>& detections,
                                        int min_box_px, const std::vector<int>& dynamic_class_ids,
                                        const BoxExtractor& extract_in_box, std::vector<cv::KeyPoint>& keypoints,
                                        cv::Mat& descriptors, std::vector<KeypointLabel>& labels);

// The production BoxExtractor: `extractor` on the frame's own `pyramid`, asking
// for `features_per_box` keypoints in each box. The extractor and pyramid must
// outlive the returned function.
BoxExtractor orbBoxExtractor(const OrbExtractor& extractor, const ImagePyramid& pyramid, int features_per_box);

// The cheaper extractor (issue 15): the frame's own FAST corners inside the
// box (no FAST run, same quotas and quadtree), described only where the box's
// quota picked a corner the frame's quota had dropped; so the filter adds
// only keypoints that are new. `frame_winners` (when given) accumulates the box
// winners that were frame keypoints already. Everything passed must outlive
// the returned function.
// `corners` is updated as boxes add keypoints (see extractFromCorners).
BoxExtractor cornerBoxExtractor(const OrbExtractor& extractor, const ImagePyramid& pyramid, OrbCorners& corners,
                                int features_per_box, int* frame_winners = nullptr);

// Features to ask for in each box: DetectorParams::box_features, or the
// frame's OrbParams::n_features when that is 0.
inline int featuresPerBox(const DetectorParams& detector, const OrbParams& orb) {
  return detector.box_features > 0 ? detector.box_features : orb.n_features;
}

}  // namespace vslam
