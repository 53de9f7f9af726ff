#include "vslam/geometry/pnp.hpp"

#include <array>
#include <cmath>
#include <numeric>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace vslam {
namespace {

constexpr int kSampleSize = 4;  // P3P uses 3 points and picks its solution with the 4th
constexpr double kConfidence = 0.99;

SE3 poseFromCv(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Mat3 R;
  Vec3 t;
  cv::cv2eigen(R_cv, R);
  cv::cv2eigen(tvec, t);
  return SE3(R, t);
}

void poseToCv(const SE3& T, cv::Mat& rvec, cv::Mat& tvec) {
  cv::Mat R_cv;
  cv::eigen2cv(T.R, R_cv);
  cv::Rodrigues(R_cv, rvec);
  cv::eigen2cv(T.t, tvec);
}

// Inliers of a pose and their summed squared error (to break ties).
std::vector<int> findInliers(const SE3& T_cw, const std::vector<Vec3>& points_w, const std::vector<Vec2>& pixels,
                             const std::vector<double>& pixel_sigma, const Mat3& K, double max_error2,
                             double* total_error2) {
  std::vector<int> inliers;
  double total = 0;
  for (size_t i = 0; i < points_w.size(); ++i) {
    const Vec3 p_c = T_cw * points_w[i];
    if (!(p_c.z() > 0)) continue;
    const double error2 = ((K * p_c).hnormalized() - pixels[i]).squaredNorm();
    const double sigma = pixel_sigma.empty() ? 1.0 : pixel_sigma[i];
    if (error2 < max_error2 * sigma * sigma) {
      inliers.push_back(static_cast<int>(i));
      total += error2;
    }
  }
  if (total_error2) *total_error2 = total;
  return inliers;
}

// Levenberg-Marquardt (cv::solvePnP ITERATIVE) on the given matches, from T.
SE3 refinePose(const SE3& T, const std::vector<Vec3>& points_w, const std::vector<Vec2>& pixels,
               const std::vector<int>& use, const cv::Mat& K_cv) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (int i : use) {
    object.emplace_back(points_w[i].x(), points_w[i].y(), points_w[i].z());
    image.emplace_back(pixels[i].x(), pixels[i].y());
  }
  cv::Mat rvec, tvec;
  poseToCv(T, rvec, tvec);
  if (!cv::solvePnP(object, image, K_cv, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE)) return T;
  const SE3 refined = poseFromCv(rvec, tvec);
  return refined.R.allFinite() && refined.t.allFinite() ? refined : T;
}

}  // namespace

PnpResult solvePnpRansac(const std::vector<Vec3>& points_w, const std::vector<Vec2>& pixels, const Mat3& K,
                         int iterations, double reproj_px, int min_inliers, uint32_t seed,
                         const std::vector<double>& pixel_sigma) {
  PnpResult result;
  const int n = static_cast<int>(points_w.size());
  if (n < kSampleSize || pixels.size() != points_w.size()) return result;
  if (!pixel_sigma.empty() && pixel_sigma.size() != points_w.size()) return result;
  cv::Mat K_cv;
  cv::eigen2cv(K, K_cv);
  const double max_error2 = reproj_px * reproj_px;

  std::mt19937 rng(seed);
  std::vector<int> pool(n);
  std::vector<int> best_inliers;
  double best_error2 = 0;
  SE3 best_pose;
  int max_iterations = iterations;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    // Partial Fisher-Yates; modulo keeps the draw identical across standard libraries.
    std::iota(pool.begin(), pool.end(), 0);
    std::vector<cv::Point3d> object(kSampleSize);
    std::vector<cv::Point2d> image(kSampleSize);
    for (int k = 0; k < kSampleSize; ++k) {
      std::swap(pool[k], pool[k + static_cast<int>(rng() % static_cast<uint32_t>(n - k))]);
      const Vec3& X = points_w[pool[k]];
      object[k] = cv::Point3d(X.x(), X.y(), X.z());
      image[k] = cv::Point2d(pixels[pool[k]].x(), pixels[pool[k]].y());
    }
    cv::Mat rvec, tvec;
    if (!cv::solvePnP(object, image, K_cv, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_P3P)) continue;
    const SE3 pose = poseFromCv(rvec, tvec);
    if (!pose.R.allFinite() || !pose.t.allFinite()) continue;
    double error2 = 0;
    std::vector<int> inliers = findInliers(pose, points_w, pixels, pixel_sigma, K, max_error2, &error2);
    if (inliers.size() > best_inliers.size() || (inliers.size() == best_inliers.size() && error2 < best_error2)) {
      best_inliers = std::move(inliers);
      best_error2 = error2;
      best_pose = pose;
      // Sets needed to draw one all-inlier set with kConfidence at this ratio.
      const double ratio = static_cast<double>(best_inliers.size()) / n;
      const double p_clean = std::pow(ratio, kSampleSize);
      if (p_clean >= 1.0) break;
      const double needed = std::log(1.0 - kConfidence) / std::log(1.0 - p_clean);
      if (std::isfinite(needed)) max_iterations = std::min(iterations, static_cast<int>(std::ceil(needed)));
    }
  }
  if (static_cast<int>(best_inliers.size()) < std::max(kSampleSize, min_inliers)) return result;

  // Refine on the inliers, re-select them with the better pose, refine again.
  SE3 pose = best_pose;
  std::vector<int> inliers = best_inliers;
  for (int round = 0; round < 2; ++round) {
    pose = refinePose(pose, points_w, pixels, inliers, K_cv);
    inliers = findInliers(pose, points_w, pixels, pixel_sigma, K, max_error2, nullptr);
    if (static_cast<int>(inliers.size()) < kSampleSize) return result;
  }
  result.T_cw = pose;
  result.inliers = std::move(inliers);
  result.success = static_cast<int>(result.inliers.size()) >= min_inliers;
  return result;
}

}  // namespace vslam
