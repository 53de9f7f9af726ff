#include "vslam/io/sequence.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <regex>
#include <stdexcept>

#include <spdlog/spdlog.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/io/depth_png.hpp"
#include "vslam/io/image_files.hpp"
#include "vslam/io/sequence_catalog.hpp"
#include "vslam/io/sequence_files.hpp"
#include "vslam/io/text_table.hpp"
#include "vslam/io/timestamp_association.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

// The benchmark's associate.py default: colour and depth closer than this pair up.
constexpr double kDepthPairingMaxDifference = 0.02;

bool startsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

std::vector<std::uint8_t> readFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open image file");
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string absoluteFolder(const fs::path& path) { return fs::weakly_canonical(fs::absolute(path)).string(); }

std::vector<ListedImage> readImageList(const fs::path& list_path, const fs::path& root) {
  const std::string file = list_path.string();
  return parseTumImageList(readTextRows(file), file, root.string());
}

void readTumFolder(Sequence& sequence) {
  const fs::path root = sequence.root;
  const fs::path rgb_list = root / "rgb.txt";
  if (!fs::exists(rgb_list)) throw InputError(rgb_list.string(), 0, "missing (a TUM sequence folder needs rgb.txt)");
  const std::vector<ListedImage> colour = readImageList(rgb_list, root);
  for (size_t i = 0; i < colour.size(); ++i) {
    FrameEntry frame;
    frame.index = static_cast<int>(i);
    frame.timestamp = colour[i].timestamp;
    frame.image_path = colour[i].path;
    frame.list_line = colour[i].line;
    sequence.frames.push_back(frame);
  }

  // Depth is optional: a monocular run needs none.
  const fs::path depth_list = root / "depth.txt";
  if (fs::exists(depth_list)) {
    const std::vector<ListedImage> depth = readImageList(depth_list, root);
    std::vector<double> colour_times, depth_times;
    for (const ListedImage& image : colour) colour_times.push_back(image.timestamp);
    for (const ListedImage& image : depth) depth_times.push_back(image.timestamp);
    for (const auto& [c, d] : associateTimestamps(colour_times, depth_times, kDepthPairingMaxDifference))
      sequence.frames[c].depth_path = depth[d].path;
    const int unpaired = static_cast<int>(sequence.frames.size()) - sequence.framesWithDepth();
    if (unpaired > 0)
      spdlog::warn("{}: {} of {} colour frames have no depth image within {} s", depth_list.string(), unpaired,
                   sequence.frames.size(), kDepthPairingMaxDifference);
  }

  const fs::path groundtruth = root / "groundtruth.txt";
  if (fs::exists(groundtruth)) {
    sequence.groundtruth_path = groundtruth.string();
    sequence.groundtruth = readTumTrajectory(sequence.groundtruth_path);
  }
}

// The intrinsics of calib.txt (P0 = left grey camera) override the config's.
void readKittiCalibration(const fs::path& calib_path, PinholeCamera& camera) {
  const std::string file = calib_path.string();
  if (!fs::exists(calib_path)) throw InputError(file, 0, "missing (a KITTI sequence folder needs calib.txt with P0)");
  parseKittiCalibration(readTextRows(file), file, camera);
}

void readKittiFolder(Sequence& sequence, const fs::path& poses_path) {
  const fs::path root = sequence.root;
  const fs::path times_path = root / "times.txt";
  const std::string times_file = times_path.string();
  if (!fs::exists(times_path)) throw InputError(times_file, 0, "missing (a KITTI sequence folder needs times.txt)");
  const std::vector<double> times = parseKittiTimes(readTextRows(times_file), times_file);

  const fs::path image_dir = root / "image_0";
  if (!fs::is_directory(image_dir))
    throw InputError(image_dir.string(), 0, "missing (a KITTI sequence folder needs the left grey images in image_0/)");
  // Images are NNNNNN.png (official) or .jpg (re-encoded copies); one extension per sequence.
  static const std::regex kImageName(R"(\d{6}\.(png|jpg|jpeg))");
  std::string extension;
  size_t image_count = 0;
  for (const auto& entry : fs::directory_iterator(image_dir)) {
    const std::string file_name = entry.path().filename().string();
    if (!std::regex_match(file_name, kImageName)) continue;
    ++image_count;
    if (file_name.rfind("000000.", 0) == 0) extension = entry.path().extension().string();
  }
  if (extension.empty()) throw InputError(image_dir.string(), 0, "has no first image 000000.png or 000000.jpg");
  if (image_count != times.size())
    throw InputError(times_file, 0,
                     "lists " + std::to_string(times.size()) + " timestamps but " + image_dir.string() + " holds " +
                         std::to_string(image_count) + " images");
  for (size_t i = 0; i < times.size(); ++i) {
    char file_name[32];
    std::snprintf(file_name, sizeof(file_name), "%06zu", i);
    FrameEntry frame;
    frame.index = static_cast<int>(i);
    frame.timestamp = times[i];
    frame.image_path = (image_dir / (file_name + extension)).string();
    sequence.frames.push_back(frame);
  }

  readKittiCalibration(root / "calib.txt", sequence.config.camera);

  if (!poses_path.empty() && fs::exists(poses_path)) {
    sequence.groundtruth_path = absoluteFolder(poses_path);
    sequence.groundtruth = readKittiTrajectory(sequence.groundtruth_path, times);
  }
}

Config loadCameraConfig(const SequenceOptions& options, const std::string& camera, const std::string& folder) {
  if (!options.config_path.empty()) return loadConfig(options.config_path);
  if (camera.empty())
    throw InputError(folder, 0,
                     "cannot tell the camera from the folder name; pass --config FILE (e.g. config/tum_fr1.yaml "
                     "or an ORB-SLAM2 settings file)");
  return loadConfig(projectConfigDir() + "/" + camera + ".yaml");
}

