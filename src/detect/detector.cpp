#include "vslam/detect/detector.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "vslam/core/error.hpp"
#include "vslam/detect/darknet_weights.hpp"

namespace vslam {
namespace {

bool hasTarget(cv::dnn::Backend backend, cv::dnn::Target target) {
  for (const auto& [available_backend, available_target] : cv::dnn::getAvailableBackends())
    if (available_backend == backend && available_target == target) return true;
  return false;
}

void selectTarget(cv::dnn::Net& net, const std::string& target) {
  if (target == "cpu") {
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  } else if (target == "opencl") {
    const auto targets = cv::dnn::getAvailableTargets(cv::dnn::DNN_BACKEND_OPENCV);
    if (std::find(targets.begin(), targets.end(), cv::dnn::DNN_TARGET_OPENCL) == targets.end())
      throw InputError("--dnn-target opencl: this OpenCV build has no OpenCL target (or no OpenCL device); use --dnn-target cpu");
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_OPENCL);
  } else if (target == "cuda") {
    if (!hasTarget(cv::dnn::DNN_BACKEND_CUDA, cv::dnn::DNN_TARGET_CUDA))
      throw InputError("--dnn-target cuda: this OpenCV build has no CUDA backend; use --dnn-target cpu");
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_CUDA);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CUDA);
  } else {
    throw InputError("--dnn-target " + target + ": unknown target (expected cpu, opencl or cuda)");
  }
}

}  // namespace

std::vector<std::string> readClassNames(const std::string& names_path) {
  std::ifstream in(names_path);
  if (!in) throw InputError(names_path, 0, "cannot open class names file");
  std::vector<std::string> names;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    names.push_back(line);
  }
  while (!names.empty() && names.back().empty()) names.pop_back();
  if (names.empty()) throw InputError(names_path, 0, "class names file is empty");
  return names;
}

const std::vector<std::string>& cocoMovableClasses() {
  static const std::vector<std::string> classes = {"person", "bicycle", "car",   "motorbike", "aeroplane",
                                                   "bus",    "train",   "truck", "boat",      "bird",
                                                   "cat",    "dog",     "horse", "sheep",     "cow",
                                                   "elephant", "bear",  "zebra", "giraffe"};
  return classes;
}

std::vector<int> classIdsOf(const std::vector<std::string>& wanted, const std::vector<std::string>& class_names,
                            const std::string& names_path) {
  std::vector<int> ids;
  for (const std::string& name : wanted) {
    if (name == "coco-movable") {
      for (const std::string& movable : cocoMovableClasses()) {
        const auto it = std::find(class_names.begin(), class_names.end(), movable);
        if (it != class_names.end()) ids.push_back(static_cast<int>(it - class_names.begin()));
      }
      continue;
    }
    const auto it = std::find(class_names.begin(), class_names.end(), name);
    if (it == class_names.end())
      throw InputError(names_path, 0, "has no class '" + name + "' (check --dynamic-classes and --moving-classes)");
    ids.push_back(static_cast<int>(it - class_names.begin()));
  }
  return ids;
}

float iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const float overlap = (a & b).area();
  const float united = a.area() + b.area() - overlap;
  return united > 0.f ? overlap / united : 0.f;
}

