#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"

namespace vslam {
namespace {

std::string writeFile(const std::string& name, const std::string& text) {
  const auto path = test::scratchDir("config_" + name) / name;
  std::ofstream(path) << text;
  return path.string();
}

std::string errorOf(const std::string& path) {
  try {
    loadConfig(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// requireDepthCamera's message for the file, "" if it accepts it.
std::string depthCameraErrorOf(const std::string& path) {
  try {
    requireDepthCamera(loadConfig(path));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Config, LoadsEveryShippedCameraFile) {
  for (const char* name : {"tum_fr1", "tum_fr2", "tum_fr3", "kitti_00-02", "kitti_03", "kitti_04-12"}) {
    const Config config = loadConfig(projectConfigDir() + "/" + name + ".yaml");
    EXPECT_EQ(config.camera.name, name);
    EXPECT_GT(config.camera.fx, 0);
    EXPECT_EQ(config.orb.n_features, 1000);
    EXPECT_EQ(config.orb.n_levels, 8);
    EXPECT_DOUBLE_EQ(config.orb.scale_factor, 1.2);
    EXPECT_DOUBLE_EQ(config.initializer.homography_ratio, 0.45);
    // The paper's 20 frames at 30 Hz; 10 frames (1 s) at KITTI's 10 Hz (issue 18).
    EXPECT_EQ(config.tracking.max_frames_between_keyframes, std::string(name).rfind("kitti", 0) == 0 ? 10 : 20);
    EXPECT_EQ(config.tracking.min_tracked_points, 100);
    EXPECT_DOUBLE_EQ(config.tracking.ref_ratio, 0.9);
    EXPECT_EQ(config.mapping.min_observations, 3);
  }
  const Config fr1 = loadConfig(projectConfigDir() + "/tum_fr1.yaml");
  EXPECT_DOUBLE_EQ(fr1.camera.fx, 517.306408);
  EXPECT_DOUBLE_EQ(fr1.camera.k3, 1.163314);
  EXPECT_TRUE(fr1.camera.hasDistortion());
}

TEST(Config, MissingFileNamesTheFile) {
  const std::string message = errorOf("/nonexistent/cam.yaml");
  EXPECT_NE(message.find("/nonexistent/cam.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open"), std::string::npos) << message;
}

TEST(Config, MissingKeyIsNamed) {
  const std::string path = writeFile("missing.yaml", "camera:\n  width: 640\n  height: 480\n  fx: 500\n  cx: 320\n  cy: 240\n");
  const std::string message = errorOf(path);
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_NE(message.find("camera.fy"), std::string::npos) << message;
}

TEST(Config, WrongTypeGivesLine) {
  const std::string path =
      writeFile("wrongtype.yaml", "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\norb:\n  n_features: many\n");
  const std::string message = errorOf(path);
  EXPECT_NE(message.find(path + ":9:"), std::string::npos) << message;
  EXPECT_NE(message.find("orb.n_features"), std::string::npos) << message;
  EXPECT_NE(message.find("integer"), std::string::npos) << message;
}

TEST(Config, LoadsOrbSlam2Settings) {
  const std::string path = writeFile("TUM1.yaml",
                                     "%YAML:1.0\nCamera.fx: 517.306408\nCamera.fy: 516.469215\nCamera.cx: 318.643040\n"
                                     "Camera.cy: 255.313989\nCamera.k1: 0.262383\nCamera.k2: -0.953104\nCamera.p1: -0.005358\n"
                                     "Camera.p2: 0.002628\nCamera.k3: 1.163314\nCamera.fps: 30.0\nCamera.RGB: 1\n"
                                     "ORBextractor.nFeatures: 1500\nORBextractor.scaleFactor: 1.3\nORBextractor.nLevels: 6\n"
                                     "ORBextractor.iniThFAST: 25\nORBextractor.minThFAST: 8\n");
  const Config config = loadConfig(path);
  EXPECT_DOUBLE_EQ(config.camera.fx, 517.306408);
  EXPECT_DOUBLE_EQ(config.camera.k1, 0.262383);
  EXPECT_EQ(config.orb.n_features, 1500);
  EXPECT_DOUBLE_EQ(config.orb.scale_factor, 1.3);
  EXPECT_EQ(config.orb.n_levels, 6);
  EXPECT_EQ(config.orb.fast_threshold, 25);
  EXPECT_EQ(config.orb.fast_min_threshold, 8);
}

// RGB-D keys (issue 13): Camera.bf, ThDepth and DepthMapFactor in ORB-SLAM2's
// files, camera.bf / th_depth / depth_factor / max_depth_m in ours.
TEST(Config, ReadsTheRgbdKeysOfBothFormats) {
  const std::string orb = writeFile("TUM1_rgbd.yaml",
                                    "%YAML:1.0\nCamera.fx: 517.306408\nCamera.fy: 516.469215\nCamera.cx: 318.643040\n"
                                    "Camera.cy: 255.313989\nCamera.bf: 40.0\nThDepth: 35.5\nDepthMapFactor: 5208.0\n");
  const Config from_orb = loadConfig(orb);
  EXPECT_DOUBLE_EQ(from_orb.camera.bf, 40.0);
  EXPECT_DOUBLE_EQ(from_orb.camera.th_depth, 35.5);
  EXPECT_DOUBLE_EQ(from_orb.camera.depth_factor, 5208.0);
  EXPECT_DOUBLE_EQ(from_orb.camera.baseline(), 40.0 / 517.306408);
  EXPECT_DOUBLE_EQ(from_orb.camera.closeDepth(), 40.0 / 517.306408 * 35.5);
  EXPECT_NO_THROW(requireDepthCamera(from_orb));

  const std::string ours = writeFile("ours_rgbd.yaml",
                                     "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n"
                                     "  bf: 50\n  th_depth: 30\n  max_depth_m: 4.5\n  depth_factor: 1000\n");
  const Config from_ours = loadConfig(ours);
  EXPECT_DOUBLE_EQ(from_ours.camera.bf, 50.0);
  EXPECT_DOUBLE_EQ(from_ours.camera.closeDepth(), 0.1 * 30);
  EXPECT_DOUBLE_EQ(from_ours.camera.max_depth_m, 4.5);
  EXPECT_DOUBLE_EQ(from_ours.camera.depth_factor, 1000.0);

  // The shipped TUM and Bonn files carry ORB-SLAM2's TUM values.
  for (const char* name : {"tum_fr1", "tum_fr2", "tum_fr3", "bonn"}) {
    const Config config = loadConfig(projectConfigDir() + "/" + name + ".yaml");
    EXPECT_DOUBLE_EQ(config.camera.bf, 40.0) << name;
    EXPECT_DOUBLE_EQ(config.camera.th_depth, 40.0) << name;
    EXPECT_DOUBLE_EQ(config.camera.depth_factor, 5000.0) << name;
  }
}

TEST(Config, RgbdWithoutBfNamesTheKeyAsTheFileSpellsIt) {
  const std::string orb = writeFile("TUM1_nobf.yaml",
                                    "%YAML:1.0\nCamera.fx: 517.3\nCamera.fy: 516.4\nCamera.cx: 318.6\nCamera.cy: 255.3\n");
  const std::string orb_error = depthCameraErrorOf(orb);
  EXPECT_NE(orb_error.find(orb + ": missing required key 'Camera.bf' for RGB-D"), std::string::npos) << orb_error;
  const std::string ours =
      writeFile("ours_nobf.yaml", "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n");
  const std::string ours_error = depthCameraErrorOf(ours);
  EXPECT_NE(ours_error.find(ours + ": missing required key 'camera.bf' for RGB-D"), std::string::npos) << ours_error;
  const std::string negative = writeFile(
      "ours_negbf.yaml", "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n  bf: -3\n");
  EXPECT_NE(errorOf(negative).find("bf must be >= 0"), std::string::npos) << errorOf(negative);
}

// camera.readout_s: the rolling shutter's readout (docs/GEOMETRY.md); 0, a
// global shutter, unless a file says otherwise, and never negative.
TEST(Config, ReadsTheRollingShutterReadout) {
  const std::string camera = "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n";
  EXPECT_DOUBLE_EQ(loadConfig(writeFile("global_shutter.yaml", camera)).camera.readout_s, 0.0);
  EXPECT_DOUBLE_EQ(loadConfig(writeFile("rolling_shutter.yaml", camera + "  readout_s: 0.025\n")).camera.readout_s,
                   0.025);
  const std::string negative = writeFile("negative_readout.yaml", camera + "  readout_s: -0.01\n");
  EXPECT_NE(errorOf(negative).find(negative + ":8: camera readout_s must be in [0, 1) seconds"), std::string::npos)
      << errorOf(negative);
  // The shipped values, each the readout with the least reprojection error on its camera's sequence.
  EXPECT_DOUBLE_EQ(loadConfig(projectConfigDir() + "/tum_fr1.yaml").camera.readout_s, 0.025);
  EXPECT_DOUBLE_EQ(loadConfig(projectConfigDir() + "/tum_fr3.yaml").camera.readout_s, 0.020);
  EXPECT_DOUBLE_EQ(loadConfig(projectConfigDir() + "/bonn.yaml").camera.readout_s, 0.025);
  EXPECT_DOUBLE_EQ(loadConfig(projectConfigDir() + "/kitti_00-02.yaml").camera.readout_s, 0.0);  // global shutter
}

TEST(Config, OrbSlam2SettingsMissingKeyIsNamed) {
  const std::string path = writeFile("bad_orbslam.yaml", "%YAML:1.0\nCamera.fx: 517.3\nCamera.cx: 318.6\nCamera.cy: 255.3\n");
  const std::string message = errorOf(path);
  EXPECT_NE(message.find("Camera.fy"), std::string::npos) << message;
  EXPECT_NE(message.find(path), std::string::npos) << message;
}

// Found by the config fuzz target (docs/FUZZING.md): Camera.width: 1e300 was
// cast to int (undefined behaviour) and accepted; .inf and .nan were accepted.
TEST(Config, NumbersOutOfRangeOrNotFiniteAreNamedErrors) {
  const std::string settings = "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  const std::string huge_width = writeFile("huge_width.yaml", settings + "Camera.width: 1e300\n");
  EXPECT_NE(errorOf(huge_width).find(huge_width + ":6: key 'Camera.width' must be an integer"), std::string::npos)
      << errorOf(huge_width);
  const std::string fraction = writeFile("fraction.yaml", settings + "ORBextractor.nFeatures: 1000.5\n");
  EXPECT_NE(errorOf(fraction).find("key 'ORBextractor.nFeatures' must be an integer"), std::string::npos)
      << errorOf(fraction);
  const std::string whole_real = writeFile("whole_real.yaml", settings + "Camera.width: 640.0\n");
  EXPECT_EQ(loadConfig(whole_real).camera.width, 640);
  const std::string infinite = writeFile("infinite.yaml", settings + "Camera.k1: 1e400\n");
  EXPECT_NE(errorOf(infinite).find("key 'Camera.k1' is not a finite number"), std::string::npos) << errorOf(infinite);
  const std::string nan = writeFile(
      "nan.yaml", "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: .nan\n  cx: 320\n  cy: 240\n");
  EXPECT_NE(errorOf(nan).find(nan + ":5: key 'camera.fy' is not a finite number"), std::string::npos) << errorOf(nan);
}

// Found by the config fuzz target: a section that is a scalar or a list let
// yaml-cpp's BadSubscript escape instead of an InputError.
TEST(Config, SectionThatIsNotAMappingIsANamedError) {
  const std::string scalar = writeFile("scalar_camera.yaml", "camera: 3\n");
  EXPECT_NE(errorOf(scalar).find(scalar + ":1: section 'camera' must be a mapping"), std::string::npos)
      << errorOf(scalar);
  const std::string list = writeFile(
      "list_orb.yaml",
      "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\norb: [1, 2]\n");
  EXPECT_NE(errorOf(list).find(list + ":8: section 'orb' must be a mapping"), std::string::npos) << errorOf(list);
}

// Found by the config fuzz target: OpenCV's FileStorage let std::length_error
// out of this malformed settings file instead of a cv::Exception. The line
// reader names the first line that is not "Key: value".
TEST(Config, OrbSlam2SettingsMalformedLineIsANamedError) {
  const std::string invalid_utf8(8, '\xd6');
  const std::string path = writeFile("opencv_length_error.yaml",
                                     "%YAML:1.0\nCcamera:\n  \n  fx" + invalid_utf8 +
                                         "x: 318.6\n  cy: 255.3\n  k1: 0.26\n  :\n  2nam depthm_fr1\nepthm_fr\n1\n");
  EXPECT_NE(errorOf(path).find(path + ":9: expected 'Key: value'"), std::string::npos) << errorOf(path);
}

// Found by the config fuzz target (CI, 4 Dec 2026): cv::FileStorage of
// OpenCV 4.6 never returns on this file; settings are now read line by line.
TEST(Config, OrbSlam2SettingsThatHungOpenCvAreANamedError) {
  const std::string path = writeFile("opencv_hang.yaml", "%YAML:1.0PCcam.3\n  k1-: 0.13\n  \n r\n0\n");
  EXPECT_NE(errorOf(path).find(path + ":2: indented line outside a block"), std::string::npos) << errorOf(path);
}

// What genuine ORB-SLAM2/3 settings files hold besides the keys read here:
// comments, quoted strings, "Key:value" without a blank, !!opencv-matrix
// blocks (Stereo/EuRoC.yaml writes "data:[...]", which yaml-cpp refuses).
TEST(Config, OrbSlam2SettingsWithMatricesCommentsAndStringsLoad) {
  const std::string path =
      writeFile("EuRoC_like.yaml",
                "%YAML:1.0\n\n#----\n# Camera Parameters. Adjust them!\nCamera.type: \"PinHole\"\n"
                "Camera.fx: 435.2046959714599  # a comment\nCamera.fy: 435.2046959714599\n"
                "Camera.cx: 367.4517211914062\r\nCamera.cy: 252.2008514404297\nCamera.width: 752\nCamera.height: 480\n"
                "Camera.bf: 47.90639384423901\nThDepth: 35.0\nLEFT.D: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
                "   data:[-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0]\n"
                "LEFT.K:  !!opencv-matrix\n\trows: 3\n\tcols: 3\n\tdt: d\n\tdata: [458.654, 0.0, 367.215, 0.0, 457.296,\n"
                "      248.375, 0.0, 0.0, 1.0]\nORBextractor.nFeatures: 1200 \t\nViewer.PointSize:2\nORBextractor.nLevels:8\n");
  const Config config = loadConfig(path);
  EXPECT_DOUBLE_EQ(config.camera.fx, 435.2046959714599);
  EXPECT_DOUBLE_EQ(config.camera.cx, 367.4517211914062);
  EXPECT_DOUBLE_EQ(config.camera.cy, 252.2008514404297);
  EXPECT_EQ(config.camera.width, 752);
  EXPECT_DOUBLE_EQ(config.camera.bf, 47.90639384423901);
  EXPECT_DOUBLE_EQ(config.camera.th_depth, 35.0);
  EXPECT_EQ(config.orb.n_features, 1200);
  EXPECT_EQ(config.orb.n_levels, 8);
}

TEST(Config, OrbSlam2SettingsKeyTwiceOrQuotedNumberAreNamedErrors) {
  const std::string settings = "%YAML:1.0\nCamera.fx: 500\nCamera.fy: 500\nCamera.cx: 320\nCamera.cy: 240\n";
  const std::string twice = writeFile("twice.yaml", settings + "Camera.fx: 501\n");
  EXPECT_NE(errorOf(twice).find(twice + ":6: key 'Camera.fx' given twice (first on line 2)"), std::string::npos)
      << errorOf(twice);
  const std::string quoted = writeFile("quoted.yaml", settings + "Camera.k1: \"0.1\"\n");
  EXPECT_NE(errorOf(quoted).find(quoted + ":6: key 'Camera.k1' has the wrong type (expected a number"),
            std::string::npos)
      << errorOf(quoted);
  const std::string text = writeFile("text.yaml", settings + "Camera.k2: 0.1x\n");
  EXPECT_NE(errorOf(text).find(text + ":6: key 'Camera.k2' has the wrong type"), std::string::npos) << errorOf(text);
  const std::string document = writeFile("document.yaml", settings + "---\nCamera.k1: 0\n");
  EXPECT_NE(errorOf(document).find(document + ":6: a settings file holds one YAML document"), std::string::npos)
      << errorOf(document);
}

// A camera section and nothing else: 7 lines, so a section after it starts on line 8.
const std::string kMinimalCamera = "camera:\n  width: 640\n  height: 480\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n";

// Each of `values` for `section`.`key` (the only key after kMinimalCamera) must
// be refused with an InputError naming bad.yaml, the key's line (9) and the key.
void expectRefused(const std::string& section, const std::string& key, const std::vector<std::string>& values) {
  for (const std::string& bad : values) {
    try {
      parseConfig(kMinimalCamera + section + ":\n  " + key + ": " + bad + "\n", "bad.yaml");
      ADD_FAILURE() << "accepted " << section << "." << key << " " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml:9:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(section + "." + key), std::string::npos) << e.what();
    }
  }
}

// Found by the config fuzz target: a list at the top level made FileStorage's
// lookup throw a cv::Exception (an assertion) past the reader (the reader was
// cv::FileStorage until 4 Dec 2026).
TEST(Config, OrbSlam2SettingsThatAreAListAreANamedError) {
  const std::string path = writeFile("orbslam_list.yaml", "%YAML:1.0\n- Camera.fx: 517.3\n- Camera.fy: 516.5\n");
  EXPECT_NE(errorOf(path).find(path + ":2: expected a mapping of keys"), std::string::npos) << errorOf(path);
}

// Issue 15: auto and labels only by default; a motion check needs fresh boxes,
// so every frame then, unless a rate is asked for.
TEST(Config, DetectorDefaultsToAutoAndLabelsButEveryFrameForMotionChecks) {
  DetectorParams defaults;
  EXPECT_EQ(detectEvery(defaults).mode, DetectEvery::Mode::Auto);
  EXPECT_EQ(defaults.box_filter, "label");
  defaults.moving_classes = {"person"};
  EXPECT_EQ(detectEvery(defaults).mode, DetectEvery::Mode::Frames);
  EXPECT_EQ(detectEvery(defaults).frames, 1);
  defaults.moving_classes.clear();
  defaults.dynamic_classes = {"person"};
  EXPECT_EQ(detectEvery(defaults).mode, DetectEvery::Mode::Frames);
  defaults.detect_every = *parseDetectEvery("keyframes");
  EXPECT_EQ(detectEvery(defaults).mode, DetectEvery::Mode::KeyFrames);
}

// Issue 15: when the detector runs, read from the config and checked with the line.
TEST(Config, DetectEveryIsReadAndCheckedWithItsLine) {
  const std::string camera = kMinimalCamera;
  Config config = parseConfig(camera + "detector:\n  detect_every: 5\n  max_box_age: 7\n  dnn_threads: 1\n  box_filter: reuse\n",
                              "five.yaml");
  EXPECT_EQ(config.detector.detect_every->mode, DetectEvery::Mode::Frames);
  EXPECT_EQ(config.detector.detect_every->frames, 5);
  EXPECT_EQ(config.detector.max_box_age, 7);
  EXPECT_EQ(config.detector.dnn_threads, 1);
  EXPECT_EQ(config.detector.box_filter, "reuse");
  config = parseConfig(camera + "detector:\n  detect_every: keyframes\n", "kf.yaml");
  EXPECT_EQ(config.detector.detect_every->mode, DetectEvery::Mode::KeyFrames);
  config = parseConfig(camera + "detector:\n  detect_every: auto\n", "auto.yaml");
  EXPECT_EQ(config.detector.detect_every->mode, DetectEvery::Mode::Auto);
  EXPECT_EQ(toString(*config.detector.detect_every), "auto");

  expectRefused("detector", "detect_every", {"0", "-2", "sometimes", "2.5", "1x"});
  EXPECT_THROW(parseConfig(camera + "detector:\n  box_filter: fast\n", "bad.yaml"), InputError);
  EXPECT_EQ(parseConfig(camera + "detector:\n  box_filter: label\n", "label.yaml").detector.box_filter, "label");
  EXPECT_THROW(parseConfig(camera + "detector:\n  max_box_age: -1\n", "bad.yaml"), InputError);
}

TEST(Config, InitializerKeysAreReadAndTheWindowLevelIsCheckedWithItsLine) {
  const std::string camera = kMinimalCamera;
  const Config config = parseConfig(
      camera + "initializer:\n  window_max_level: 2\n  max_translation_direction_std_deg: 3.5\n", "init.yaml");
  EXPECT_EQ(config.initializer.window_max_level, 2);
  EXPECT_DOUBLE_EQ(config.initializer.max_translation_direction_std_deg, 3.5);
  EXPECT_EQ(parseConfig(camera, "none.yaml").initializer.window_max_level, 0);  // ORB-SLAM's finest level only
  // The road configs search level 1 too (issue 18); the TUM ones keep ORB-SLAM's rule.
  EXPECT_EQ(loadConfig(projectConfigDir() + "/kitti_00-02.yaml").initializer.window_max_level, 1);
  EXPECT_EQ(loadConfig(projectConfigDir() + "/tum_fr1.yaml").initializer.window_max_level, 0);

  expectRefused("initializer", "window_max_level", {"-1", "8", "12"});  // 8 levels: 0 to 7
  // A bound of 0 or less would refuse every motion from F (NaN: the reader's own check).
  expectRefused("initializer", "max_translation_direction_std_deg", {"0", "-2", ".nan", "181"});
  EXPECT_DOUBLE_EQ(
      parseConfig(camera + "initializer:\n  max_translation_direction_std_deg: 180\n", "edge.yaml")
          .initializer.max_translation_direction_std_deg,
      180.0);
}

// Issue 18: the road configs ask more parallax of a two-view point than
// ORB-SLAM2's 0.9998 (1.15 deg), which the TUM ones and the defaults keep.
TEST(Config, MinParallaxIsReadInDegreesAndCheckedWithItsLine) {
  const std::string camera = kMinimalCamera;
  auto cosOf = [](const Config& config) { return std::cos(config.mapping.min_parallax_deg * M_PI / 180); };
  EXPECT_DOUBLE_EQ(cosOf(parseConfig(camera, "none.yaml")), 0.9998);  // ORB-SLAM2's, as Local Mapping computes it
  EXPECT_DOUBLE_EQ(cosOf(parseConfig(camera + "mapping:\n  min_parallax_deg: 60\n", "p.yaml")), 0.5);
  EXPECT_DOUBLE_EQ(loadConfig(projectConfigDir() + "/kitti_00-02.yaml").mapping.min_parallax_deg, 2.3);
  EXPECT_DOUBLE_EQ(cosOf(loadConfig(projectConfigDir() + "/tum_fr1.yaml")), 0.9998);
  expectRefused("mapping", "min_parallax_deg", {"0", "-1", "90", "120", ".nan"});
}

// Issue 18: the road configs triangulate a keyframe against the keyframes
// before it too; the TUM ones and the defaults keep the covisible ones only.
TEST(Config, MinTriangulationNeighboursIsReadAndChecked) {
  const std::string camera = kMinimalCamera;
  EXPECT_EQ(parseConfig(camera, "none.yaml").mapping.min_triangulation_neighbours, 0);
  EXPECT_EQ(parseConfig(camera + "mapping:\n  min_triangulation_neighbours: 7\n", "n.yaml")
                .mapping.min_triangulation_neighbours,
            7);
  for (const char* road : {"/kitti_00-02.yaml", "/kitti_03.yaml", "/kitti_04-12.yaml"})
    EXPECT_EQ(loadConfig(projectConfigDir() + road).mapping.min_triangulation_neighbours, 80) << road;
  EXPECT_EQ(loadConfig(projectConfigDir() + "/tum_fr1.yaml").mapping.min_triangulation_neighbours, 0);
  expectRefused("mapping", "min_triangulation_neighbours", {"-1", "-80"});
}

// A range check names the bad key's own line. It named its section's mark,
// which yaml-cpp puts at the section's first key, so a bad value under a
// later key was reported on another key's line.
TEST(Config, ARangeErrorNamesTheLineOfItsKeyNotOfTheSectionsFirstKey) {
  const std::vector<std::pair<std::string, std::string>> later_keys = {
      {"initializer:\n  min_matches: 100", "max_translation_direction_std_deg: 0"},
      {"initializer:\n  min_matches: 100", "window_max_level: 8"},
      {"mapping:\n  min_observations: 3", "min_parallax_deg: 120"},
      {"mapping:\n  min_observations: 3", "min_triangulation_neighbours: -1"},
  };
  for (const auto& [section, bad_line] : later_keys) {
    // Line 8 holds the section, 9 its first key and 10 the bad one.
    const std::string text = kMinimalCamera + section + "\n  " + bad_line + "\n";
    try {
      parseConfig(text, "bad.yaml");
      ADD_FAILURE() << "accepted " << section << "." << bad_line;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml:10:"), std::string::npos) << e.what();
    }
  }
}

// Bonn RGB-D Dynamic's ground truth is its markers' pose. config/bonn.yaml
// takes it to the camera with the dataset page's calibration, T_ros * T_m,
// whose rotation (a rotation times 1.0593) is projected onto SO(3); the TUM
// and KITTI configs have none, since their ground truth is the camera's.
TEST(Config, BonnGroundTruthIsTakenToTheCameraByThePublishedCalibration) {
  Eigen::Matrix4d T_ros, T_m;
  T_ros << -1, 0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  T_m << 1.0157, 0.1828, -0.2389, 0.0113, 0.0009, -0.8431, -0.6413, -0.0098, -0.3009, 0.6147, -0.8085, 0.0111, 0, 0,
      0, 1;
  const Eigen::Matrix4d published = T_ros * T_m;
  const Eigen::JacobiSVD<Mat3> svd(published.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Mat3 nearest_rotation = svd.matrixU() * svd.matrixV().transpose();

  const Config bonn = loadConfig(projectConfigDir() + "/bonn.yaml");
  ASSERT_TRUE(bonn.evaluation.groundtruth_camera_in_body.has_value());
  const SE3& camera_in_body = *bonn.evaluation.groundtruth_camera_in_body;
  EXPECT_LT((camera_in_body.R - nearest_rotation).cwiseAbs().maxCoeff(), 2e-9);
  EXPECT_LT((camera_in_body.t - published.topRightCorner<3, 1>()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((camera_in_body.R.transpose() * camera_in_body.R - Mat3::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  for (const char* name : {"/tum_fr1.yaml", "/tum_fr3.yaml", "/kitti_00-02.yaml"})
    EXPECT_FALSE(loadConfig(projectConfigDir() + name).evaluation.groundtruth_camera_in_body.has_value()) << name;
}

TEST(Config, GroundTruthCameraInBodyIsReadAndChecked) {
  const Config config = parseConfig(kMinimalCamera +
                                        "evaluation:\n  groundtruth_camera_in_body: [0, -1, 0, 0.1, 1, 0, 0, 0.2, "
                                        "0, 0, 1, 0.3]\n",
                                    "turned.yaml");
  ASSERT_TRUE(config.evaluation.groundtruth_camera_in_body.has_value());
  const SE3& offset = *config.evaluation.groundtruth_camera_in_body;
  EXPECT_NEAR(offset.R(0, 1), -1.0, 1e-15);
  EXPECT_NEAR(offset.R(1, 0), 1.0, 1e-15);
  EXPECT_NEAR(offset.R(2, 2), 1.0, 1e-15);
  EXPECT_DOUBLE_EQ(offset.t.x(), 0.1);
  EXPECT_DOUBLE_EQ(offset.t.z(), 0.3);
  // 11 numbers; a scaled rotation (Bonn's T_m as published); a reflection; a NaN; not numbers.
  expectRefused("evaluation", "groundtruth_camera_in_body",
                {"[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]", "[1.06, 0, 0, 0, 0, 1.06, 0, 0, 0, 0, 1.06, 0]",
                 "[-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]", "[1, 0, 0, .nan, 0, 1, 0, 0, 0, 0, 1, 0]", "[a, b]"});
}

}  // namespace
}  // namespace vslam
