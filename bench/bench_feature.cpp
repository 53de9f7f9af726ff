// Feature module timings on a real fr1_xyz frame (640x480). Run with
//   build/bench/bench_feature --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <opencv2/features2d.hpp>

// The tests' data helpers; scratchDir (which needs the build directory) is not used here.
#ifndef VSLAM_BINARY_DIR
#define VSLAM_BINARY_DIR ""
#endif
#include "../tests/feature_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/feature/matcher.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

// Frames 0 and 1 of fr1_xyz. Loading them also pins OpenCV to one thread, so
// every figure here is single-threaded (OpenCV would otherwise parallelise
// resize and blur, and CPU time would include the thread hand-offs).
const cv::Mat& frame(int index) {
  static const cv::Mat frames[2] = {(cv::setNumThreads(1), test::tumGray("freiburg1_xyz", 0)),
                                    test::tumGray("freiburg1_xyz", 1)};
  return frames[index];
}

void BM_OrbExtract(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(extractor.buildPyramid(frame(0)), keypoints, descriptors);  // load and warm up outside the timing
  for (auto _ : state) {
    extractor.extract(extractor.buildPyramid(frame(0)), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_OrbExtract)->Unit(benchmark::kMillisecond);

void BM_OrbPyramid(benchmark::State& state) {
  const OrbExtractor extractor{OrbParams()};
  frame(0);
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
  auto orb = cv::ORB::create(1000, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  frame(0);
  for (auto _ : state) {
    orb->detectAndCompute(frame(0), cv::noArray(), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
  state.counters["keypoints"] = static_cast<double>(keypoints.size());
}
BENCHMARK(BM_CvOrbExtract)->Unit(benchmark::kMillisecond);

// Frames 0 and 1 of fr1_xyz extracted and undistorted once, as Tracking holds them.
struct BenchFrame {
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Point2f> points;
  cv::Mat descriptors;
  FeatureGrid grid;
  FeatureView view() const { return FeatureView{keypoints, points, descriptors}; }
};

const BenchFrame& benchFrame(int index) {
  static const std::vector<BenchFrame> frames = [] {
    const PinholeCamera camera = loadConfig(projectConfigDir() + "/tum_fr1.yaml").camera;
    const OrbExtractor extractor{OrbParams()};
    std::vector<BenchFrame> out(2);
    for (int i = 0; i < 2; ++i) {
      extractor.extract(frame(i), out[i].keypoints, out[i].descriptors);
      std::vector<cv::Point2f> raw;
      std::vector<int> levels;
      for (const cv::KeyPoint& kp : out[i].keypoints) raw.push_back(kp.pt), levels.push_back(kp.octave);
      out[i].points = camera.undistort(raw);
      out[i].grid = FeatureGrid(out[i].points, levels, undistortedImageBounds(camera));
    }
    return out;
  }();
  return frames[index];
}

void BM_MatchInWindow(benchmark::State& state) {
  const BenchFrame &f1 = benchFrame(0), &f2 = benchFrame(1);
  int matches = 0;
  for (auto _ : state) {
    std::vector<cv::Point2f> prev = f1.points;
    matches = matchInWindow(f1.view(), f2.view(), f2.grid, prev).count;
    benchmark::DoNotOptimize(matches);
  }
  state.counters["matches"] = matches;
}
BENCHMARK(BM_MatchInWindow)->Unit(benchmark::kMillisecond);

void BM_FeatureGridBuild(benchmark::State& state) {
  const BenchFrame& f = benchFrame(0);
  std::vector<int> levels;
  for (const cv::KeyPoint& kp : f.keypoints) levels.push_back(kp.octave);
  for (auto _ : state) {
    FeatureGrid grid(f.points, levels, cv::Rect2f(0, 0, 640, 480));
    benchmark::DoNotOptimize(grid);
  }
}
BENCHMARK(BM_FeatureGridBuild)->Unit(benchmark::kMicrosecond);

// One query per feature, radius 15 px at the feature's own position: what a
// search by projection does for each map point.
void BM_FeatureGridQuery1000(benchmark::State& state) {
  const BenchFrame& f = benchFrame(0);
  std::size_t found = 0;
  for (auto _ : state) {
    for (const cv::Point2f& p : f.points) found += f.grid.featuresInArea(p.x, p.y, 15.f).size();
    benchmark::DoNotOptimize(found);
  }
}
BENCHMARK(BM_FeatureGridQuery1000)->Unit(benchmark::kMicrosecond);

void BM_Hamming1M(benchmark::State& state) {
  const BenchFrame &f1 = benchFrame(0), &f2 = benchFrame(1);
  long long total = 0;
  for (auto _ : state) {
    for (int i = 0; i < f1.descriptors.rows; ++i)
      for (int j = 0; j < f2.descriptors.rows; ++j)
        total += hammingDistance(f1.descriptors.ptr<std::uint8_t>(i), f2.descriptors.ptr<std::uint8_t>(j));
    benchmark::DoNotOptimize(total);
  }
}
BENCHMARK(BM_Hamming1M)->Unit(benchmark::kMillisecond);

void BM_MatchByRatio1000(benchmark::State& state) {
  const BenchFrame &f1 = benchFrame(0), &f2 = benchFrame(1);
  for (auto _ : state) benchmark::DoNotOptimize(matchByRatio(f1.descriptors, f2.descriptors, 0.8f, kHammingThresholdLow));
}
BENCHMARK(BM_MatchByRatio1000)->Unit(benchmark::kMillisecond);

void BM_SearchForTriangulation(benchmark::State& state) {
  const BenchFrame &f1 = benchFrame(0), &f2 = benchFrame(1);
  // Any plausible F: a small sideways motion.
  const PinholeCamera camera = loadConfig(projectConfigDir() + "/tum_fr1.yaml").camera;
  const cv::Matx33d F21 = fundamentalFromPoses(SE3(), SE3(Mat3::Identity(), Vec3(-0.02, 0, 0)), camera.Keigen(), camera.Keigen());
  const std::vector<double> sigma2 = OrbExtractor(OrbParams()).levelSigma2();
  std::size_t pairs = 0;
  for (auto _ : state) {
    pairs = searchForTriangulation(f1.view(), f2.view(), F21, sigma2).size();
    benchmark::DoNotOptimize(pairs);
  }
  state.counters["pairs"] = static_cast<double>(pairs);
}
BENCHMARK(BM_SearchForTriangulation)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