YoloDetector::YoloDetector(const DetectorParams& params, const ModelFiles& files) : params_(params), files_(files) {
  if (params_.input_size < 0 || params_.input_size % 32 != 0)
    throw InputError("detector input size " + std::to_string(params_.input_size) +
                     " must be a positive multiple of 32 (e.g. 320, 416, 608)");
  if (params_.confidence_threshold < 0 || params_.confidence_threshold > 1 || params_.nms_threshold < 0 ||
      params_.nms_threshold > 1)
    throw InputError("detector confidence and NMS thresholds must lie in [0, 1]");

  const DarknetNetwork network = parseDarknetCfg(files_.cfg);
  // No size given: the cfg's, as Darknet itself runs a model.
  if (params_.input_size > 0) {
    input_size_ = cv::Size(params_.input_size, params_.input_size);
  } else {
    if (network.width <= 0 || network.height <= 0 || network.width % 32 != 0 || network.height % 32 != 0)
      throw InputError(files_.cfg, 0,
                       "[net] width " + std::to_string(network.width) + " and height " +
                           std::to_string(network.height) +
                           " must be positive multiples of 32 (or give --input-size)");
    input_size_ = cv::Size(network.width, network.height);
  }
  // Placeholder weights load and run like trained ones; say so, since their
  // boxes mean nothing.
  placeholder_weights_ = checkWeightsFile(network, files_.weights).seen == 0;
  if (placeholder_weights_)
    spdlog::warn("{}: these weights have seen no training image (placeholder weights, as `vslam detect "
                 "--placeholder-weights` writes): good for timing only, their detections mean nothing",
                 files_.weights);
  class_names_ = readClassNames(files_.names);
  if (network.classes > 0 && static_cast<int>(class_names_.size()) != network.classes)
    throw InputError(files_.names, 0,
                     "has " + std::to_string(class_names_.size()) + " class names but " + files_.cfg + " has " +
                         std::to_string(network.classes) + " classes");

  try {
    net_ = cv::dnn::readNetFromDarknet(files_.cfg, files_.weights);
  } catch (const cv::Exception& e) {
    throw InputError(files_.cfg, 0, "OpenCV cannot load this Darknet model: " + e.msg);
  }
  selectTarget(net_, params_.dnn_target);
  output_names_ = net_.getUnconnectedOutLayersNames();
}

std::vector<Detection> YoloDetector::detect(const cv::Mat& bgr) {
  const auto start = std::chrono::steady_clock::now();
  CV_Assert(!bgr.empty() && bgr.depth() == CV_8U);
  // Grey sequences (KITTI's image_0) go through the colour network as grey BGR.
  cv::Mat colour = bgr;
  if (bgr.channels() == 1) cv::cvtColor(bgr, colour, cv::COLOR_GRAY2BGR);
  if (bgr.channels() == 4) cv::cvtColor(bgr, colour, cv::COLOR_BGRA2BGR);
  const cv::Mat blob =
      cv::dnn::blobFromImage(colour, 1.0 / 255.0, input_size_, cv::Scalar(), /*swapRB=*/true, /*crop=*/false);
  net_.setInput(blob);
  net_.forward(outputs_, output_names_);

  // Each output row: centre x, centre y, width, height (fractions of the
  // image), objectness, then one score per class (already times objectness).
  std::map<int, std::vector<cv::Rect2d>> boxes_by_class;
  std::map<int, std::vector<float>> scores_by_class;
  const float width = static_cast<float>(bgr.cols), height = static_cast<float>(bgr.rows);
  for (const cv::Mat& output : outputs_) {
    for (int row = 0; row < output.rows; ++row) {
      const float* values = output.ptr<float>(row);
      const cv::Mat scores = output.row(row).colRange(5, output.cols);
      cv::Point best;
      double best_score = 0.0;
      cv::minMaxLoc(scores, nullptr, &best_score, nullptr, &best);
      if (best_score < params_.confidence_threshold) continue;
      const float w = values[2] * width, h = values[3] * height;
      boxes_by_class[best.x].emplace_back(values[0] * width - w / 2, values[1] * height - h / 2, w, h);
      scores_by_class[best.x].push_back(static_cast<float>(best_score));
    }
  }

  std::vector<Detection> detections;
  for (const auto& [class_id, boxes] : boxes_by_class) {
    const std::vector<float>& scores = scores_by_class[class_id];
    std::vector<int> kept;
    cv::dnn::NMSBoxes(boxes, scores, static_cast<float>(params_.confidence_threshold),
                      static_cast<float>(params_.nms_threshold), kept);
    for (int index : kept) {
      Detection detection;
      detection.class_id = class_id;
      detection.class_name = class_id < static_cast<int>(class_names_.size()) ? class_names_[class_id]
                                                                              : "class" + std::to_string(class_id);
      detection.confidence = scores[index];
      detection.box = cv::Rect2f(boxes[index]);
      detections.push_back(detection);
    }
  }
  std::sort(detections.begin(), detections.end(),
            [](const Detection& a, const Detection& b) { return a.confidence > b.confidence; });
  for (size_t i = 0; i < detections.size(); ++i) detections[i].id = static_cast<int>(i);

  last_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return detections;
}

}  // namespace vslam
