#include "fuzz_entry_points.hpp"

#include <sstream>
#include <stdexcept>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/darknet_weights.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/io/sequence_files.hpp"
#include "vslam/io/text_table.hpp"
#include "vslam/io/timestamp_association.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam::fuzz {
namespace {

std::string bytesOf(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Runs `read`; an InputError is a rejected input, every other exception escapes.
template <typename Read>
bool accepts(Read&& read) {
  try {
    read();
    return true;
  } catch (const InputError&) {
    return false;
  }
}

std::vector<TextRow> rowsOf(const std::string& text, const std::string& name) {
  std::istringstream in(text);
  return readTextRows(in, name);
}

// A two-convolution network of 124 + 10 parameters (536 bytes), for the weights header target.
constexpr const char* kSmallCfg =
    "[net]\nwidth=32\nheight=32\nchannels=3\n"
    "[convolutional]\nbatch_normalize=1\nfilters=4\nsize=3\n"
    "[convolutional]\nfilters=2\nsize=1\n";

}  // namespace

const std::vector<FuzzTarget>& fuzzTargets() {
  static const std::vector<FuzzTarget> kTargets = {
      {"tum_list", fuzzTumList},
      {"tum_trajectory", fuzzTumTrajectory},
      {"kitti_poses", fuzzKittiPoses},
      {"kitti_times", fuzzKittiTimes},
      {"kitti_calib", fuzzKittiCalib},
      {"config", fuzzConfig},
      {"vocabulary", fuzzVocabulary},
      {"darknet_cfg", fuzzDarknetCfg},
      {"darknet_weights", fuzzDarknetWeights},
      {"ply", fuzzPly},
      {"bundle_problem", fuzzBundleProblem},
  };
  return kTargets;
}

bool fuzzTumList(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    const std::string text = bytesOf(data, size);
    const size_t split = text.find('\f');
    const std::vector<ListedImage> colour = parseTumImageList(rowsOf(text.substr(0, split), "rgb.txt"), "rgb.txt", "/seq");
    if (split == std::string::npos) return;
    const std::vector<ListedImage> depth =
        parseTumImageList(rowsOf(text.substr(split + 1), "depth.txt"), "depth.txt", "/seq");
    std::vector<double> colour_times, depth_times;
    for (const ListedImage& image : colour) colour_times.push_back(image.timestamp);
    for (const ListedImage& image : depth) depth_times.push_back(image.timestamp);
    for (const auto& [c, d] : associateTimestamps(colour_times, depth_times, 0.02)) {
      if (c < 0 || static_cast<size_t>(c) >= colour.size() || d < 0 || static_cast<size_t>(d) >= depth.size())
        throw std::logic_error("associateTimestamps: pair out of range");
    }
  });
}

bool fuzzTumTrajectory(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size));
    readTumTrajectory(in, "groundtruth.txt");
  });
}

bool fuzzKittiPoses(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size));
    readKittiTrajectory(in, "poses.txt");
  });
}

bool fuzzKittiTimes(const std::uint8_t* data, std::size_t size) {
  return accepts([&] { parseKittiTimes(rowsOf(bytesOf(data, size), "times.txt"), "times.txt"); });
}

bool fuzzKittiCalib(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    PinholeCamera camera;
    parseKittiCalibration(rowsOf(bytesOf(data, size), "calib.txt"), "calib.txt", camera);
  });
}

bool fuzzConfig(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    const Config config = parseConfig(bytesOf(data, size), "config.yaml");
    requireDepthCamera(config);
  });
}

bool fuzzVocabulary(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    const Vocabulary vocabulary = Vocabulary::parse(bytesOf(data, size), "vocabulary");
    // Descend the loaded tree: its indices must hold whatever the file said.
    cv::Mat descriptors(4, 32, CV_8U);
    for (int r = 0; r < descriptors.rows; ++r)
      for (int c = 0; c < descriptors.cols; ++c) descriptors.at<uint8_t>(r, c) = static_cast<uint8_t>(r * 85 + c * 7);
    BowVector bow;
    FeatureVector features;
    vocabulary.transform(descriptors, bow, features, 2);
    for (const auto& [word, value] : bow) {
      if (word >= vocabulary.wordCount()) throw std::logic_error("Vocabulary::transform: word out of range");
      (void)value;
    }
  });
}

bool fuzzDarknetCfg(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size));
    const DarknetNetwork network = parseDarknetCfg(in, "net.cfg");
    DarknetWeightsHeader header;  // version 0.2: 20-byte header
    checkWeightsSize(network, header, expectedWeightsBytes(network, header), "net.weights");
  });
}

bool fuzzDarknetWeights(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream cfg(kSmallCfg);
    const DarknetNetwork network = parseDarknetCfg(cfg, "small.cfg");
    std::istringstream in(bytesOf(data, size));
    const DarknetWeightsHeader header = readDarknetWeightsHeader(in, "net.weights");
    checkWeightsSize(network, header, static_cast<std::int64_t>(size), "net.weights");
  });
}

bool fuzzPly(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size), std::ios::in | std::ios::binary);
    readMapPly(in, "map.ply");
  });
}

bool fuzzBundleProblem(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size));
    loadBundleProblem(in, "problem.txt");
  });
}

}  // namespace vslam::fuzz
