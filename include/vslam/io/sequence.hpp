#pragma once
// A recorded image sequence: the TUM RGB-D or KITTI odometry layout on disk,
// read into a list of frames, its camera configuration and its ground truth.
//
// A sequence is named "tum/<short name>" (tum/fr1_xyz, tum/fr3_long_office_household, ...),
// "kitti/<NN>" (kitti/00), or given as a folder path in TUM layout (rgb.txt,
// optional depth.txt and groundtruth.txt) or KITTI layout (image_0/, times.txt,
// calib.txt). Named sequences are looked for, in order, under --data-root,
// $VSLAM_DATA, ./data and ../shared/data (relative to the working directory).
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

enum class SequenceKind { Tum, Kitti };

struct FrameEntry {
  int index = 0;           // 0-based position in the sequence
  double timestamp = 0.0;  // seconds
  std::string image_path;  // absolute path of the colour / grey image
  std::string depth_path;  // absolute path of the paired depth image, "" if none
  int list_line = 0;       // line of rgb.txt naming the image (TUM), 0 for KITTI; for error messages
};

struct SequenceOptions {
  std::string data_root;    // --data-root ("" = not given)
  std::string config_path;  // --config ("" = from the sequence name)
};

class Sequence {
 public:
  std::string name;  // "tum/fr1_xyz", "kitti/00", or the folder path given
  std::string root;  // absolute folder of the sequence
  SequenceKind kind = SequenceKind::Tum;
  Config config;  // camera + pipeline parameters (from config/<camera>.yaml or --config)
  std::vector<FrameEntry> frames;
  // T_wc of the camera; KITTI: one per frame, timestamp = times.txt. Where the
  // file gives another body's pose, config.evaluation.groundtruth_camera_in_body
  // has taken it to the camera.
  std::vector<StampedPose> groundtruth;
  std::string groundtruth_path;          // "" when the sequence has none
  // Frames the catalogue knows the named sequence to have (tum/..., kitti/NN),
  // 0 when unknown (a folder given by path, or a count not in the catalogue).
  int frames_expected = 0;

  bool hasGroundTruth() const { return !groundtruth.empty(); }
  bool hasDepth() const;  // every frame has a depth image
  int framesWithDepth() const;

  // Throws InputError naming the first colour image (and, with_depth, paired
  // depth image) of frames [begin, end) that is missing or empty, and the list
  // line naming it: checked before a run starts, so that it fails before any work.
  void checkFilesPresent(size_t begin, size_t end, bool with_depth) const;

  // Images are decoded on demand; each throws InputError naming the image file
  // (and the rgb.txt line that lists it) when it is missing, unreadable, or of
  // another size than the camera's: FrameUnreadable when the file itself is
  // bad (missing, undecodable, truncated), which a run skips as one bad frame.
  cv::Mat loadColor(size_t i) const;        // CV_8UC3 BGR (grey images converted)
  cv::Mat loadGray(size_t i) const;         // CV_8UC1
  // CV_32F metres (0 = no measurement); the file must be 16-bit and of the size
  // of frame i's colour image (`colour_size`), else the error names both files.
  cv::Mat loadDepthMeters(size_t i, const cv::Size& colour_size) const;

 private:
  // `size_of` non-empty: the image's size is checked by the caller against
  // that file's, not here against the camera's.
  cv::Mat readImage(const std::string& path, int imread_flags, int list_line, const char* what,
                    const std::string& size_of = "") const;
};

// One image file that cannot be read: missing, undecodable or truncated.
class FrameUnreadable : public InputError {
 public:
  using InputError::InputError;
};

// Thrown by openSequence when a named sequence is in none of the data roots.
// `vslam run` catches it to offer fetching; the message alone is complete.
class SequenceNotFound : public InputError {
 public:
  using InputError::InputError;
};

// Resolves a spec ("tum/fr1_xyz", "kitti/00", or a folder), finds it (search order above), reads its index files.
// Throws SequenceNotFound when a named sequence is not found (the message lists where it looked and says how to
// fetch it or where to put it), InputError for anything malformed.
Sequence openSequence(const std::string& spec, const SequenceOptions& options);

// The data roots searched for named sequences, in order: options.data_root, $VSLAM_DATA, ./data, ../shared/data
// (the unset ones left out).
std::vector<std::string> dataSearchRoots(const SequenceOptions& options);

// Where a fetched sequence goes: options.data_root, else $VSLAM_DATA, else ./data.
std::string fetchDataRoot(const SequenceOptions& options);

// Sum of the distances between consecutive positions (metres for metric trajectories).
double pathLength(const std::vector<StampedPose>& poses);

}  // namespace vslam
