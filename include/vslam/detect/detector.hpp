#pragma once
// YOLO object detection through OpenCV DNN's Darknet importer.
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "vslam/core/config.hpp"
#include "vslam/detect/model_locator.hpp"

namespace vslam {

struct Detection {
  int id = -1;             // index in this frame's detections (sorted by confidence, highest first)
  int class_id = -1;
  std::string class_name;
  float confidence = 0.f;  // objectness x class probability
  cv::Rect2f box;          // pixels of the input image, not clipped to it
};

class YoloDetector {
 public:
  // Checks the weights file's size against the cfg, loads the network and
  // the class names, and selects the backend from params.dnn_target
  // ("cpu", "opencl", "cuda"). The network runs at params.input_size square,
  // or, when that is 0, at the cfg's [net] width and height, as Darknet does.
  // Throws InputError for a bad file, an input size that is not a multiple of
  // 32, a names file whose line count differs from the cfg's classes, or a
  // target this OpenCV build lacks.
  YoloDetector(const DetectorParams& params, const ModelFiles& files);

  // Detections at or above params.confidence_threshold after per-class NMS.
  // Takes 8-bit BGR; grey and BGRA images are converted first.
  std::vector<Detection> detect(const cv::Mat& bgr);

  const std::vector<std::string>& classNames() const { return class_names_; }
  double lastMs() const { return last_ms_; }  // wall time of the last detect()
  const ModelFiles& files() const { return files_; }
  const DetectorParams& params() const { return params_; }
  cv::Size inputSize() const { return input_size_; }  // the network's input, width by height
  // The weights' header says they have seen no training image: placeholder
  // weights (vslam detect --placeholder-weights), whose boxes mean nothing.
  bool placeholderWeights() const { return placeholder_weights_; }

  // Raw network outputs of the last detect() (one matrix per YOLO head), for tests.
  const std::vector<cv::Mat>& lastOutputs() const { return outputs_; }

 private:
  DetectorParams params_;
  ModelFiles files_;
  cv::Size input_size_;
  bool placeholder_weights_ = false;
  cv::dnn::Net net_;
  std::vector<std::string> output_names_;
  std::vector<std::string> class_names_;
  std::vector<cv::Mat> outputs_;
  double last_ms_ = 0.0;
};

// Class names, one a line (blank trailing lines ignored). Throws InputError naming the file.
std::vector<std::string> readClassNames(const std::string& names_path);

// Ids of `wanted` class names in `class_names`; throws InputError naming
// `names_path` and the unknown class (e.g. a typo in --dynamic-classes).
// COCO's classes of things that move by themselves or are moved (people,
// animals, vehicles), as darknet's coco.names spells them.
const std::vector<std::string>& cocoMovableClasses();

// `wanted` may hold "coco-movable", which stands for those of
// cocoMovableClasses() the names file has.
std::vector<int> classIdsOf(const std::vector<std::string>& wanted, const std::vector<std::string>& class_names,
                            const std::string& names_path);

// Intersection over union of two boxes (0 when either is empty).
float iou(const cv::Rect2f& a, const cv::Rect2f& b);

}  // namespace vslam
