// The weights-size check: the formula against the real files' sizes, and the
// refusal of a truncated file.
#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/darknet_weights.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

const DarknetWeightsHeader kVersion025{0, 2, 5};  // the header of every file below

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const fs::path path = test::scratchDir(dir) / name;
  std::ofstream(path) << text;
  return path.string();
}

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(DarknetWeights, ExpectedSizesMatchTheRealFiles) {
  const fs::path models = test::sharedModels();
  EXPECT_EQ(expectedWeightsBytes(parseDarknetCfg((models / "yolo-fastest-1.1/yolo-fastest-1.1-xl.cfg").string()),
                                 kVersion025),
            3693964);
  EXPECT_EQ(expectedWeightsBytes(parseDarknetCfg((models / "yolo-fastest-1.1/yolo-fastest-1.1.cfg").string()),
                                 kVersion025),
            1384268);
  // The official AlexeyAB/darknet release files (not downloadable here).
  EXPECT_EQ(expectedWeightsBytes(parseDarknetCfg((models / "darknet-cfg/yolov4.cfg").string()), kVersion025),
            257717640);
  EXPECT_EQ(expectedWeightsBytes(parseDarknetCfg((models / "darknet-cfg/yolov4-tiny.cfg").string()), kVersion025),
            24251276);
}

TEST(DarknetWeights, RealHeadersAreReadAndRealFilesPass) {
  const fs::path dir = test::sharedModels() / "yolo-fastest-1.1";
  const DarknetWeightsHeader header = readDarknetWeightsHeader((dir / "yolo-fastest-1.1-xl.weights").string());
  EXPECT_EQ(header.major, 0);
  EXPECT_EQ(header.minor, 2);
  EXPECT_EQ(header.bytes(), 20);
  EXPECT_EQ(header.seen, 16000000);  // images seen in training
  for (const char* name : {"yolo-fastest-1.1-xl", "yolo-fastest-1.1"})
    EXPECT_NO_THROW(checkWeightsFile((dir / (std::string(name) + ".cfg")).string(),
                                     (dir / (std::string(name) + ".weights")).string()));
}

TEST(DarknetWeights, OldHeadersHaveA32BitSeenCounter) {
  EXPECT_EQ((DarknetWeightsHeader{0, 1, 0}.bytes()), 16);
  EXPECT_EQ((DarknetWeightsHeader{0, 2, 0}.bytes()), 20);
  EXPECT_EQ((DarknetWeightsHeader{1, 0, 0}.bytes()), 20);
}

TEST(DarknetWeights, ChannelsAreTrackedThroughRouteGroupsAndShortcuts) {
  const DarknetNetwork tiny = parseDarknetCfg((test::sharedModels() / "darknet-cfg/yolov4-tiny.cfg").string());
  ASSERT_GE(tiny.layers.size(), 5u);
  EXPECT_EQ(tiny.layers[2].out_channels, 64);
  EXPECT_EQ(tiny.layers[3].type, "route");
  EXPECT_EQ(tiny.layers[3].out_channels, 32);  // groups=2 keeps half of 64
  EXPECT_EQ(tiny.classes, 80);
  EXPECT_EQ(tiny.yoloLayerCount(), 2);
  EXPECT_EQ(tiny.width, 416);

  const std::string cfg = writeFile("weights_formula", "small.cfg",
                                    "[net]\nchannels=3\n"
                                    "[convolutional]\nbatch_normalize=1\nfilters=8\nsize=3\n"  // 8+24+8*3*9
                                    "[convolutional]\ngroups=8\nfilters=8\nsize=3\n"           // 8+8*1*9
                                    "[shortcut]\nfrom=-2\n"
                                    "[route]\nlayers=0,-1\n"                                   // 16 channels
                                    "[convolutional]\nfilters=4\nsize=1\n");                   // 4+4*16
  const DarknetNetwork net = parseDarknetCfg(cfg);
  EXPECT_EQ(net.layers[3].out_channels, 16);
  EXPECT_EQ(net.parameterCount(), (8 + 24 + 8 * 3 * 9) + (8 + 8 * 9) + (4 + 4 * 16));
}

