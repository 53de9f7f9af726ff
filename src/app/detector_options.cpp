#include "detector_options.hpp"

#include "vslam/core/error.hpp"

namespace vslam::app {

void addDetectorOptions(CLI::App& command, DetectorOptions& options) {
  command.add_option("--detector", options.model,
                     "Detector model: yolo-fastest-1.1-xl, yolo-fastest-1.1, yolov4, yolov4-tiny; 'none' turns detection "
                     "off (default: the config's detector.model, yolo-fastest-1.1-xl)");
  command.add_option("--detector-cfg", options.cfg, "Darknet cfg file (overrides the model's)");
  command.add_option("--detector-weights", options.weights, "Darknet weights file (overrides the model's)");
  command.add_option("--detector-names", options.names, "Class names file, one a line (overrides the model's)");
  command.add_option("--input-size", options.input_size,
                     "Network input size in pixels, square, a multiple of 32 (320, 416, 608) (default: the config's "
                     "detector.input_size; 0 there, as shipped: the model cfg's [net] width and height)");
  command.add_option("--conf", options.confidence, "Confidence threshold in [0, 1]");
  command.add_option("--nms", options.nms, "Non-maximum suppression IoU threshold in [0, 1]");
  command.add_option("--min-box-px", options.min_box_px, "Skip boxes narrower or lower than this (paper: 64)");
  command.add_option("--box-features", options.box_features,
                     "ORB features asked for inside each box (default 250; 0: the frame's n_features)");
  command.add_option("--dnn-target", options.dnn_target, "cpu (default), opencl or cuda, where OpenCV supports it");
  command.add_option("--dynamic-classes", options.dynamic_classes,
                     "Comma-separated classes whose keypoints are removed, e.g. person,car")
      ->delimiter(',');
  command.add_option("--moving-classes", options.moving_classes,
                     "Comma-separated classes whose boxes are checked for motion each frame: moving instances are "
                     "kept out of tracking and mapping, parked ones stay (coco-movable: COCO's movable classes)")
      ->delimiter(',');
  command.add_option("--detect-every", options.detect_every,
                     "Frames the network sees: N (every N-th frame; 1 = every frame, the paper), 'keyframes' or 'auto' "
                     "(whenever the detection thread is free, never waited for; the default, but 1 with --moving-classes or "
                     "--dynamic-classes); boxes are carried in between");
  command.add_option("--max-box-age", options.max_box_age, "Frames a carried box lives after its detection (default 30)");
  command.add_option("--dnn-threads", options.dnn_threads,
                     "OpenCV threads while a detector is loaded (cv::setNumThreads; default 1); 0: OpenCV's default");
  command.add_option("--box-filter", options.box_filter,
                     "paper: ORB again inside each box (Algorithm 1); reuse: only the frame's own FAST corners its "
                     "quota dropped; label (the default): no keypoint added, the frame's own keypoints in a box take its class");
}

void applyDetectorOptions(const DetectorOptions& options, DetectorParams& params) {
  if (options.model) params.model = *options.model;
  if (options.cfg) params.cfg = *options.cfg;
  if (options.weights) params.weights = *options.weights;
  if (options.names) params.names = *options.names;
  if (options.input_size) params.input_size = *options.input_size;
  if (options.confidence) params.confidence_threshold = *options.confidence;
  if (options.nms) params.nms_threshold = *options.nms;
  if (options.min_box_px) params.min_box_px = *options.min_box_px;
  if (options.box_features) params.box_features = *options.box_features;
  if (options.dnn_target) params.dnn_target = *options.dnn_target;
  if (options.dynamic_classes) params.dynamic_classes = *options.dynamic_classes;
  if (options.moving_classes) params.moving_classes = *options.moving_classes;
  if (options.detect_every) {
    const std::optional<DetectEvery> every = parseDetectEvery(*options.detect_every);
    if (!every)
      throw InputError("--detect-every: expected a whole number >= 1, 'keyframes' or 'auto', not '" +
                       *options.detect_every + "'");
    params.detect_every = *every;
  }
  if (options.max_box_age) {
    if (*options.max_box_age < 0) throw InputError("--max-box-age: must be >= 0, not " + std::to_string(*options.max_box_age));
    params.max_box_age = *options.max_box_age;
  }
  if (options.dnn_threads) {
    if (*options.dnn_threads < 0) throw InputError("--dnn-threads: must be >= 0, not " + std::to_string(*options.dnn_threads));
    params.dnn_threads = *options.dnn_threads;
  }
  if (options.box_filter) {
    if (!isBoxFilter(*options.box_filter))
      throw InputError("--box-filter: expected 'paper', 'reuse' or 'label', not '" + *options.box_filter + "'");
    params.box_filter = *options.box_filter;
  }
}

}  // namespace vslam::app
