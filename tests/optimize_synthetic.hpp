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

#include "vslam/optimize/bundle_adjuster.hpp"

namespace vslam::test {

// A Local-Mapping-shaped problem: `n_keyframes` cameras moving sideways along
// x (0.25 m apart) looking down +z; the odd ones are free, the even ones
// fixed (the "others that see those points"). Each point is seen by 4
// consecutive keyframes, so 2000 points give 8000 observations. Pixels carry
// Gaussian noise of `noise_px` sigma (scaled by the pyramid level), a fraction
// `outlier_ratio` of them is moved 20..50 sigma; free poses start 2 cm / 1 deg
// off and free points 5 cm off. Optionally returns the true poses and which
// observations were made outliers.
inline BundleProblem localBundleScene(const PinholeCamera& camera, int n_keyframes, int n_points,
                                      double noise_px, double outlier_ratio, unsigned seed,
                                      std::vector<SE3>* true_poses = nullptr,
                                      std::vector<bool>* is_outlier = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 7);
  const int window = 4;
  std::uniform_int_distribution<int> first_keyframe(0, n_keyframes - window);
  BundleProblem problem;
  std::vector<SE3> truth;
  for (int k = 0; k < n_keyframes; ++k) {
    truth.push_back(SE3(rotationAbout(Vec3(0, 1, 0), 0.01 * k), Vec3(-0.25 * k, 0.0, 0.0)));
    BaKeyframe kf{k, truth.back(), k % 2 == 0, false};
    if (!kf.fixed) kf.T_cw = perturbPose(kf.T_cw, 0.02, degrees(1), rng);
    problem.keyframes.push_back(kf);
  }
  for (int p = 0; p < n_points; ++p) {
    const int first = first_keyframe(rng);
    const Vec3 p_w = pointSeenBy(camera, truth[first + window / 2], 4.0, 10.0, rng);
    problem.points.push_back({p, p_w + 0.05 * randomUnitVector(rng), false});
    for (int k = first; k < first + window; ++k) {
      BaObservation obs;
      obs.keyframe = k;
      obs.point = p;
      obs.inv_sigma2 = 1.0 / std::pow(1.2, 2 * level(rng));
      const double sigma = 1.0 / std::sqrt(obs.inv_sigma2);
      obs.pixel = camera.project(truth[k] * p_w) + noise_px * sigma * Vec2(gauss(rng), gauss(rng));
      const bool outlier = unit(rng) < outlier_ratio;
      if (outlier) {
        const Vec3 d = randomUnitVector(rng);
        obs.pixel += (20.0 + 30.0 * unit(rng)) * sigma * Vec2(d.x(), d.y()).normalized();
      }
      problem.observations.push_back(obs);
      if (is_outlier) is_outlier->push_back(outlier);
    }
  }
  if (true_poses) *true_poses = truth;
  return problem;
}

}  // namespace vslam::test
