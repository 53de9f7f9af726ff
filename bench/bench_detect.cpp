// Detection time per frame and the keypoint filter's yield on the
// freiburg3_long_office_household frames in ../shared (or $VSLAM_SHARED).
//   build/bench/bench_detect --benchmark_repetitions=5
#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/detect/detector.hpp"
#include "vslam/detect/keypoint_filter.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace {

namespace fs = std::filesystem;

std::vector<cv::Mat> fr3Frames() {
  const char* env = std::getenv("VSLAM_SHARED");
  const fs::path shared = env ? fs::path(env) : fs::path(VSLAM_SOURCE_DIR).parent_path() / "shared";
  const fs::path rgb = shared / "data/tum/rgbd_dataset_freiburg3_long_office_household/rgb";
  std::vector<fs::path> paths;
  for (const auto& entry : fs::directory_iterator(rgb)) paths.push_back(entry.path());
  std::sort(paths.begin(), paths.end());
  std::vector<cv::Mat> frames;
  for (const fs::path& path : paths) frames.push_back(cv::imread(path.string()));
  return frames;
}

// Yolo-Fastest-1.1-XL, the default model, at the input size given as argument.
void BM_DetectFr3(benchmark::State& state) {
  vslam::DetectorParams params;
  params.input_size = static_cast<int>(state.range(0));
  vslam::YoloDetector detector(params, vslam::locateModel(params));
  const std::vector<cv::Mat> frames = fr3Frames();
  detector.detect(frames[0]);  // the first forward pass allocates; keep it out
  size_t next = 0, detections = 0;
  for (auto _ : state) {
    detections += detector.detect(frames[next]).size();
    next = (next + 1) % frames.size();
  }
  state.counters["detections_per_frame"] =
      benchmark::Counter(static_cast<double>(detections), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_DetectFr3)->Arg(320)->Arg(416)->Unit(benchmark::kMillisecond)->MinTime(2.0);

// ORB on the whole frame plus Algorithm 1 on its detections (found beforehand,
// at 320 and confidence 0.4); the argument is the features asked for per box
// (1000 = the frame's n_features, the default).
void BM_KeypointFilterFr3(benchmark::State& state) {
  vslam::DetectorParams params;
  vslam::YoloDetector detector(params, vslam::locateModel(params));
  const std::vector<cv::Mat> frames = fr3Frames();
  std::vector<cv::Mat> grays(frames.size());
  std::vector<std::vector<vslam::Detection>> detections;
  for (size_t i = 0; i < frames.size(); ++i) {
    cv::cvtColor(frames[i], grays[i], cv::COLOR_BGR2GRAY);
    detections.push_back(detector.detect(frames[i]));
  }
  const vslam::OrbExtractor extractor{vslam::OrbParams{}};
  const int per_box = static_cast<int>(state.range(0));
  size_t next = 0;
  double frame_keypoints = 0, added = 0, boxes = 0, duplicates = 0;
  for (auto _ : state) {
    const vslam::ImagePyramid pyramid = extractor.buildPyramid(grays[next]);
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    extractor.extract(pyramid, keypoints, descriptors);
    frame_keypoints += static_cast<double>(keypoints.size());
    std::vector<vslam::KeypointLabel> labels;
    const auto stats = vslam::applyKeypointFilter(grays[next].size(), detections[next], params.min_box_px, {},
                                                  vslam::orbBoxExtractor(extractor, pyramid, per_box), keypoints,
                                                  descriptors, labels);
    added += stats.keypoints_added;
    boxes += stats.boxes_used;
    duplicates += stats.duplicates_dropped;
    next = (next + 1) % frames.size();
  }
  state.counters["frame_keypoints"] = benchmark::Counter(frame_keypoints, benchmark::Counter::kAvgIterations);
  state.counters["added_per_frame"] = benchmark::Counter(added, benchmark::Counter::kAvgIterations);
  state.counters["boxes_used_per_frame"] = benchmark::Counter(boxes, benchmark::Counter::kAvgIterations);
  state.counters["duplicates_per_frame"] = benchmark::Counter(duplicates, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_KeypointFilterFr3)->Arg(1000)->Arg(200)->Unit(benchmark::kMillisecond)->Iterations(32);

}  // namespace
