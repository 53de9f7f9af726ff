// Is our extractor as good for tracking as cv::ORB? A proxy measured on real
// data: for frame pairs (a, a + 3) of fr1_xyz, match all features by ratio test,
// lift frame a's features to 3D with its depth image, estimate frame b's pose by
// PnP-RANSAC and compare with the ground truth. Same matcher and same PnP for
// both extractors; only the keypoints and descriptors differ.
#include <algorithm>
#include <functional>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "feature_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/feature/matcher.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

struct PairResult {
  double rotation_error_deg = 0;
  double translation_error_cm = 0;
  int pnp_inliers = 0;
  int covered_cells = 0;  // 40 px cells holding a PnP inlier
};

using Extract = std::function<void(const cv::Mat&, std::vector<cv::KeyPoint>&, cv::Mat&)>;

PairResult poseFromPair(const Extract& extract, int a, int b) {
  const std::string seq = "freiburg1_xyz";
  static const PinholeCamera camera = loadConfig(projectConfigDir() + "/tum_fr1.yaml").camera;
  std::vector<cv::KeyPoint> ka, kb;
  cv::Mat da, db;
  extract(test::tumGray(seq, a), ka, da);
  extract(test::tumGray(seq, b), kb, db);
  std::vector<cv::Point2f> raw_a, raw_b;
  for (const cv::KeyPoint& k : ka) raw_a.push_back(k.pt);
  for (const cv::KeyPoint& k : kb) raw_b.push_back(k.pt);
  const std::vector<cv::Point2f> ua = camera.undistort(raw_a), ub = camera.undistort(raw_b);

  const cv::Mat depth = test::tumDepthNear(seq, test::tumRgbStamp(seq, a));
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  for (const cv::DMatch& m : matchByRatio(da, db, 0.8f, kHammingThresholdLow)) {
    const std::uint16_t d = depth.at<std::uint16_t>(cvRound(ka[m.queryIdx].pt.y), cvRound(ka[m.queryIdx].pt.x));
    if (d == 0) continue;
    const Vec3 p = camera.unproject(Vec2(ua[m.queryIdx].x, ua[m.queryIdx].y)) * (d / 5000.0);
    object.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    image.push_back(ub[m.trainIdx]);
  }
  PairResult result;
  cv::Mat rvec, tvec, inliers, R;
  cv::setRNGSeed(1);
  if (object.size() < 6 || !cv::solvePnPRansac(object, image, camera.K(), cv::noArray(), rvec, tvec, false, 200, 2.0,
                                               0.99, inliers)) {
    result.rotation_error_deg = result.translation_error_cm = 1e9;
    return result;
  }
  cv::Rodrigues(rvec, R);
  Mat3 R_ba;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R_ba(r, c) = R.at<double>(r, c);
  const Vec3 t_ba(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  const SE3 truth = test::tumPoseAt(seq, test::tumRgbStamp(seq, b)).inverse() * test::tumPoseAt(seq, test::tumRgbStamp(seq, a));
  result.rotation_error_deg = Eigen::AngleAxisd(R_ba * truth.R.transpose()).angle() * 180.0 / CV_PI;
  result.translation_error_cm = (t_ba - truth.t).norm() * 100.0;
  result.pnp_inliers = inliers.rows;
  std::set<int> cells;
  for (int k = 0; k < inliers.rows; ++k) {
    const cv::Point2f& p = image[inliers.at<int>(k)];
    cells.insert(static_cast<int>(p.y / 40) * 16 + static_cast<int>(p.x / 40));
  }
  result.covered_cells = static_cast<int>(cells.size());
  return result;
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

TEST(OursVsCvOrb, PnpPoseFromDepthIsAsGood) {
  cv::setNumThreads(1);
  const OrbExtractor ours{OrbParams()};
  const auto orb = cv::ORB::create(1000, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 31, 20);
  const Extract extract_ours = [&](const cv::Mat& g, std::vector<cv::KeyPoint>& k, cv::Mat& d) { ours.extract(g, k, d); };
  const Extract extract_cv = [&](const cv::Mat& g, std::vector<cv::KeyPoint>& k, cv::Mat& d) {
    orb->detectAndCompute(g, cv::noArray(), k, d);
  };

  std::vector<double> rot[2], trans[2], inliers[2], cells[2];
  // 20 pairs over the first half of the sequence (clear of the motion-capture
  // gap near frame 200, where the ground truth has no sample for 0.11 s).
  for (int a = 10; a < 400; a += 20) {
    for (int method = 0; method < 2; ++method) {
      const PairResult r = poseFromPair(method == 0 ? extract_ours : extract_cv, a, a + 3);
      rot[method].push_back(r.rotation_error_deg);
      trans[method].push_back(r.translation_error_cm);
      inliers[method].push_back(r.pnp_inliers);
      cells[method].push_back(r.covered_cells);
    }
  }
  for (int method = 0; method < 2; ++method)
    std::cout << (method == 0 ? "ours:    " : "cv::ORB: ") << "median rotation error " << median(rot[method])
              << " deg, translation error " << median(trans[method]) << " cm, PnP inliers " << median(inliers[method])
              << ", 40 px cells with an inlier " << median(cells[method]) << "\n";
  // The reference is noisy itself: the depth image is ~15 ms off the colour
  // image (several mm of motion here) and motion capture is good to a few mm,
  // so "as good" means within 25 % of cv::ORB plus that noise floor.
  EXPECT_LE(median(rot[0]), 1.25 * median(rot[1]) + 0.1);
  EXPECT_LE(median(trans[0]), 1.25 * median(trans[1]) + 0.3);
  EXPECT_LT(*std::max_element(rot[0].begin(), rot[0].end()), 2.0);
  EXPECT_GT(median(cells[0]), median(cells[1]));  // inliers spread wider
}

}  // namespace
}  // namespace vslam
