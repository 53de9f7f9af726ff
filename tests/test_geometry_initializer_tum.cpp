// The two-view initializer on real images: two frames of TUM fr1_xyz, matched
// with OpenCV's ORB (only to produce test input), against the motion-capture
// ground truth.
//
// Two fixed pairs, one taken through F (40-55) and one through H (420-432).
// They are not typical: over 117 pairs (every 20th frame, 10/12/15 apart) the
// initializer accepts 44, and 33 of those are within 1.5 deg (median 0.85 deg,
// worst 4.5 deg); OpenCV's 5-point RANSAC on the same matches is within 1.5 deg
// on 57 of 117 (median 1.7 deg). Rejection is the normal outcome at this
// baseline (desk scene, near-planar, 2-8 deg of parallax): tracking retries on
// the next frame. See docs/GEOMETRY.md.
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/geometry/two_view_initializer.hpp"

namespace vslam {
namespace {

struct Frame {
  double timestamp;
  std::string path;
};

std::vector<Frame> readRgbList(const std::filesystem::path& sequence) {
  std::ifstream in(sequence / "rgb.txt");
  std::vector<Frame> frames;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    Frame frame;
    fields >> frame.timestamp >> frame.path;
    frames.push_back({frame.timestamp, (sequence / frame.path).string()});
  }
  return frames;
}

// Ground truth T_wc by timestamp (TUM: tx ty tz qx qy qz qw, camera-to-world).
std::map<double, SE3> readGroundTruth(const std::filesystem::path& sequence) {
  std::ifstream in(sequence / "groundtruth.txt");
  std::map<double, SE3> poses;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, tx, ty, tz, qx, qy, qz, qw;
    fields >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw;
    poses[t] = SE3(Quat(qw, qx, qy, qz), Vec3(tx, ty, tz));
  }
  return poses;
}

SE3 nearestPose(const std::map<double, SE3>& poses, double timestamp) {
  auto after = poses.lower_bound(timestamp);
  if (after == poses.end()) return std::prev(after)->second;
  if (after == poses.begin()) return after->second;
  const auto before = std::prev(after);
  return (timestamp - before->first < after->first - timestamp) ? before->second : after->second;
}

constexpr float kRatio = 0.8f;

struct PairOutcome {
  TwoViewResult result;
  SE3 T_cur_ref_truth;
  int matches = 0;
};

PairOutcome initializeFromPair(int ref_index, int cur_index) {
  const auto sequence = test::tumSequence("freiburg1_xyz");
  const Config config = loadConfig(projectConfigDir() + "/tum_fr1.yaml");
  const auto frames = readRgbList(sequence);
  const auto truth = readGroundTruth(sequence);
  const Frame& ref = frames.at(ref_index);
  const Frame& cur = frames.at(cur_index);
  const cv::Mat image_ref = cv::imread(ref.path, cv::IMREAD_GRAYSCALE);
  const cv::Mat image_cur = cv::imread(cur.path, cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(image_ref.empty()) << ref.path;
  EXPECT_FALSE(image_cur.empty()) << cur.path;

  auto orb = cv::ORB::create(config.orb.n_features, static_cast<float>(config.orb.scale_factor), config.orb.n_levels);
  std::vector<cv::KeyPoint> keys_ref, keys_cur;
  cv::Mat desc_ref, desc_cur;
  orb->detectAndCompute(image_ref, cv::noArray(), keys_ref, desc_ref);
  orb->detectAndCompute(image_cur, cv::noArray(), keys_cur, desc_cur);
  // Mutual nearest neighbours (cross-check) that also pass Lowe's ratio test:
  // RANSAC on 8-point sets needs a high inlier ratio (ORB-SLAM's own matcher
  // for initialisation is similarly strict).
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> forward, backward;
  matcher.knnMatch(desc_ref, desc_cur, forward, 2);
  matcher.knnMatch(desc_cur, desc_ref, backward, 1);
  std::vector<cv::DMatch> matches;
  for (const auto& candidates : forward) {
    if (candidates.size() < 2) continue;
    const cv::DMatch& best = candidates[0];
    if (best.distance >= kRatio * candidates[1].distance) continue;
    if (backward[best.trainIdx].empty() || backward[best.trainIdx][0].trainIdx != best.queryIdx) continue;
    matches.push_back(best);
  }

  std::vector<cv::Point2f> distorted_ref, distorted_cur;
  std::vector<double> sigma2_ref, sigma2_cur;
  for (const cv::DMatch& m : matches) {
    distorted_ref.push_back(keys_ref[m.queryIdx].pt);
    distorted_cur.push_back(keys_cur[m.trainIdx].pt);
    sigma2_ref.push_back(std::pow(config.orb.scale_factor, 2 * keys_ref[m.queryIdx].octave));
    sigma2_cur.push_back(std::pow(config.orb.scale_factor, 2 * keys_cur[m.trainIdx].octave));
  }
  const auto undistorted_ref = config.camera.undistort(distorted_ref);
  const auto undistorted_cur = config.camera.undistort(distorted_cur);
  std::vector<Vec2> pts_ref, pts_cur;
  for (size_t i = 0; i < matches.size(); ++i) {
    pts_ref.emplace_back(undistorted_ref[i].x, undistorted_ref[i].y);
    pts_cur.emplace_back(undistorted_cur[i].x, undistorted_cur[i].y);
  }

  PairOutcome outcome;
  outcome.matches = static_cast<int>(matches.size());
  const TwoViewInitializer initializer(config.camera.Keigen(), config.initializer, 0);
  outcome.result = initializer.initialize(pts_ref, pts_cur, sigma2_ref, sigma2_cur);
  const SE3 T_w_ref = nearestPose(truth, ref.timestamp);
  const SE3 T_w_cur = nearestPose(truth, cur.timestamp);
  outcome.T_cur_ref_truth = T_w_cur.inverse() * T_w_ref;
  return outcome;
}

double angleDeg(const Mat3& R_a, const Mat3& R_b) {
  return Eigen::AngleAxisd(R_a.transpose() * R_b).angle() * 180.0 / M_PI;
}

TEST(GeometryInitializerTum, Fr1XyzRotationAgreesWithGroundTruth) {
  for (const auto& [ref_index, cur_index] : {std::pair{40, 55}, std::pair{420, 432}}) {
    const PairOutcome outcome = initializeFromPair(ref_index, cur_index);
    const TwoViewResult& result = outcome.result;
    ASSERT_TRUE(result.success) << "frames " << ref_index << "-" << cur_index << ": " << result.failure_reason;
    const double rotation_error = angleDeg(result.T_cur_ref.R, outcome.T_cur_ref_truth.R);
    const double truth_angle = angleDeg(Mat3::Identity(), outcome.T_cur_ref_truth.R);
    EXPECT_LT(rotation_error, 1.5) << "frames " << ref_index << "-" << cur_index;
    std::cout << "frames " << ref_index << "-" << cur_index << ": " << outcome.matches << " matches, "
              << (result.used_homography ? "H" : "F") << " (ratio " << result.score_ratio << "), "
              << result.n_triangulated << " triangulated, parallax " << result.median_parallax_deg
              << " deg, rotation " << truth_angle << " deg, error " << rotation_error << " deg\n";
  }
}

}  // namespace
}  // namespace vslam
