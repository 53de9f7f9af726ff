// Model lookup by name: search roots, subfolders, explicit paths, errors.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/model_locator.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

DetectorParams model(const std::string& name) {
  DetectorParams params;
  params.model = name;
  return params;
}

TEST(ModelLocator, DefaultModelIsFoundInSharedModels) {
  const ModelFiles files = locateModel(DetectorParams{});
  EXPECT_EQ(files.name, "yolo-fastest-1.1-xl");
  EXPECT_TRUE(fs::equivalent(files.cfg, test::sharedModels() / "yolo-fastest-1.1/yolo-fastest-1.1-xl.cfg"));
  EXPECT_TRUE(fs::equivalent(files.weights, test::sharedModels() / "yolo-fastest-1.1/yolo-fastest-1.1-xl.weights"));
  EXPECT_TRUE(fs::equivalent(files.names, test::sharedModels() / "yolo-fastest-1.1/coco.names"));  // beside the cfg
}

TEST(ModelLocator, CfgAndWeightsMayComeFromDifferentRoots) {
  // Weights in $VSLAM_MODELS (as tools/fetch_models.sh leaves them), cfg from ../shared/models/darknet-cfg.
  const fs::path root = test::scratchDir("locator_env");
  std::ofstream(root / "yolov4-tiny.weights") << "stand-in";
  setenv("VSLAM_MODELS", root.c_str(), 1);
  const ModelFiles files = locateModel(model("yolov4-tiny"));
  unsetenv("VSLAM_MODELS");
  EXPECT_EQ(files.weights, (root / "yolov4-tiny.weights").string());
  EXPECT_TRUE(fs::equivalent(files.cfg, test::sharedModels() / "darknet-cfg/yolov4-tiny.cfg"));
}

TEST(ModelLocator, FirstRootWinsAndSubfoldersAreSearched) {
  const fs::path root = test::scratchDir("locator_first");
  fs::create_directories(root / "mine");
  std::ofstream(root / "mine" / "yolo-fastest-1.1.cfg") << "[net]\n";
  setenv("VSLAM_MODELS", root.c_str(), 1);
  const ModelFiles files = locateModel(model("yolo-fastest-1.1"));
  unsetenv("VSLAM_MODELS");
  EXPECT_EQ(files.cfg, (root / "mine" / "yolo-fastest-1.1.cfg").string());
  EXPECT_TRUE(fs::equivalent(files.weights, test::sharedModels() / "yolo-fastest-1.1/yolo-fastest-1.1.weights"));
}

TEST(ModelLocator, MissingWeightsSayWhereItLookedAndHowToFetch) {
  unsetenv("VSLAM_MODELS");
  const std::string message = errorOf([] { locateModel(model("yolov4")); });
  EXPECT_NE(message.find("yolov4.weights"), std::string::npos) << message;
  EXPECT_NE(message.find("../shared/models"), std::string::npos) << message;
  EXPECT_NE(message.find("./models"), std::string::npos) << message;
  EXPECT_NE(message.find("tools/fetch_models.sh yolov4"), std::string::npos) << message;
}

TEST(ModelLocator, UnknownNameListsTheKnownOnes) {
  const std::string message = errorOf([] { locateModel(model("yolov9")); });
  EXPECT_NE(message.find("yolov9"), std::string::npos) << message;
  EXPECT_NE(message.find("yolov4-tiny"), std::string::npos) << message;
  EXPECT_NE(message.find("--detector-cfg"), std::string::npos) << message;
}

TEST(ModelLocator, ExplicitPathsOverrideTheModel) {
  const fs::path dir = test::sharedModels() / "yolo-fastest-1.1";
  DetectorParams params = model("anything");
  params.cfg = (dir / "yolo-fastest-1.1.cfg").string();
  params.weights = (dir / "yolo-fastest-1.1.weights").string();
  const ModelFiles files = locateModel(params);
  EXPECT_EQ(files.name, "custom");
  EXPECT_EQ(files.cfg, params.cfg);
  EXPECT_EQ(files.weights, params.weights);
  EXPECT_EQ(fs::path(files.names).filename(), "coco.names");

  params.weights = "/nonexistent/my.weights";
  const std::string message = errorOf([&] { locateModel(params); });
  EXPECT_NE(message.find("/nonexistent/my.weights"), std::string::npos) << message;
  EXPECT_NE(message.find("--detector-weights"), std::string::npos) << message;
}

// Bug: with the default model name and another model's cfg and weights given
// explicitly, the run was reported as the default model.
TEST(ModelLocator, AnotherModelsCfgUnderAKnownNameIsCustom) {
  const fs::path dir = test::sharedModels() / "yolo-fastest-1.1";
  DetectorParams params = model("yolo-fastest-1.1-xl");
  params.cfg = (dir / "yolo-fastest-1.1.cfg").string();
  params.weights = (dir / "yolo-fastest-1.1.weights").string();
  EXPECT_EQ(locateModel(params).name, "custom");
  params = model("yolo-fastest-1.1");
  params.cfg = (dir / "yolo-fastest-1.1.cfg").string();
  params.weights = (dir / "yolo-fastest-1.1.weights").string();
  EXPECT_EQ(locateModel(params).name, "yolo-fastest-1.1");  // its own cfg, given by path
}

TEST(ModelLocator, CfgAloneIsFoundWithoutTheWeights) {
  unsetenv("VSLAM_MODELS");
  // YOLOv4's weights are not in ../shared; its cfg is.
  EXPECT_EQ(fs::path(locateModelCfg(model("yolov4"))).filename(), "yolov4.cfg");
  EXPECT_NE(errorOf([] { locateModelCfg(model("yolov9")); }).find("yolov9"), std::string::npos);
}

TEST(ModelLocator, ManifestListsEveryKnownModelWithTheSameFiles) {
  std::ifstream manifest(test::sourceDir() / "models/manifest.tsv");
  ASSERT_TRUE(manifest);
  std::map<std::string, std::vector<std::string>> rows;
  std::string line;
  while (std::getline(manifest, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream split(line);
    std::string field;
    while (std::getline(split, field, '\t')) fields.push_back(field);
    ASSERT_GE(fields.size(), 4u) << line;
    rows[fields[0]] = fields;
  }
  for (const KnownModel& known : knownModels()) {
    ASSERT_TRUE(rows.count(known.name)) << known.name;
    EXPECT_EQ(rows[known.name][1], known.cfg_file);
    EXPECT_EQ(rows[known.name][2], known.weights_file);
    EXPECT_EQ(rows[known.name][3], known.names_file);
  }
}

}  // namespace
}  // namespace vslam
