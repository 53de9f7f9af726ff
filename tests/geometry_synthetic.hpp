#pragma once
// Synthetic two-view scenes with known answers for the geometry tests.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "vslam/core/types.hpp"

namespace vslam::test {

inline Mat3 syntheticK() {
  Mat3 K;
  K << 500, 0, 320, 0, 510, 240, 0, 0, 1;
  return K;
}

inline Mat3 rotationDeg(double angle_deg, const Vec3& axis) {
  return Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

// Angle of the rotation R_a^T R_b, in radians.
inline double rotationAngle(const Mat3& R_a, const Mat3& R_b) {
  return Eigen::AngleAxisd(R_a.transpose() * R_b).angle();
}

inline double angleBetween(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

inline Vec2 projectPx(const Mat3& K, const Vec3& X_c) { return (K * X_c).hnormalized(); }

inline bool inImage(const Vec2& px) { return px.x() >= 0 && px.y() >= 0 && px.x() < 640 && px.y() < 480; }

struct TwoViewScene {
  SE3 T_cur_ref;
  std::vector<Vec3> points_ref;  // true points, reference frame
  std::vector<Vec2> px_ref, px_cur;
  std::vector<bool> is_outlier;
};

// `n` points seen by both cameras. A point is drawn as a random reference pixel
// and a depth from `depth_of_ray(ray, rng)`; points leaving the current image
// are redrawn. Then Gaussian pixel noise of `noise_px` is added to both
// images, and a fraction `outlier_ratio` of the matches gets a random current
// pixel at least 10 px from its true epipolar line.
template <typename DepthOfRay>
TwoViewScene makeScene(const SE3& T_cur_ref, int n, double noise_px, double outlier_ratio, uint32_t seed,
                       DepthOfRay depth_of_ray) {
  const Mat3 K = syntheticK();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u_x(10, 630), u_y(10, 470);
  std::normal_distribution<double> noise(0.0, noise_px);
  TwoViewScene scene;
  scene.T_cur_ref = T_cur_ref;
  while (static_cast<int>(scene.points_ref.size()) < n) {
    const Vec2 px(u_x(rng), u_y(rng));
    const Vec3 ray = K.inverse() * px.homogeneous();
    const Vec3 X = depth_of_ray(ray, rng) * ray;
    const Vec3 X_cur = T_cur_ref * X;
    if (X_cur.z() <= 0.1) continue;
    const Vec2 px_cur = projectPx(K, X_cur);
    if (!inImage(px_cur)) continue;
    scene.points_ref.push_back(X);
    scene.px_ref.push_back(px);
    scene.px_cur.push_back(px_cur);
  }
  // Essential matrix of the true motion, to keep outliers off their epipolar line.
  Mat3 t_cross;
  const Vec3& t = T_cur_ref.t;
  t_cross << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  const Mat3 F = K.inverse().transpose() * t_cross * T_cur_ref.R * K.inverse();
  scene.is_outlier.assign(n, false);
  const int n_outliers = static_cast<int>(std::round(outlier_ratio * n));
  for (int k = 0; k < n_outliers; ++k) {
    const int i = k * n / std::max(1, n_outliers);  // spread over the list
    while (true) {
      const Vec2 px(u_x(rng), u_y(rng));
      const Vec3 line = F * scene.px_ref[i].homogeneous();
      const double distance = std::abs(line.dot(px.homogeneous())) / line.head<2>().norm();
      if (t.norm() > 0 && !(distance > 10)) continue;
      if ((px - scene.px_cur[i]).norm() < 10) continue;
      scene.px_cur[i] = px;
      scene.is_outlier[i] = true;
      break;
    }
  }
  if (noise_px > 0) {
    for (int i = 0; i < n; ++i) {
      scene.px_ref[i] += Vec2(noise(rng), noise(rng));
      scene.px_cur[i] += Vec2(noise(rng), noise(rng));
    }
  }
  return scene;
}

// Points at depths uniform in [1, 4] m.
inline TwoViewScene makeDepthScene(const SE3& T_cur_ref, int n, double noise_px, double outlier_ratio,
                                   uint32_t seed) {
  return makeScene(T_cur_ref, n, noise_px, outlier_ratio, seed, [](const Vec3&, std::mt19937& rng) {
    return std::uniform_real_distribution<double>(1.0, 4.0)(rng);
  });
}

// Points on the plane normal . X = distance (reference frame).
inline TwoViewScene makePlanarScene(const SE3& T_cur_ref, const Vec3& normal, double distance, int n,
                                    double noise_px, double outlier_ratio, uint32_t seed) {
  return makeScene(T_cur_ref, n, noise_px, outlier_ratio, seed,
                   [normal, distance](const Vec3& ray, std::mt19937&) { return distance / normal.dot(ray); });
}

}  // namespace vslam::test
