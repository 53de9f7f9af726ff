// ExtractionAhead: features extracted on the worker are the caller's own,
// bit for bit, and a job that is not the frame or count asked for is never used.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "feature_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/slam/extraction_ahead.hpp"

namespace vslam {
namespace {

cv::Mat tumImage(int k) {
  const std::string path = test::tumRgbPath("freiburg1_xyz", k);
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << path;
  return image;
}

void expectSameFeatures(const ExtractedFeatures& a, const ExtractedFeatures& b) {
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    EXPECT_EQ(a.keypoints[i].pt, b.keypoints[i].pt) << i;
    EXPECT_EQ(a.keypoints[i].octave, b.keypoints[i].octave) << i;
    EXPECT_EQ(a.keypoints[i].angle, b.keypoints[i].angle) << i;
  }
  ASSERT_EQ(a.descriptors.size(), b.descriptors.size());
  EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING), 0.0);
  EXPECT_EQ(a.n_features, b.n_features);
}

TEST(ExtractionAhead, FeaturesOfTheNextFrameAreTheCallersOwn) {
  const Config config;
  const FrameBuilder builder(config, config.camera);
  const cv::Mat first = tumImage(0), second = tumImage(1);
  ExtractionAhead ahead(builder, nullptr);
  // As System does: the next frame is submitted before the current one is taken.
  ahead.submit(10, first, -1);
  ahead.submit(11, second, -1);
  const std::optional<ExtractedFeatures> taken_first = ahead.take(10, -1);
  const std::optional<ExtractedFeatures> taken_second = ahead.take(11, config.orb.n_features);  // the same count
  ASSERT_TRUE(taken_first && taken_second);
  expectSameFeatures(*taken_first, builder.extractFeatures(first));
  expectSameFeatures(*taken_second, builder.extractFeatures(second));
  EXPECT_EQ(ahead.jobsTaken(), 2);
  EXPECT_EQ(ahead.jobsDropped(), 0);
}

TEST(ExtractionAhead, AnotherCountOrAFrameNeverSubmittedIsExtractedByTheCaller) {
  const Config config;
  const FrameBuilder builder(config, config.camera);
  const cv::Mat image = tumImage(0);
  ExtractionAhead ahead(builder, nullptr);
  ahead.submit(1, image, -1);
  // The frame that starts a monocular map makes the next frame's count wrong.
  EXPECT_FALSE(ahead.take(1, 2 * config.orb.n_features));
  ahead.submit(3, image, -1);
  EXPECT_FALSE(ahead.take(2, -1));  // frame 2 never submitted: 3 stays queued
  EXPECT_TRUE(ahead.take(3, -1));
  ahead.submit(6, image, -1);
  ahead.submit(7, image, -1);
  ahead.submit(8, image, -1);  // at most kMaxJobs wait: 6 goes
  EXPECT_FALSE(ahead.take(6, -1));
  EXPECT_TRUE(ahead.take(8, -1));  // 7 was skipped by the caller
  EXPECT_EQ(ahead.jobsTaken(), 2);
  EXPECT_EQ(ahead.jobsDropped(), 3);
}

}  // namespace
}  // namespace vslam