TEST(DarknetWeights, TruncatedFileIsRefusedNamingBothSizes) {
  const fs::path dir = test::sharedModels() / "yolo-fastest-1.1";
  const fs::path truncated = test::scratchDir("weights_truncated") / "yolo-fastest-1.1-xl.weights";
  {
    std::ifstream in(dir / "yolo-fastest-1.1-xl.weights", std::ios::binary);
    std::vector<char> bytes(1000000);
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    std::ofstream(truncated, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const std::string message =
      errorOf([&] { checkWeightsFile((dir / "yolo-fastest-1.1-xl.cfg").string(), truncated.string()); });
  EXPECT_NE(message.find(truncated.string()), std::string::npos) << message;
  EXPECT_NE(message.find("1000000"), std::string::npos) << message;
  EXPECT_NE(message.find("3693964"), std::string::npos) << message;
  EXPECT_NE(message.find("truncated"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

TEST(DarknetWeights, MissingWeightsFileIsNamed) {
  const std::string message = errorOf([] {
    checkWeightsFile((test::sharedModels() / "darknet-cfg/yolov4.cfg").string(), "/nonexistent/yolov4.weights");
  });
  EXPECT_NE(message.find("/nonexistent/yolov4.weights"), std::string::npos) << message;
}

TEST(DarknetWeights, CfgErrorsNameFileAndLine) {
  const std::string bad_value = writeFile("weights_bad_cfg", "bad.cfg", "[net]\nwidth=416\n\n[convolutional]\nfilters=abc\n");
  std::string message = errorOf([&] { parseDarknetCfg(bad_value); });
  EXPECT_NE(message.find(bad_value + ":5:"), std::string::npos) << message;

  const std::string bad_route = writeFile("weights_bad_route", "route.cfg", "[net]\n[convolutional]\nfilters=4\n[route]\nlayers=-3\n");
  message = errorOf([&] { parseDarknetCfg(bad_route); });
  EXPECT_NE(message.find(bad_route + ":4:"), std::string::npos) << message;

  const std::string unknown = writeFile("weights_unknown", "unknown.cfg", "[net]\n[lstm]\n");
  message = errorOf([&] { parseDarknetCfg(unknown); });
  EXPECT_NE(message.find(unknown + ":2:"), std::string::npos) << message;
  EXPECT_NE(message.find("[lstm]"), std::string::npos) << message;

  message = errorOf([] { parseDarknetCfg("/nonexistent/x.cfg"); });
  EXPECT_NE(message.find("/nonexistent/x.cfg"), std::string::npos) << message;
}

// Found by the darknet_cfg and darknet_weights fuzz targets (docs/FUZZING.md):
// filters * channels * size^2 overflowed int64 and the header's major * 10 +
// minor overflowed int (undefined behaviour); such a cfg was accepted.
TEST(DarknetWeights, LayersBeyondAnyRealNetworkAreRefusedNotOverflowed) {
  const std::string huge = writeFile("weights_huge", "huge.cfg",
                                     "[net]\nchannels=3\n[convolutional]\nfilters=2000000000\nsize=2000000000\n");
  std::string message = errorOf([&] { parseDarknetCfg(huge); });
  EXPECT_NE(message.find(huge + ":3: filters must be at most 65536"), std::string::npos) << message;

  const std::string wide_route = writeFile("weights_wide_route", "route.cfg",
                                           "[net]\n[convolutional]\nfilters=65536\nsize=1\n[route]\nlayers=-1,-1\n");
  message = errorOf([&] { parseDarknetCfg(wide_route); });
  EXPECT_NE(message.find(wide_route + ":5: route gives more than 65536 channels"), std::string::npos) << message;

  std::string many = "[net]\nchannels=65536\n";
  for (int i = 0; i < 20; ++i) many += "[convolutional]\nfilters=65536\nsize=1024\n";
  const std::string too_many = writeFile("weights_too_many", "many.cfg", many);
  message = errorOf([&] { parseDarknetCfg(too_many); });
  EXPECT_NE(message.find(too_many + ":3: the network needs more than 68719476736 parameters"), std::string::npos)
      << message;

  // Darknet's rule for the width of `seen`, whatever the version numbers.
  EXPECT_EQ((DarknetWeightsHeader{2147483647, 2147483647, 0}.bytes()), 16);
  EXPECT_EQ((DarknetWeightsHeader{-2147483647 - 1, 5, 0}.bytes()), 16);
  EXPECT_EQ((DarknetWeightsHeader{0, 2, 0}.bytes()), 20);
}

TEST(DarknetWeights, PlaceholderHasExactlyTheExpectedSize) {
  const fs::path dir = test::scratchDir("weights_placeholder");
  const std::string cfg = (test::sharedModels() / "darknet-cfg/yolov4-tiny.cfg").string();
  const std::string weights = (dir / "yolov4-tiny.weights").string();
  writePlaceholderWeights(cfg, weights);
  EXPECT_EQ(fs::file_size(weights), 24251276u);
  EXPECT_NO_THROW(checkWeightsFile(cfg, weights));
  EXPECT_EQ(readDarknetWeightsHeader(weights).seen, 0);  // what marks them as placeholders
}

}  // namespace
}  // namespace vslam
