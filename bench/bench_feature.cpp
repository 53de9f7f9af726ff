// Feature module timings on a real fr1_xyz frame (640x480). Run with
//   build/bench/bench_feature --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <opencv2/features2d.hpp>

// The tests' data helpers; scratchDir (which needs the build directory) is not used here.
#ifndef VSLAM_BINARY_DIR
#define VSLAM_BINARY_DIR ""
#endif
#include "../tests/feature_test_support.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

const cv::Mat& frame(int index) {
  static const cv::Mat frames[2] = {test::tumGray("freiburg1_xyz", 0), test::tumGray("freiburg1_xyz", 1)};
  return frames[index];
}

void BM_OrbExtract(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    extractor.extract(extractor.buildPyramid(frame(0)), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_OrbExtract)->Unit(benchmark::kMillisecond);

void BM_OrbPyramid(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  for (auto _ : state) {
    ImagePyramid pyramid = extractor.buildPyramid(frame(0));
    benchmark::DoNotOptimize(pyramid.levels.back().data);
  }
}
BENCHMARK(BM_OrbPyramid)->Unit(benchmark::kMillisecond);

void BM_OrbExtractFromPyramid(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  const ImagePyramid pyramid = extractor.buildPyramid(frame(0));
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    extractor.extract(pyramid, keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
}
BENCHMARK(BM_OrbExtractFromPyramid)->Unit(benchmark::kMillisecond);

// A 160x200 detection box, 150 features, reusing the frame's pyramid.
void BM_OrbExtractRoi(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  const ImagePyramid pyramid = extractor.buildPyramid(frame(0));
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    extractor.extract(pyramid, keypoints, descriptors, cv::Rect(200, 150, 160, 200), 150);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_OrbExtractRoi)->Unit(benchmark::kMillisecond);

void BM_CvOrbExtract(benchmark::State& state) {
  cv::setNumThreads(1);  // compare single-threaded, like ours
  auto orb = cv::ORB::create(1000, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    orb->detectAndCompute(frame(0), cv::noArray(), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_CvOrbExtract)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
