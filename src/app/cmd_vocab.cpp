// `vslam vocab build`: trains a place-recognition vocabulary on images.
// `vslam vocab info`: describes a vocabulary file (ours or DBoW2 text).
// `vslam vocab convert`: rewrites one in the other format.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/feature/orb_extractor.hpp"
#include "vslam/io/image_files.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam::app {
namespace {

namespace fs = std::filesystem;

struct BuildOptions {
  std::vector<std::string> inputs;
  std::string out;
  VocabularyParams params;
  int max_images = 0;  // 0: all
  int features = Config{}.orb.n_features;
};

// At most `max_images`, spread evenly over the list (first one included).
std::vector<fs::path> evenlySpaced(const std::vector<fs::path>& images, int max_images) {
  if (max_images <= 0 || images.size() <= static_cast<size_t>(max_images)) return images;
  std::vector<fs::path> chosen;
  for (size_t i = 0; i < static_cast<size_t>(max_images); ++i) chosen.push_back(images[i * images.size() / max_images]);
  return chosen;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int runBuild(const BuildOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  // Folders are searched recursively; TUM's depth/ folders hold 16-bit depth
  // maps beside rgb/, not photographs.
  const ImageListOptions training_images{/*recursive=*/true, /*skipped_folders=*/{"depth"}};
  const std::vector<fs::path> images = evenlySpaced(listImages(options.inputs, training_images), options.max_images);

  OrbParams orb = Config{}.orb;
  orb.n_features = options.features;
  const OrbExtractor extractor(orb);
  std::vector<cv::Mat> descriptors;
  descriptors.reserve(images.size());
  size_t descriptor_count = 0;
  int last_percent = -1;
  for (size_t i = 0; i < images.size(); ++i) {
    const cv::Mat gray = cv::imread(images[i].string(), cv::IMREAD_GRAYSCALE);
    if (gray.empty()) throw InputError(images[i].string(), 0, "cannot read image");
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat image_descriptors;
    extractor.extract(gray, keypoints, image_descriptors);
    descriptor_count += static_cast<size_t>(image_descriptors.rows);
    descriptors.push_back(image_descriptors);
    const int percent = static_cast<int>(100 * (i + 1) / images.size());
    if (percent / 10 != last_percent / 10) {
      spdlog::info("vocab: ORB features of {}/{} images ({} descriptors)", i + 1, images.size(), descriptor_count);
      last_percent = percent;
    }
  }
  const double extraction_seconds = secondsSince(start);

  const auto training_start = std::chrono::steady_clock::now();
  const std::clock_t training_cpu_start = std::clock();  // wall time is misleading on a busy machine
  spdlog::info("vocab: training k={} L={} seed={} on {} descriptors", options.params.branching, options.params.depth,
               options.params.seed, descriptor_count);
  last_percent = -1;
  const Vocabulary vocabulary = Vocabulary::train(descriptors, options.params, [&](double fraction) {
    const int percent = static_cast<int>(fraction * 100);
    if (percent / 5 != last_percent / 5) {
      spdlog::info("vocab: training {:3d}% ({:.0f} s)", percent, secondsSince(training_start));
      last_percent = percent;
    }
  });
  const double training_seconds = secondsSince(training_start);
  const double training_cpu_seconds = static_cast<double>(std::clock() - training_cpu_start) / CLOCKS_PER_SEC;

  const fs::path out(options.out);
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  vocabulary.save(options.out);
  const auto bytes = fs::file_size(out);

  std::printf("images: %zu\n", images.size());
  std::printf("descriptors: %zu\n", descriptor_count);
  std::printf("params: k=%d L=%d seed=%u kmeans_iterations=%d features=%d\n", options.params.branching,
              options.params.depth, options.params.seed, options.params.max_kmeans_iterations, options.features);
  std::printf("words: %zu\n", vocabulary.wordCount());
  std::printf("nodes: %zu\n", vocabulary.nodeCount());
  std::printf("file: %s (%ju bytes, %.2f MB)\n", options.out.c_str(), static_cast<uintmax_t>(bytes), bytes / 1e6);
  std::printf("seconds: %.1f (features %.1f, training %.1f; training CPU %.1f)\n", secondsSince(start),
              extraction_seconds, training_seconds, training_cpu_seconds);
  return 0;
}

int runInfo(const std::string& path) {
  const Vocabulary vocabulary = Vocabulary::load(path);
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, sizeof(magic));
  const bool binary = std::string(magic, sizeof(magic)) == "VSLAMVOC";
  std::printf("file: %s (%ju bytes)\n", path.c_str(), static_cast<uintmax_t>(fs::file_size(path)));
  std::printf("format: %s\n", binary ? "vslam binary" : "DBoW2 text");
  std::printf("branching: %d\ndepth: %d\n", vocabulary.branching(), vocabulary.depth());
  if (binary)
    std::printf("seed: %u\nkmeans_iterations: %d\n", vocabulary.params().seed, vocabulary.params().max_kmeans_iterations);
  std::printf("nodes: %zu\nwords: %zu\n", vocabulary.nodeCount(), vocabulary.wordCount());
  return 0;
}

int runConvert(const std::string& in, const std::string& out, const std::string& format) {
  const auto start = std::chrono::steady_clock::now();
  const Vocabulary vocabulary = Vocabulary::load(in);
  const double load_seconds = secondsSince(start);
  const fs::path out_path(out);
  if (out_path.has_parent_path()) fs::create_directories(out_path.parent_path());
  if (format == "dbow2-text")
    vocabulary.saveDbow2Text(out);
  else
    vocabulary.save(out);
  std::printf("words: %zu\n", vocabulary.wordCount());
  std::printf("file: %s (%s, %ju bytes)\n", out.c_str(), format.c_str(), static_cast<uintmax_t>(fs::file_size(out)));
  std::printf("seconds: %.1f (load %.1f)\n", secondsSince(start), load_seconds);
  return 0;
}

}  // namespace

