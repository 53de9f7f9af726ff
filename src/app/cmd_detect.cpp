// `vslam detect`: run the object detector on photos or frames and write the
// detections as JSON plus one PNG per image with boxes and labels.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.hpp"
#include "detector_options.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/darknet_weights.hpp"
#include "vslam/detect/detector.hpp"
#include "vslam/detect/keypoint_filter.hpp"
#include "vslam/detect/model_locator.hpp"
#include "vslam/io/image_files.hpp"

namespace vslam::app {
namespace {

namespace fs = std::filesystem;

struct DetectArgs {
  std::vector<std::string> inputs;
  std::string out_dir;
  bool filter_keypoints = false;
  std::string placeholder_weights;
  DetectorOptions detector;
};

std::string defaultOutDir() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::ostringstream name;
  name << "runs/detect-" << std::put_time(&utc, "%Y%m%d-%H%M%S");
  return name.str();
}

// A distinct, stable colour per class: hues spread by a step coprime with 180.
cv::Scalar classColour(int class_id) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar((class_id * 47) % 180, 220, 230)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return cv::Scalar(c[0], c[1], c[2]);
}

void drawDetections(cv::Mat& image, const std::vector<Detection>& detections) {
  const int thickness = std::max(2, image.cols / 400);
  const double font_scale = std::max(0.5, image.cols / 1200.0);
  // Lowest confidence first, so the most confident labels end on top.
  for (auto it = detections.rbegin(); it != detections.rend(); ++it) {
    const cv::Scalar colour = classColour(it->class_id);
    const cv::Rect box(it->box);
    cv::rectangle(image, box, colour, thickness);
    std::ostringstream text;
    text << it->class_name << ' ' << std::fixed << std::setprecision(2) << it->confidence;
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text.str(), cv::FONT_HERSHEY_SIMPLEX, font_scale, 1, &baseline);
    // Label above the box, or inside it when the box touches the top edge.
    const int top = box.y - size.height - baseline - 2 >= 0 ? box.y - size.height - baseline - 2 : std::max(box.y, 0);
    const cv::Rect label(std::max(box.x, 0), top, size.width + 4, size.height + baseline + 2);
    cv::rectangle(image, label, colour, cv::FILLED);
    cv::putText(image, text.str(), cv::Point(label.x + 2, label.y + size.height + 1), cv::FONT_HERSHEY_SIMPLEX,
                font_scale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
}

// ORB on the whole image, then the keypoint filter on its detections; draws
// the frame's keypoints in green and those the filter added in red.
KeypointFilterStats filterKeypoints(const DetectorParams& params, const std::vector<int>& dynamic_class_ids,
                                    const std::vector<Detection>& detections, cv::Mat& image, int& frame_keypoints) {
  const OrbParams orb;  // the paper's defaults: 1000 features, 8 levels, scale 1.2
  const OrbExtractor extractor(orb);
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  const ImagePyramid pyramid = extractor.buildPyramid(gray);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(pyramid, keypoints, descriptors);
  frame_keypoints = static_cast<int>(keypoints.size());
  std::vector<KeypointLabel> labels;
  const KeypointFilterStats stats =
      applyKeypointFilter(image.size(), detections, params.min_box_px, dynamic_class_ids,
                          orbBoxExtractor(extractor, pyramid, featuresPerBox(params, orb)), keypoints, descriptors, labels);
  // Added keypoints follow the frame's survivors, so the last keypoints_added ones are new.
  const size_t first_added = keypoints.size() - static_cast<size_t>(stats.keypoints_added);
  for (size_t i = 0; i < keypoints.size(); ++i)
    cv::circle(image, keypoints[i].pt, 2, i < first_added ? cv::Scalar(0, 200, 0) : cv::Scalar(0, 0, 255), 1,
               cv::LINE_AA);
  return stats;
}

// Weights of the right size for a model whose trained weights are not at
// hand (YOLOv4's cannot be had on every machine): timing runs only.
int writePlaceholder(const DetectorParams& params, const std::string& weights_path) {
  std::error_code error;
  if (fs::exists(weights_path, error))
    throw InputError(weights_path, 0, "already exists; placeholder weights are not written over a file");
  const std::string cfg = locateModelCfg(params);
  writePlaceholderWeights(cfg, weights_path);
  std::cout << "wrote " << weights_path << ": " << fs::file_size(weights_path) << " bytes of placeholder weights for "
            << cfg << " (random numbers: for timing only, they detect nothing)\n";
  return 0;
}

int runDetect(const DetectArgs& args) {
  DetectorParams params;
  applyDetectorOptions(args.detector, params);
  if (params.model == "none") throw InputError("vslam detect: --detector none leaves nothing to do; name a model");
  if (!args.placeholder_weights.empty()) return writePlaceholder(params, args.placeholder_weights);
  if (args.inputs.empty()) throw InputError("vslam detect: --images is required (or --placeholder-weights)");
  const std::vector<fs::path> images = listImages(args.inputs);  // folders: not recursive
  const ModelFiles files = locateModel(params);
  YoloDetector detector(params, files);
  const std::vector<int> dynamic_class_ids = classIdsOf(params.dynamic_classes, detector.classNames(), files.names);

  const fs::path out_dir = args.out_dir.empty() ? defaultOutDir() : args.out_dir;
  std::error_code error;
  fs::create_directories(out_dir, error);
  if (error) throw InputError(out_dir.string(), 0, "cannot create output folder: " + error.message());

  nlohmann::json report;
  report["model"] = files.name;
  report["cfg"] = files.cfg;
  report["weights"] = files.weights;
  report["input_size"] = detector.inputSize().width;  // the network's input; input_height beside it
  report["input_height"] = detector.inputSize().height;
  report["placeholder_weights"] = detector.placeholderWeights();
  report["confidence_threshold"] = params.confidence_threshold;
  report["nms_threshold"] = params.nms_threshold;
  report["dnn_target"] = params.dnn_target;
  report["images"] = nlohmann::json::array();

  std::set<std::string> used_names;
  std::vector<double> times_ms, cpu_ms, added_keypoints;
  size_t total_detections = 0;
  for (const fs::path& path : images) {
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw InputError(path.string(), 0, "cannot read image");
    const std::clock_t cpu_start = std::clock();
    const std::vector<Detection> detections = detector.detect(image);
    // CPU time of all threads: a figure that other processes on a busy machine inflate less than wall time.
    cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
    times_ms.push_back(detector.lastMs());
    total_detections += detections.size();

    nlohmann::json entry;
    entry["file"] = path.string();
    entry["width"] = image.cols;
    entry["height"] = image.rows;
    entry["ms"] = detector.lastMs();
    entry["detections"] = nlohmann::json::array();
    std::ostringstream summary;
    for (const Detection& d : detections) {
      entry["detections"].push_back({{"class", d.class_name},
                                     {"class_id", d.class_id},
                                     {"confidence", d.confidence},
                                     {"box", {d.box.x, d.box.y, d.box.width, d.box.height}}});
      summary << (summary.tellp() > 0 ? ", " : "") << d.class_name << ' ' << std::fixed << std::setprecision(2)
              << d.confidence;
    }

    // Same-named inputs from different folders get _2, _3, ... rather than overwrite each other.
    std::string name = path.stem().string() + "_det";
    for (int n = 2; used_names.count(name); ++n) name = path.stem().string() + "_det_" + std::to_string(n);
    used_names.insert(name);
    if (args.filter_keypoints) {
      int frame_keypoints = 0;
      const KeypointFilterStats stats = filterKeypoints(params, dynamic_class_ids, detections, image, frame_keypoints);
      entry["keypoint_filter"] = {{"frame_keypoints", frame_keypoints},
                                  {"boxes_used", stats.boxes_used},
                                  {"boxes_skipped_small", stats.boxes_skipped_small},
                                  {"keypoints_added", stats.keypoints_added},
                                  {"duplicates_dropped", stats.duplicates_dropped},
                                  {"keypoints_removed_dynamic", stats.keypoints_removed_dynamic}};
      added_keypoints.push_back(stats.keypoints_added);
      summary << (summary.tellp() > 0 ? "; " : "") << "keypoints " << frame_keypoints << " + " << stats.keypoints_added
              << " added in " << stats.boxes_used << " boxes";
      if (stats.keypoints_removed_dynamic > 0) summary << ", " << stats.keypoints_removed_dynamic << " removed";
    }
    drawDetections(image, detections);
    const fs::path png = out_dir / (name + ".png");
    if (!cv::imwrite(png.string(), image)) throw InputError(png.string(), 0, "cannot write image");
    entry["output"] = png.string();
    report["images"].push_back(entry);

    std::cout << path.filename().string() << ": " << detections.size() << " detections in " << std::fixed
              << std::setprecision(1) << detector.lastMs() << " ms" << (detections.empty() ? "" : " (")
              << summary.str() << (detections.empty() ? "" : ")") << "\n";
  }

  const fs::path json_path = out_dir / "detections.json";
  std::ofstream(json_path) << report.dump(2) << "\n";
  if (!fs::exists(json_path)) throw InputError(json_path.string(), 0, "cannot write detections");

  auto median = [](std::vector<double> values) {
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
  };
  const cv::Size input = detector.inputSize();
  std::cout << images.size() << " images, " << total_detections << " detections, " << files.name << " at "
            << input.width << "x" << input.height << " px: median " << std::fixed << std::setprecision(1)
            << median(times_ms)
            << " ms per image (CPU " << median(cpu_ms) << " ms; first image " << times_ms.front() << " ms); wrote "
            << json_path.string() << " and " << images.size() << " PNGs\n";
  if (args.filter_keypoints)
    std::cout << "keypoint filter: median " << median(added_keypoints) << " keypoints added per image (min "
              << *std::min_element(added_keypoints.begin(), added_keypoints.end()) << ", max "
              << *std::max_element(added_keypoints.begin(), added_keypoints.end()) << ")\n";
  return 0;
}

}  // namespace

Command addDetectCommand(CLI::App& app) {
  auto args = std::make_shared<DetectArgs>();
  Command command;
  command.cli = app.add_subcommand("detect", "Run the object detector on images; write detections.json and annotated PNGs");
  command.cli->add_option("--images", args->inputs, "Images or folders of images (required unless --placeholder-weights)")
      ->expected(1, -1);
  command.cli->add_option("--out", args->out_dir, "Output folder (default runs/detect-<UTC time>)");
  command.cli->add_flag("--filter-keypoints", args->filter_keypoints,
                        "Also run ORB and the keypoint filter (paper's Algorithm 1): counts in the JSON, "
                        "frame keypoints green and added ones red in the PNGs");
  command.cli->add_option("--placeholder-weights", args->placeholder_weights,
                          "Write a weights file of the size the model's cfg implies, filled with small random "
                          "numbers, to this path and exit (for timing a model whose weights are not at hand: it "
                          "detects nothing)");
  addDetectorOptions(*command.cli, args->detector);
  command.run = [args] { return runDetect(*args); };
  return command;
}

}  // namespace vslam::app
