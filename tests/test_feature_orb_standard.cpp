// Our descriptors are standard ORB descriptors: bit for bit what cv::ORB
// computes for the same keypoints (with their angles) on the same level image.
// cv::ORB::compute, given keypoints, blurs the image it is given (7x7 Gaussian,
// sigma 2, reflected border, like ImagePyramid::blurred), drops keypoints
// closer than edgeThreshold to the border (19 here, our border, so it drops
// none) and keeps the keypoints' angles; octave 0 makes it sample the image
// itself. So each of our levels is handed to it as an image of its own, with
// that level's keypoints in level pixels. (The comparison caught that OpenCV
// blurs a whole 8-bit image with a fixed-point kernel but cv::ORB's in-place
// view of its bordered buffer with a float one: buildPyramid blurs a view too.)
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>

#include "feature_test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

cv::Ptr<cv::ORB> cvOrbForOneLevel() {
  return cv::ORB::create(500, 1.2f, 1, OrbExtractor::kEdgeBorder, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
}

// Rows of `a` and `b` that differ in any bit.
int differingRows(const cv::Mat& a, const cv::Mat& b) {
  int differing = 0;
  for (int r = 0; r < a.rows; ++r)
    if (cv::norm(a.row(r), b.row(r), cv::NORM_HAMMING) != 0) ++differing;
  return differing;
}

void expectSameAsCvOrbOnEveryLevel(const cv::Mat& gray) {
  const OrbExtractor extractor{OrbParams()};
  const ImagePyramid pyramid = extractor.buildPyramid(gray);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(pyramid, keypoints, descriptors);
  ASSERT_GT(keypoints.size(), 500u);

  int compared = 0;
  for (int level = 0; level < extractor.levels(); ++level) {
    const cv::Mat& image = pyramid.levels[level];
    const double ratio_x = static_cast<double>(gray.cols) / image.cols;
    const double ratio_y = static_cast<double>(gray.rows) / image.rows;
    std::vector<cv::KeyPoint> level_keypoints;
    cv::Mat ours;
    for (std::size_t i = 0; i < keypoints.size(); ++i) {
      if (keypoints[i].octave != level) continue;
      // Back to level pixels (the inverse of the extractor's level-0 mapping):
      // FAST corners lie on whole pixels.
      cv::KeyPoint k = keypoints[i];
      const double x = (k.pt.x + 0.5) / ratio_x - 0.5, y = (k.pt.y + 0.5) / ratio_y - 0.5;
      ASSERT_NEAR(x, std::round(x), 1e-3);
      ASSERT_NEAR(y, std::round(y), 1e-3);
      k.pt = cv::Point2f(static_cast<float>(std::round(x)), static_cast<float>(std::round(y)));
      k.octave = 0;
      level_keypoints.push_back(k);
      ours.push_back(descriptors.row(static_cast<int>(i)));
    }
    if (level_keypoints.empty()) continue;
    const std::vector<cv::KeyPoint> given = level_keypoints;
    cv::Mat theirs;
    cvOrbForOneLevel()->compute(image, level_keypoints, theirs);
    ASSERT_EQ(level_keypoints.size(), given.size()) << "cv::ORB dropped keypoints on level " << level;
    for (std::size_t i = 0; i < given.size(); ++i) {
      ASSERT_EQ(level_keypoints[i].pt, given[i].pt);
      ASSERT_EQ(level_keypoints[i].angle, given[i].angle);
    }
    EXPECT_EQ(differingRows(ours, theirs), 0) << "of " << ours.rows << " on level " << level;
    compared += ours.rows;
  }
  EXPECT_EQ(compared, static_cast<int>(keypoints.size()));
}

TEST(StandardOrb, ExtractorDescriptorsAreCvOrbsOnEveryLevel) {
  expectSameAsCvOrbOnEveryLevel(test::tumGray("freiburg1_xyz", 0));
  expectSameAsCvOrbOnEveryLevel(test::tumGray("freiburg1_xyz", 400));
}

// Every angle, including the quarter turns where the rotated test points fall
// exactly on whole pixels and the ones where cvRound's halves-to-even matters.
TEST(StandardOrb, DescribeIsCvOrbsAtAnyAngle) {
  cv::Mat noise(120, 160, CV_8UC1);
  cv::RNG rng(16);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  const OrbExtractor extractor{OrbParams()};
  const ImagePyramid pyramid = extractor.buildPyramid(noise);

  std::vector<cv::KeyPoint> keypoints;
  for (int i = 0; i < 3600; ++i) {
    const float x = static_cast<float>(OrbExtractor::kEdgeBorder + (i * 7) % (noise.cols - 2 * OrbExtractor::kEdgeBorder));
    const float y = static_cast<float>(OrbExtractor::kEdgeBorder + (i * 13) % (noise.rows - 2 * OrbExtractor::kEdgeBorder));
    keypoints.emplace_back(cv::Point2f(x, y), 31.f, 0.1f * static_cast<float>(i), 0.f, 0);
  }
  for (float angle : {0.f, 45.f, 90.f, 135.f, 180.f, 270.f, 359.99f})
    keypoints.emplace_back(cv::Point2f(60.f, 60.f), 31.f, angle, 0.f, 0);

  cv::Mat ours, theirs;
  extractor.describe(pyramid.blurred[0], keypoints, ours);
  std::vector<cv::KeyPoint> given = keypoints;
  cvOrbForOneLevel()->compute(noise, given, theirs);
  ASSERT_EQ(given.size(), keypoints.size());
  ASSERT_EQ(ours.size(), theirs.size());
  EXPECT_EQ(differingRows(ours, theirs), 0) << "of " << ours.rows;
}

TEST(StandardOrb, DescribeRejectsKeypointsTooNearTheBorder) {
  const OrbExtractor extractor{OrbParams()};
  const cv::Mat blurred(100, 100, CV_8UC1, cv::Scalar(0));
  cv::Mat descriptors;
  std::vector<cv::KeyPoint> near_border{cv::KeyPoint(cv::Point2f(10.f, 50.f), 31.f, 0.f)};
  EXPECT_THROW(extractor.describe(blurred, near_border, descriptors), InputError);
}

}  // namespace
}  // namespace vslam