Command addVocabCommand(CLI::App& app) {
  Command command;
  CLI::App* vocab = app.add_subcommand("vocab", "Build or inspect a place-recognition vocabulary");
  vocab->require_subcommand(1);
  command.cli = vocab;

  auto options = std::make_shared<BuildOptions>();
  CLI::App* build = vocab->add_subcommand(
      "build", "Train a vocabulary on images (png/jpg, searched recursively, depth/ folders skipped)");
  build->add_option("--images", options->inputs, "Image directories or files")->required();
  build->add_option("--out", options->out, "Output file (vslam binary form)")->required();
  build->add_option("--branching", options->params.branching, "Children per node (k)")
      ->check(CLI::Range(2, 65535))
      ->capture_default_str();
  build->add_option("--depth", options->params.depth, "Levels below the root (L)")
      ->check(CLI::Range(1, 32))
      ->capture_default_str();
  build->add_option("--seed", options->params.seed, "Random seed: the same images and seed give the same file")
      ->capture_default_str();
  build->add_option("--iterations", options->params.max_kmeans_iterations, "k-means iterations per node")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  build->add_option("--max-images", options->max_images, "Use at most N images, evenly spaced (0: all)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  build->add_option("--features", options->features, "ORB features per image")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();

  auto info_path = std::make_shared<std::string>();
  CLI::App* info = vocab->add_subcommand("info", "Describe a vocabulary file (vslam binary or DBoW2 text)");
  info->add_option("path", *info_path, "Vocabulary file")->required();

  struct ConvertOptions {
    std::string in, out, format = "binary";
  };
  auto convert_options = std::make_shared<ConvertOptions>();
  CLI::App* convert = vocab->add_subcommand(
      "convert", "Rewrite a vocabulary: DBoW2 text (ORBvoc.txt) to our binary form, which loads much faster, or back");
  convert->add_option("in", convert_options->in, "Vocabulary file (vslam binary or DBoW2 text)")->required();
  convert->add_option("out", convert_options->out, "Output file")->required();
  convert->add_option("--format", convert_options->format, "Output format")
      ->check(CLI::IsMember({"binary", "dbow2-text"}))
      ->capture_default_str();

  command.run = [build, info, convert, options, info_path, convert_options] {
    if (build->parsed()) return runBuild(*options);
    if (info->parsed()) return runInfo(*info_path);
    if (convert->parsed()) return runConvert(convert_options->in, convert_options->out, convert_options->format);
    return 2;
  };
  return command;
}

}  // namespace vslam::app
