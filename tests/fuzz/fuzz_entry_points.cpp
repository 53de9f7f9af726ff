#include "fuzz_entry_points.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/darknet_weights.hpp"
#include "vslam/io/depth_png.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/io/sequence_files.hpp"
#include "vslam/io/text_table.hpp"
#include "vslam/io/timestamp_association.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/map_database.hpp"
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

// Far above any seed: larger inputs would only slow the runs down (SQLite's
// integrity check reads every page), whatever -max_len says.
constexpr std::size_t kMaxMapFileBytes = 1 << 20;

// The map reader takes a path (SQLite opens the file itself), so the input is
// written to a file named for this process (libFuzzer's -jobs and -fork run
// several) and removed afterwards, with any side file SQLite may have made.
class TemporaryMapFile {
 public:
  TemporaryMapFile(const std::uint8_t* data, std::size_t size)
      : path_((std::filesystem::temp_directory_path() / ("vslam_fuzz_map_" + std::to_string(::getpid()) + ".sqlite"))
                  .string()) {
    std::ofstream out(path_, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    out.close();
    if (!out) {
      removeFiles();
      throw std::runtime_error("cannot write the fuzz input to " + path_);  // the machine's fault, not the reader's
    }
  }
  ~TemporaryMapFile() { removeFiles(); }
  TemporaryMapFile(const TemporaryMapFile&) = delete;
  TemporaryMapFile& operator=(const TemporaryMapFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  void removeFiles() const {
    std::error_code ignored;
    for (const char* suffix : {"", "-journal", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix, ignored);
  }
  std::string path_;
};

// The camera of the map_file seeds (TUM freiburg1, with its distortion, so
// that the loader's image bounds come from undistorted corners as in a run).
PinholeCamera freiburg1Camera() {
  PinholeCamera camera;
  camera.name = "tum_fr1";
  camera.width = 640;
  camera.height = 480;
  camera.fx = 517.306408;
  camera.fy = 516.469215;
  camera.cx = 318.643040;
  camera.cy = 255.313989;
  camera.k1 = 0.262383;
  camera.k2 = -0.953104;
  camera.p1 = -0.005358;
  camera.p2 = 0.002628;
  camera.k3 = 1.163314;
  camera.bf = 40.0;
  return camera;
}

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
      {"depth_png", fuzzDepthPng},
      {"bundle_problem", fuzzBundleProblem},
      {"map_file", fuzzMapFile},
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

bool fuzzDepthPng(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    const cv::Mat image = decodeGray16Png(data, size, "depth.png");
    if (!image.empty() && image.type() != CV_16UC1) throw std::logic_error("decodeGray16Png: not CV_16UC1");
  });
}

bool fuzzBundleProblem(const std::uint8_t* data, std::size_t size) {
  return accepts([&] {
    std::istringstream in(bytesOf(data, size));
    loadBundleProblem(in, "problem.txt");
  });
}

bool fuzzMapFile(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxMapFileBytes) return false;
  const TemporaryMapFile file(data, size);
  return accepts([&] {
    // `vslam map info`: the header (after SQLite's integrity check), then the row counts.
    const MapFileHeader header = readMapHeader(file.path());
    readMapCounts(file.path());
    // `vslam run --load-map`: the check against the run, then the whole map. A
    // refusal by the check does not end the input here: the loader must read a
    // file made with any camera, mode or vocabulary just as safely.
    const PinholeCamera camera = freiburg1Camera();
    const ScalePyramid pyramid = makeScalePyramid(8, 1.2);
    MapIdentity required;
    required.mode = header.mode;  // the file's, so that the check goes on to compare the camera
    required.camera = camera;
    required.vocabulary_checksum = "ec2a24000922ae8b";  // the seeds' (vocab/orbvoc.bin)
    try {
      checkMapCompatible(file.path(), header, required);
    } catch (const InputError&) {
    }
    Map map;
    std::vector<ObjectLandmark> objects;
    std::vector<std::string> class_names;
    loadMapDatabase(file.path(), map, camera, pyramid, &objects, &class_names);
  });
}

}  // namespace vslam::fuzz
