#include "detector_options.hpp"

namespace vslam::app {

void addDetectorOptions(CLI::App& command, DetectorOptions& options) {
  command.add_option("--detector", options.model,
                     "Detector model: yolo-fastest-1.1-xl, yolo-fastest-1.1, yolov4, yolov4-tiny; 'none' turns detection "
                     "off (default: the config's detector.model, yolo-fastest-1.1-xl)");
  command.add_option("--detector-cfg", options.cfg, "Darknet cfg file (overrides the model's)");
  command.add_option("--detector-weights", options.weights, "Darknet weights file (overrides the model's)");
  command.add_option("--detector-names", options.names, "Class names file, one a line (overrides the model's)");
  command.add_option("--input-size", options.input_size, "Network input size in pixels, a multiple of 32 (320, 416, 608)");
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
}

}  // namespace vslam::app
