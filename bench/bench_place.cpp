// Place recognition speed: a keyframe's bag of words (target: <= 3 ms for
// 1000 descriptors) and a keyframe-database query.
//
//   build/bench/bench_place                       # trains k=10 L=5 on 60 fr3_teddy frames first (~10 s)
//   VSLAM_BENCH_VOCAB=vocab/orbvoc.bin build/bench/bench_place   # or any saved/DBoW2 text vocabulary
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>

#include "vslam/core/config.hpp"
#include "vslam/feature/orb_extractor.hpp"
#include "vslam/place/keyframe_database.hpp"
#include "vslam/place/vocabulary.hpp"

namespace {

using namespace vslam;

std::filesystem::path teddyDir() {
  const char* shared = std::getenv("VSLAM_SHARED");
  const std::filesystem::path root =
      shared ? std::filesystem::path(shared) : std::filesystem::path(VSLAM_SOURCE_DIR).parent_path() / "shared";
  return root / "data/tum/rgbd_dataset_freiburg3_teddy";
}

std::vector<cv::Mat> teddyDescriptors(int first, int step, int count) {
  std::ifstream list(teddyDir() / "rgb.txt");
  if (!list) throw std::runtime_error("missing " + (teddyDir() / "rgb.txt").string());
  std::vector<std::string> frames;
  for (std::string line; std::getline(list, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    fields >> stamp >> path;
    frames.push_back((teddyDir() / path).string());
  }
  const OrbExtractor extractor(Config{}.orb);
  std::vector<cv::Mat> descriptors;
  for (int i = 0; i < count; ++i) {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat d;
    extractor.extract(cv::imread(frames.at(first + i * step), cv::IMREAD_GRAYSCALE), keypoints, d);
    descriptors.push_back(d);
  }
  return descriptors;
}

struct BenchData {
  Vocabulary vocabulary;
  std::vector<cv::Mat> keyframes = teddyDescriptors(1, 5, 40);  // odd frames: not in the training set
  BenchData() {
    if (const char* path = std::getenv("VSLAM_BENCH_VOCAB"))
      vocabulary = Vocabulary::load(path);
    else
      vocabulary = Vocabulary::train(teddyDescriptors(0, 2, 60), VocabularyParams{10, 5, 42, 10});
  }
};

const BenchData& data() {
  static const BenchData instance;  // trained once for all benchmarks in this process
  return instance;
}

void BM_KeyframeToBagOfWords(benchmark::State& state) {
  const BenchData& d = data();
  const cv::Mat& keyframe = d.keyframes[20];
  BowVector bow;
  FeatureVector features;
  for (auto _ : state) {
    d.vocabulary.transform(keyframe, bow, features, 4);
    benchmark::DoNotOptimize(bow);
  }
  state.counters["descriptors"] = keyframe.rows;
  state.counters["words"] = static_cast<double>(d.vocabulary.wordCount());
  state.counters["k"] = d.vocabulary.branching();
  state.counters["L"] = d.vocabulary.depth();
}
BENCHMARK(BM_KeyframeToBagOfWords)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

void BM_KeyframeDatabaseQuery(benchmark::State& state) {
  const BenchData& d = data();
  std::vector<BowVector> bows;
  for (const cv::Mat& keyframe : d.keyframes) bows.push_back(d.vocabulary.transform(keyframe));
  KeyframeDatabase database;
  const long keyframe_count = state.range(0);
  for (long id = 0; id < keyframe_count; ++id) database.add(id, bows[id % bows.size()]);
  for (auto _ : state) benchmark::DoNotOptimize(database.query(bows[7], 0.0, {}, 10));
  state.counters["keyframes"] = static_cast<double>(keyframe_count);
}
BENCHMARK(BM_KeyframeDatabaseQuery)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace
