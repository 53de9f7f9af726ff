// Image decoding on the loader thread: one fr1_xyz depth PNG (640x480, 16-bit)
// through OpenCV's libpng path and through decodeGray16Png (libdeflate). Run with
//   build/bench/bench_io --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <cstdint>
#include <fstream>
#include <iterator>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#ifndef VSLAM_BINARY_DIR
#define VSLAM_BINARY_DIR ""
#endif
#include "../tests/test_support.hpp"
#include "vslam/io/depth_png.hpp"

namespace vslam {
namespace {

// The first depth image of fr1_xyz, as bytes in memory (file reading is not timed).
const std::vector<std::uint8_t>& depthPngBytes() {
  static const std::vector<std::uint8_t> bytes = [] {
    cv::setNumThreads(1);
    std::ifstream in(test::tumSequence("freiburg1_xyz") / "depth" / "1305031102.160407.png", std::ios::binary);
    return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }();
  return bytes;
}

void BM_DepthPngOpenCv(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(cv::imdecode(depthPngBytes(), cv::IMREAD_UNCHANGED).data);
}
BENCHMARK(BM_DepthPngOpenCv)->Unit(benchmark::kMillisecond);

void BM_DepthPngLibdeflate(benchmark::State& state) {
  const std::vector<std::uint8_t>& bytes = depthPngBytes();
  for (auto _ : state) benchmark::DoNotOptimize(decodeGray16Png(bytes.data(), bytes.size(), "depth.png").data);
}
BENCHMARK(BM_DepthPngLibdeflate)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
