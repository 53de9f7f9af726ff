// The detection thread: results per frame, a frame ahead, errors handed over,
// clean shutdown; then with the real detector on fr3 frames.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <future>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "detect_test_support.hpp"
#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/detect/async_detector.hpp"
#include "vslam/detect/detection_stage.hpp"

namespace vslam {
namespace {

using namespace std::chrono_literals;

// Frames whose first pixel holds their index; the fake detector reports it back.
cv::Mat frame(int index) { return cv::Mat(8, 8, CV_8UC3, cv::Scalar(index, 0, 0)); }

std::vector<Detection> echo(const cv::Mat& image) {
  Detection detection;
  detection.id = image.at<cv::Vec3b>(0, 0)[0];
  return {detection};
}

TEST(AsyncDetector, ReturnsEachFramesDetections) {
  AsyncDetector async(echo);
  async.submit(0, frame(0));
  for (int i = 0; i < 10; ++i) {
    if (i + 1 < 10) async.submit(i + 1, frame(i + 1));
    const auto detections = async.wait(i);
    ASSERT_EQ(detections.size(), 1u);
    EXPECT_EQ(detections[0].id, i);
  }
}

TEST(AsyncDetector, SubmitReturnsBeforeDetectionFinishes) {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<int> started{0};
  AsyncDetector async([&](const cv::Mat& image) {
    ++started;
    released.wait();  // detection "takes" until the test releases it
    return echo(image);
  });
  cv::Mat image = frame(7);
  async.submit(7, image);
  image.setTo(cv::Scalar(99, 0, 0));  // the caller may reuse its buffer: submit copied it
  while (started == 0) std::this_thread::sleep_for(1ms);
  EXPECT_EQ(started, 1);  // running on the other thread while this one goes on
  release.set_value();
  EXPECT_EQ(async.wait(7).at(0).id, 7);
  EXPECT_GE(async.totalWaitMs(), 0.0);
}

TEST(AsyncDetector, ExceptionsReachTheCallerAndLaterFramesStillWork) {
  AsyncDetector async([](const cv::Mat& image) -> std::vector<Detection> {
    if (image.at<cv::Vec3b>(0, 0)[0] == 1) throw std::runtime_error("detector failed on frame 1");
    return echo(image);
  });
  async.submit(0, frame(0));
  async.submit(1, frame(1));
  async.submit(2, frame(2));
  EXPECT_EQ(async.wait(0).at(0).id, 0);
  try {
    async.wait(1);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "detector failed on frame 1");
  }
  EXPECT_EQ(async.wait(2).at(0).id, 2);
}

TEST(AsyncDetector, MisuseIsALogicError) {
  AsyncDetector async(echo);
  EXPECT_THROW(async.wait(3), std::logic_error);
  async.submit(3, frame(3));
  EXPECT_THROW(async.submit(3, frame(3)), std::logic_error);
  async.wait(3);
  EXPECT_THROW(async.wait(3), std::logic_error);  // already collected
}

TEST(AsyncDetector, ShutsDownWithFramesStillQueued) {
  std::atomic<int> detected{0};
  const auto start = std::chrono::steady_clock::now();
  {
    AsyncDetector async([&](const cv::Mat& image) {
      std::this_thread::sleep_for(20ms);
      ++detected;
      return echo(image);
    });
    for (int i = 0; i < 50; ++i) async.submit(i, frame(i));
  }
  // At most the frame in progress (and one the worker took just before the stop) ran.
  EXPECT_LE(detected.load(), 2);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);
}

TEST(AsyncDetector, RealDetectorAheadOfTheCaller) {
  DetectorParams params;
  YoloDetector detector(params, locateModel(params));
  AsyncDetector async([&](const cv::Mat& image) { return detector.detect(image); });
  std::vector<std::filesystem::path> frames;
  for (const auto& entry : std::filesystem::directory_iterator(test::tumSequence("freiburg3_long_office_household") / "rgb"))
    frames.push_back(entry.path());
  std::sort(frames.begin(), frames.end());
  frames.resize(4);
  async.submit(0, cv::imread(frames[0].string()));
  int chairs = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (i + 1 < frames.size()) async.submit(static_cast<int>(i + 1), cv::imread(frames[i + 1].string()));
    for (const Detection& d : async.wait(static_cast<int>(i))) chairs += d.class_name == "chair" ? 1 : 0;
  }
  EXPECT_GE(chairs, 4);
}

TEST(DetectionStage, NoneGivesNoStage) {
  DetectorParams params;
  params.model = "none";
  EXPECT_EQ(makeDetectionStage(params), nullptr);
}

TEST(DetectionStage, ResolvesDynamicClassesAndDetectsAhead) {
  DetectorParams params;
  params.dynamic_classes = {"person", "chair"};
  params.detect_every = *parseDetectEvery("1");
  const auto stage = makeDetectionStage(params);
  ASSERT_NE(stage, nullptr);
  EXPECT_EQ(stage->dynamicClassIds(), (std::vector<int>{0, 56}));
  EXPECT_EQ(stage->classNames().size(), 80u);
  const cv::Mat dog = test::dogImage();
  // Every frame: both submitted ahead, each frame gets its own three boxes, fresh.
  stage->submitAhead(0, dog);
  stage->submitAhead(1, dog);
  FeatureSnapshot frame;
  frame.frame_index = 0;
  EXPECT_EQ(stage->boxesFor(frame, dog).size(), 3u);
  frame.frame_index = 1;
  EXPECT_EQ(stage->boxesFor(frame, dog).size(), 3u);
  EXPECT_EQ(stage->scheduleStats().network_frames, 2);
  EXPECT_EQ(stage->scheduleStats().fresh_frames, 2);
  EXPECT_EQ(stage->scheduleStats().ages, (std::vector<int>(6, 0)));

  params.dynamic_classes = {"pedestrian"};
  try {
    DetectionStage bad(params);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("pedestrian"), std::string::npos) << e.what();
  }
}

// The thread budget holds while a detector is loaded and is lifted with it.
TEST(DetectionStage, ThreadBudgetHoldsWhileTheStageLives) {
  const int before = cv::getNumThreads();
  DetectorParams params;
  params.dnn_threads = 1;
  {
    const auto stage = makeDetectionStage(params);
    ASSERT_NE(stage, nullptr);
    EXPECT_EQ(cv::getNumThreads(), 1);
  }
  EXPECT_EQ(cv::getNumThreads(), before);
  params.dnn_threads = 0;  // OpenCV's own count, untouched
  {
    const auto stage = makeDetectionStage(params);
    EXPECT_EQ(cv::getNumThreads(), before);
  }
}

}  // namespace
}  // namespace vslam