std::string joined(const std::vector<std::string>& items, const std::string& separator) {
  std::string text;
  for (size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

std::string listOfTumNames() {
  std::vector<std::string> names;
  for (const char* n : {"fr1_xyz", "fr1_desk", "fr2_xyz", "fr3_long_office_household", "fr3_teddy"})
    names.push_back(std::string("tum/") + n);
  return joined(names, ", ");
}

struct Located {
  fs::path folder;
  SequenceKind kind = SequenceKind::Tum;
  std::string camera;  // config/<camera>.yaml, "" if unknown
  fs::path kitti_poses;
  int frames_expected = 0;  // the catalogue's count for a named sequence, 0 = unknown
};

Located locateTum(const std::string& spec, const SequenceOptions& options) {
  const std::string short_name = spec.substr(4);
  const std::optional<TumSequenceInfo> info = findTumSequence(short_name);
  if (!info)
    throw InputError(spec, 0,
                     "unknown TUM RGB-D sequence; valid names are tum/fr1_..., tum/fr2_..., tum/fr3_... as on the "
                     "benchmark's page, e.g. " +
                         listOfTumNames() + " (tools/fetch_dataset.sh --list prints all)");
  std::vector<std::string> looked;
  for (const std::string& root : dataSearchRoots(options)) {
    for (const fs::path& candidate :
         {fs::path(root) / "tum" / info->archive_name, fs::path(root) / info->archive_name}) {
      looked.push_back(candidate.string());
      if (fs::is_directory(candidate)) return {candidate, SequenceKind::Tum, info->camera, {}, info->frames};
    }
  }
  const std::string how_to_get = "Fetch it with 'tools/fetch_dataset.sh tum/" + info->short_name +
                                 "' (needs internet), or download " + tumArchiveUrl(*info) +
                                 " by hand and unpack it into " + fetchDataRoot(options) + "/tum/";
  throw SequenceNotFound(spec, 0, "sequence not found; looked in " + joined(looked, ", ") + ". " + how_to_get);
}

Located locateKitti(const std::string& spec, const SequenceOptions& options) {
  const std::string number_text = spec.substr(6);
  static const std::regex kNumber(R"(\d{1,2})");
  if (!std::regex_match(number_text, kNumber) || std::stoi(number_text) >= kKittiSequenceCount)
    throw InputError(spec, 0, "unknown KITTI odometry sequence; valid names are kitti/00 ... kitti/21");
  const int number = std::stoi(number_text);
  char nn[8];
  std::snprintf(nn, sizeof(nn), "%02d", number);
  std::vector<std::string> looked;
  for (const std::string& root : dataSearchRoots(options)) {
    const fs::path candidate = fs::path(root) / "kitti" / "sequences" / nn;
    looked.push_back(candidate.string());
    if (fs::is_directory(candidate))
      return {candidate, SequenceKind::Kitti, kittiCameraFor(number),
              fs::path(root) / "kitti" / "poses" / (std::string(nn) + ".txt"), kittiFrameCount(number)};
  }
  throw SequenceNotFound(spec, 0,
                         "sequence not found; looked in " + joined(looked, ", ") +
                             ". KITTI odometry needs registration at cvlibs.net: download the grey images and "
                             "poses and unpack them so that " +
                             fetchDataRoot(options) + "/kitti/sequences/" + nn + "/image_0/ and " +
                             fetchDataRoot(options) + "/kitti/poses/" + nn + ".txt exist");
}

// The Bonn RGB-D Dynamic dataset (Palazzolo et al., IROS 2019): TUM layout,
// its own camera (config/bonn.yaml), one zip per sequence on the dataset's
// page. No frame counts are catalogued, so a partial copy is not flagged.
constexpr const char* kBonnPrefix = "rgbd_bonn_";
constexpr const char* kBonnUrl = "https://www.ipb.uni-bonn.de/html/projects/rgbd_dynamic2019/";

Located locateBonn(const std::string& spec, const SequenceOptions& options) {
  const std::string short_name = spec.substr(5);
  static const std::regex kName(R"([a-z0-9_]+)");
  if (!std::regex_match(short_name, kName))
    throw InputError(spec, 0,
                     "not a Bonn RGB-D Dynamic sequence name; names are as on the dataset's page without "
                     "'rgbd_bonn_', e.g. bonn/crowd, bonn/balloon, bonn/person_tracking");
  const std::string folder_name = kBonnPrefix + short_name;
  std::vector<std::string> looked;
  for (const std::string& root : dataSearchRoots(options)) {
    for (const fs::path& candidate : {fs::path(root) / "bonn" / folder_name, fs::path(root) / folder_name}) {
      looked.push_back(candidate.string());
      if (fs::is_directory(candidate)) return {candidate, SequenceKind::Tum, "bonn", {}, 0};
    }
  }
  throw SequenceNotFound(spec, 0,
                         "sequence not found; looked in " + joined(looked, ", ") + ". Download " + kBonnUrl +
                             folder_name + ".zip and unpack it into " + fetchDataRoot(options) + "/bonn/");
}

Located locateFolder(const std::string& spec) {
  const fs::path folder = spec;
  fs::path normalized = fs::absolute(folder).lexically_normal();
  if (normalized.filename().empty()) normalized = normalized.parent_path();  // "dir/" -> "dir"
  const std::string folder_name = normalized.filename().string();
  static const std::regex kTumName(R"(rgbd_dataset_freiburg([123])_.+)");
  static const std::regex kKittiName(R"(\d{2})");
  std::smatch match;
  const bool tum_named = std::regex_match(folder_name, match, kTumName);
  std::string tum_camera = tum_named ? "tum_fr" + match[1].str() : "";
  if (startsWith(folder_name, kBonnPrefix)) tum_camera = "bonn";

  if (tum_named || fs::exists(folder / "rgb.txt")) return {folder, SequenceKind::Tum, tum_camera, {}};
  if (fs::is_directory(folder / "image_0") && fs::exists(folder / "times.txt")) {
    Located located{folder, SequenceKind::Kitti, "", {}};
    // Standard odometry layout: <root>/sequences/NN beside <root>/poses/NN.txt.
    if (std::regex_match(folder_name, kKittiName)) {
      located.camera = kittiCameraFor(std::stoi(folder_name));
      located.kitti_poses = normalized.parent_path().parent_path() / "poses" / (folder_name + ".txt");
    }
    return located;
  }
  throw InputError((folder / "rgb.txt").string(), 0,
                   "missing: the folder is neither in TUM layout (rgb.txt) nor in KITTI layout (image_0/ and "
                   "times.txt)");
}

}  // namespace

std::vector<std::string> dataSearchRoots(const SequenceOptions& options) {
  std::vector<std::string> roots;
  if (!options.data_root.empty()) roots.push_back(options.data_root);
  if (const char* env = std::getenv("VSLAM_DATA"); env && *env) roots.push_back(env);
  roots.push_back("./data");
  roots.push_back("../shared/data");
  return roots;
}

std::string fetchDataRoot(const SequenceOptions& options) {
  if (!options.data_root.empty()) return options.data_root;
  if (const char* env = std::getenv("VSLAM_DATA"); env && *env) return env;
  return "./data";
}

double pathLength(const std::vector<StampedPose>& poses) {
  double length = 0.0;
  for (size_t i = 1; i < poses.size(); ++i) length += (poses[i].T_wc.t - poses[i - 1].T_wc.t).norm();
  return length;
}

Sequence openSequence(const std::string& spec, const SequenceOptions& options) {
  if (spec.empty()) throw InputError("--seq: empty sequence name (tum/<name>, kitti/<NN>, bonn/<name> or a folder)");
  Located located;
  if (fs::is_directory(spec)) {
    located = locateFolder(spec);
  } else if (startsWith(spec, "tum/")) {
    located = locateTum(spec, options);
  } else if (startsWith(spec, "kitti/")) {
    located = locateKitti(spec, options);
  } else if (startsWith(spec, "bonn/")) {
    located = locateBonn(spec, options);
  } else if (fs::exists(spec)) {
    throw InputError(spec, 0, "is a file, not a sequence folder");
  } else {
    throw InputError(spec, 0,
                     "no such folder, and not a sequence name (tum/<name> such as tum/fr1_xyz, kitti/<NN>, or "
                     "bonn/<name> such as bonn/crowd)");
  }

  Sequence sequence;
  sequence.name = spec;
  sequence.root = absoluteFolder(located.folder);
  sequence.kind = located.kind;
  sequence.frames_expected = located.frames_expected;
  sequence.config = loadCameraConfig(options, located.camera, sequence.root);
  if (located.kind == SequenceKind::Tum)
    readTumFolder(sequence);
  else
    readKittiFolder(sequence, located.kitti_poses);
  // Scored as the camera's poses from here on: by the run's report, its
  // groundtruth.txt, the plots and the tests alike.
  if (const std::optional<SE3>& camera_in_body = sequence.config.evaluation.groundtruth_camera_in_body)
    for (StampedPose& pose : sequence.groundtruth) pose.T_wc = pose.T_wc * *camera_in_body;

  // A KITTI sequence's own files define its camera: calib.txt the intrinsics
  // (read above), the images their size (sequences 13-21 have no camera file of their own).
  if (located.kind == SequenceKind::Kitti && options.config_path.empty())
    sequence.config.camera.width = sequence.config.camera.height = 0;

  // ORB-SLAM2 settings files carry no image size: take it from the first image.
  PinholeCamera& camera = sequence.config.camera;
  if (camera.width <= 0 || camera.height <= 0) {
    camera.width = camera.height = 0;  // so the size check in loadColor stays quiet
    const cv::Mat first = sequence.loadGray(0);
    camera.width = first.cols;
    camera.height = first.rows;
  }
  return sequence;
}

bool Sequence::hasDepth() const { return !frames.empty() && framesWithDepth() == static_cast<int>(frames.size()); }

int Sequence::framesWithDepth() const {
  return static_cast<int>(
      std::count_if(frames.begin(), frames.end(), [](const FrameEntry& f) { return !f.depth_path.empty(); }));
}

cv::Mat Sequence::readImage(const std::string& path, int imread_flags, int list_line, const char* what,
                            const std::string& size_of) const {
  const std::string listed_at =
      list_line > 0 ? " (listed at " + (fs::path(root) / what).string() + ":" + std::to_string(list_line) + ")" : "";
  if (!fs::exists(path)) throw FrameUnreadable(path, 0, "image file does not exist" + listed_at);
  const std::string truncation = imageTruncation(path);
  if (!truncation.empty()) throw FrameUnreadable(path, 0, truncation + listed_at);
  cv::Mat image;
  try {
    if (imread_flags == cv::IMREAD_UNCHANGED) {
      // Depth: 16-bit greyscale PNGs are decoded by libdeflate (depth_png.hpp),
      // anything else by OpenCV.
      const std::vector<std::uint8_t> bytes = readFileBytes(path);
      image = decodeGray16Png(bytes.data(), bytes.size(), path);
      if (image.empty()) image = cv::imdecode(bytes, imread_flags);
    } else {
      image = cv::imread(path, imread_flags);
    }
  } catch (const InputError& e) {
    throw FrameUnreadable(e.what() + listed_at);
  } catch (const cv::Exception& e) {
    throw FrameUnreadable(path, 0, "cannot decode image: " + e.msg + listed_at);
  }
  if (image.empty()) throw FrameUnreadable(path, 0, "cannot decode image (not a readable PNG or JPEG)" + listed_at);
  if (!size_of.empty()) return image;  // the caller compares it with that image
  const PinholeCamera& camera = config.camera;
  if (camera.width > 0 && camera.height > 0 && (image.cols != camera.width || image.rows != camera.height))
    throw InputError(path, 0,
                     "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + " but camera '" +
                         camera.name + "' of " + (config.source.empty() ? "the config" : config.source) + " is " +
                         std::to_string(camera.width) + "x" + std::to_string(camera.height));
  return image;
}

void Sequence::checkFilesPresent(size_t begin, size_t end, bool with_depth) const {
  auto check = [&](const std::string& path, int list_line, const char* list) {
    const std::string listed_at =
        list_line > 0 ? " (listed at " + (fs::path(root) / list).string() + ":" + std::to_string(list_line) + ")" : "";
    std::error_code error;
    const auto size = fs::file_size(path, error);
    if (error) throw InputError(path, 0, "image file does not exist" + listed_at);
    if (size == 0) throw InputError(path, 0, "image file is empty" + listed_at);
  };
  for (size_t i = begin; i < std::min(end, frames.size()); ++i) {
    check(frames[i].image_path, frames[i].list_line, kind == SequenceKind::Tum ? "rgb.txt" : "");
    if (with_depth && !frames[i].depth_path.empty()) check(frames[i].depth_path, 0, "depth.txt");
  }
}

cv::Mat Sequence::loadColor(size_t i) const {
  const FrameEntry& frame = frames.at(i);
  cv::Mat image = readImage(frame.image_path, cv::IMREAD_COLOR, frame.list_line, "rgb.txt");
  return image;  // IMREAD_COLOR already expands grey images to 3 channels
}

cv::Mat Sequence::loadGray(size_t i) const {
  const FrameEntry& frame = frames.at(i);
  return readImage(frame.image_path, cv::IMREAD_GRAYSCALE, frame.list_line, "rgb.txt");
}

cv::Mat Sequence::loadDepthMeters(size_t i, const cv::Size& colour_size) const {
  const FrameEntry& frame = frames.at(i);
  if (frame.depth_path.empty())
    throw InputError(
        (fs::path(root) / "depth.txt").string(), 0,
        "no depth image within 0.02 s of colour frame " + std::to_string(i) + " (" + frame.image_path + ")");
  const cv::Mat raw = readImage(frame.depth_path, cv::IMREAD_UNCHANGED, 0, "depth.txt", frame.image_path);
  if (raw.size() != colour_size)
    throw InputError(frame.depth_path, 0,
                     "depth image is " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) +
                         " but its colour image " + frame.image_path + " is " + std::to_string(colour_size.width) +
                         "x" + std::to_string(colour_size.height) +
                         ": depth must be registered to the colour image, pixel for pixel");
  if (raw.type() != CV_16UC1) throw InputError(frame.depth_path, 0, "depth image is not a single-channel 16-bit PNG");
  if (config.camera.depth_factor <= 0)
    throw InputError(config.source, 0, "camera.depth_factor must be positive to read depth images");
  cv::Mat metres;
  raw.convertTo(metres, CV_32F, 1.0 / config.camera.depth_factor);
  return metres;
}

}  // namespace vslam
