#pragma once
// Configuration is a value: loaded once from a YAML file and passed down.
// Defaults are the paper's parameters ("A Modified V-SLAM Technique for Road
// Scene Modelling"): 1000 ORB features, 8 levels, scale 1.2, H/F ratio 0.45,
// keyframe every 20 frames / < 100 tracked points / < 90 % of the reference.
#include <optional>
#include <string>
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

struct OrbParams {
  int n_features = 1000;
  int n_levels = 8;
  double scale_factor = 1.2;
  int fast_threshold = 20;      // normal FAST threshold
  int fast_min_threshold = 7;   // fallback where a cell has no corner at the normal one
};

struct InitializerParams {
  double homography_ratio = 0.45;  // take H when S_H / (S_H + S_F) > this
  int ransac_iterations = 200;
  double sigma_px = 1.0;
  int min_matches = 100;
  double min_parallax_deg = 1.0;
  int min_triangulated = 50;
  // Two-view geometry (geometry module); ORB-SLAM's values, the paper gives none.
  double min_point_parallax_deg = 0.36;  // a point counts as triangulated above this (cos 0.99998)
  double max_second_best_ratio = 0.7;    // motion is ambiguous if the runner-up has more than this x the best's points
  double min_consistent_fraction = 0.9;  // the motion must explain this share of the model's inliers
  // Ours: a motion from F is refused while its translation direction is known
  // no better than this (1 sigma, first order); docs/GEOMETRY.md.
  double max_translation_direction_std_deg = 5.0;
  // Coarsest pyramid level of the window search that starts a monocular map
  // (ORB-SLAM: 0, the finest only). The KITTI configs take 1: at 10 Hz on the
  // road, level 0 of 1000 features keeps under 100 matches two frames apart.
  int window_max_level = 0;
  bool refine_motion = true;             // Sampson-error refinement of the chosen (R, t)
  bool score_calibrated_f = false;       // true: score each F as its nearest essential matrix (see docs/GEOMETRY.md)
};

struct TrackingParams {
  int max_frames_between_keyframes = 20;  // paper: a keyframe at least every 20 frames...
  int min_tracked_points = 100;           // ...or when fewer points are tracked...
  double ref_ratio = 0.9;                 // ...and only if < 90 % of the reference's points are tracked
  int min_inliers = 30;                   // fewer means the frame is lost
};

struct MappingParams {
  int min_observations = 3;  // the paper's map point survival rule
  double min_found_ratio = 0.25;
  double redundant_keyframe_ratio = 0.9;
  int local_ba_iterations = 10;
  // A point triangulated from two views without depth needs its rays at
  // least this far apart, in (0, 90) degrees. The default is ORB-SLAM2's cos
  // 0.9998 (acos gives these digits, whose cosine is 0.9998 exactly). On the
  // road the camera moves along its axis and many points ahead are seen at
  // small parallax; KITTI's configs ask more (docs/BENCHMARKS.md, "KITTI 00
  // across start frames").
  double min_parallax_deg = 1.1459346897142422;
  // A new keyframe is triangulated against its best covisible keyframes (20,
  // or 10 with depth, as ORB-SLAM2). Where they are fewer than this, the
  // keyframes before it along the spanning tree join them, up to this many in
  // all: on the road a keyframe shares enough points with only the last 5-8,
  // too short a baseline for the points ahead. 0: covisible keyframes only
  // (the TUM default); KITTI's configs ask 80 (docs/BENCHMARKS.md,
  // "Triangulation with the keyframes before").
  int min_triangulation_neighbours = 0;
};

struct LoopParams {
  bool enabled = true;
  int consistency = 3;
  bool final_ba = true;
  int final_ba_iterations = 20;
  // After a final BA that was merged, every tracked frame that is not a
  // keyframe is posed again against the points it matched, as the final map
  // holds them (docs/LOOP_CLOSING.md).
  bool refine_frames = true;
  // Place-recognition vocabulary for relocalisation and loop detection. A
  // relative path not found from the working directory is taken from the
  // project root (resolveVocabularyPath).
  std::string vocabulary = kDefaultVocabulary;

  // ORB-SLAM's shape (k = 10, L = 6). Over 5 MB, so it is not in the
  // repository: tools/setup.sh trains it where the training images are
  // (vocab/README.md).
  static constexpr const char* kDefaultVocabulary = "vocab/orbvoc_k10_L6.bin";
  // The committed k = 10, L = 5 vocabulary, used in the default's place
  // where it could not be built.
  static constexpr const char* kFallbackVocabulary = "vocab/orbvoc.bin";
};

// The vocabulary file `LoopParams::vocabulary` names: as given if it exists,
// else relative to the project root; as given when neither exists (the
// loader then reports it missing). The default (kDefaultVocabulary) found in
// neither place resolves to kFallbackVocabulary the same way.
std::string resolveVocabularyPath(const std::string& path);
std::string resolveVocabularyPath(const std::string& path, const std::string& project_root);

// Which frames the detection network sees (issue 15); the frames in between
// get the last boxes carried along by their keypoints' motion.
struct DetectEvery {
  enum class Mode {
    Frames,     // every `frames`-th frame (by frame index); 1 is the paper's every frame
    KeyFrames,  // each frame Tracking makes a keyframe, without waiting for the result
    Auto,       // the newest frame whenever the detection thread has rested, never waited for
  };
  Mode mode = Mode::Frames;
  int frames = 1;
};

// "N" (a whole number >= 1), "keyframes" or "auto"; std::nullopt for anything else.
std::optional<DetectEvery> parseDetectEvery(const std::string& text);
std::string toString(const DetectEvery& every);

struct DetectorParams {
  std::string model = "yolo-fastest-1.1-xl";  // "none" disables detection
  std::string cfg;       // Darknet cfg; empty: resolved from `model`
  std::string weights;   // Darknet weights; empty: resolved from `model`
  std::string names;     // class names, one a line; empty: resolved from `model`
  int input_size = 0;    // network input, square; 0: the cfg's [net] width and height
  double confidence_threshold = 0.4;
  double nms_threshold = 0.45;
  int min_box_px = 64;   // paper's Algorithm 1: skip boxes narrower or lower than this
  // ORB features asked for inside each box (same pyramid as the frame); 0: orb.n_features.
  // 250 adds ~400 keypoints a frame on fr1_xyz; the frame's 1000 per box added
  // ~1300 and made extraction and tracking slower for no better ATE (docs/DETECTOR.md).
  int box_features = 250;
  std::string dnn_target = "cpu";  // cpu | opencl | cuda
  std::vector<std::string> dynamic_classes;  // keypoints in these boxes are removed
  // Boxes of these classes are checked for motion each frame instead: a moving
  // instance's keypoints and map points are kept out of tracking and mapping,
  // a parked one stays. "coco-movable" stands for COCO's movable classes.
  std::vector<std::string> moving_classes;
  // Config key detector.detect_every: 1, N, keyframes or auto. Unset, it is
  // resolved by detectEvery() below.
  std::optional<DetectEvery> detect_every;
  // Frames a box lives after the network saw it; older carried boxes expire.
  // 30 (1 s at 30 Hz) outlives fr1_xyz's keyframe spacing (~19 frames), so
  // --detect-every keyframes still labels the next keyframe.
  int max_box_age = 30;
  // OpenCV's worker threads (cv::setNumThreads, process-wide) once a detector
  // is loaded; 0 leaves OpenCV's default (one per core). 1 measured faster on
  // 2 shared cores: the network's second thread only took a core from
  // Tracking and Local Mapping (docs/BENCHMARKS.md, "Detection rate").
  int dnn_threads = 1;
  // How boxes add keypoints: "paper" runs ORB again inside each box (Algorithm
  // 1); "reuse" takes the frame's own FAST corners and describes only the ones
  // the frame's quota dropped (issue 15); "label" adds none: the frame's own
  // keypoints inside a box take its class, so tracking sees exactly the
  // keypoints of a detector-off run. "label" is the default: it is the one
  // detector-on setting measured no worse than detector off on every shared
  // sequence (docs/BENCHMARKS.md, "Labels only"); the paper's added keypoints
  // cost accuracy on static scenes and on walking people.
  std::string box_filter = "label";
};

// The rate a run detects at. Unset: auto, so the network never holds Tracking
// up (issue 15); but every frame when boxes are checked for motion or their
// keypoints removed, since a box carried by its keypoints lags a walking
// person (Bonn crowd RGB-D with --moving-classes person, docs/BENCHMARKS.md,
// "Labels only").
inline DetectEvery detectEvery(const DetectorParams& params) {
  if (params.detect_every) return *params.detect_every;
  DetectEvery every;
  if (params.moving_classes.empty() && params.dynamic_classes.empty()) every.mode = DetectEvery::Mode::Auto;
  return every;
}

inline bool isBoxFilter(const std::string& name) { return name == "paper" || name == "reuse" || name == "label"; }

// How the ground truth is read when its poses are not the camera's own.
struct EvaluationParams {
  // The camera's pose in the frame whose poses the ground truth gives
  // (T_body_camera): the camera's pose is then T_world_body * T_body_camera.
  // Unset for TUM and KITTI, whose ground truth is the camera's. Bonn RGB-D
  // Dynamic's motion capture gives its markers' pose (config/bonn.yaml).
  // Without it, rotation errors (RPE) compare the markers' turn with the
  // camera's and mean nothing (docs/EVALUATION.md).
  std::optional<SE3> groundtruth_camera_in_body;
};

// What the run feeds the pipeline: colour alone, or colour with registered
// depth (ORB-SLAM2's RGB-D system). Chosen by `vslam run --mode`, not by the file.
enum class SensorMode { Monocular, RgbD };

struct Config {
  std::string source;  // file the config was read from ("" for defaults)
  bool orb_slam_settings = false;  // `source` is an ORB-SLAM2 settings file (keys as Camera.bf)
  SensorMode sensor = SensorMode::Monocular;
  PinholeCamera camera;
  OrbParams orb;
  InitializerParams initializer;
  TrackingParams tracking;
  MappingParams mapping;
  LoopParams loop;
  DetectorParams detector;
  EvaluationParams evaluation;
};

// Reads our YAML layout (see config/*.yaml) or an ORB-SLAM2 settings file
// (Camera.fx, ORBextractor.nFeatures, ...), told apart by their keys.
// Throws InputError naming the file (and line where known) for a missing file,
// a missing required key, or a value of the wrong type.
Config loadConfig(const std::string& path);

// The same from the file's text; `source` is the file named in errors and
// kept in Config::source.
Config parseConfig(const std::string& text, const std::string& source);

// Checks what RGB-D needs of the camera (bf > 0); throws InputError naming
// the config file and the key as that file spells it.
void requireDepthCamera(const Config& config);

// Directory holding the project's config/*.yaml.
std::string projectConfigDir();

}  // namespace vslam
