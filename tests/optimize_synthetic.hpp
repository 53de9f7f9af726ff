#pragma once
// Synthetic scenes with known answers for the optimize tests and benchmarks.
#include <cmath>
#include <random>
#include <vector>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam::test {

inline PinholeCamera syntheticCamera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = 500;
  camera.fy = 505;
  camera.cx = 320;
  camera.cy = 240;
  return camera;
}

inline Mat3 rotationAbout(const Vec3& axis, double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

inline double degrees(double d) { return d * M_PI / 180.0; }

// Rotation angle of R_a^T R_b, in radians.
inline double rotationDifference(const Mat3& R_a, const Mat3& R_b) {
  return Eigen::AngleAxisd(R_a.transpose() * R_b).angle();
}

inline Vec3 randomUnitVector(std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  return Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
}

// T with its rotation turned by exactly `rotation_rad` and its translation
// moved by exactly `translation_m`, in random directions.
inline SE3 perturbPose(const SE3& T, double translation_m, double rotation_rad, std::mt19937& rng) {
  return SE3(rotationAbout(randomUnitVector(rng), rotation_rad) * T.R, T.t + translation_m * randomUnitVector(rng));
}

// A world point that camera T_cw sees at a random pixel, at depth in [min_depth, max_depth].
inline Vec3 pointSeenBy(const PinholeCamera& camera, const SE3& T_cw, double min_depth, double max_depth,
                        std::mt19937& rng) {
  std::uniform_real_distribution<double> u(20.0, camera.width - 20.0);
  std::uniform_real_distribution<double> v(20.0, camera.height - 20.0);
  std::uniform_real_distribution<double> depth(min_depth, max_depth);
  const Vec3 p_c = camera.unproject(Vec2(u(rng), v(rng))) * depth(rng);
  return T_cw.inverse() * p_c;
}

// Camera poses T_cw along a gentle arc, all looking roughly at the same scene
// around (0, 0, 5) in the world; pose 0 is the identity.
inline std::vector<SE3> arcOfCameras(int count, double spacing_m) {
  std::vector<SE3> poses;
  for (int i = 0; i < count; ++i) {
    const Vec3 centre(spacing_m * i, 0.02 * i * i * spacing_m, 0.01 * i);
    const Mat3 R_wc = rotationAbout(Vec3(0, 1, 0), -0.05 * i) * rotationAbout(Vec3(1, 0, 0), 0.01 * i);
    const SE3 T_wc(R_wc, centre);
    poses.push_back(T_wc.inverse());
  }
  return poses;
}

}  // namespace vslam::test
