#pragma once
// Internal to src/optimize: a similarity as Ceres parameter blocks.
#include <array>
#include <cmath>

#include <Eigen/Geometry>

#include "vslam/core/types.hpp"

namespace vslam {

// Three blocks: unit quaternion (Eigen order x, y, z, w; for
// ceres::EigenQuaternionManifold), translation, and log(scale), which keeps
// the scale positive and can be held constant on its own.
struct Sim3Parameters {
  std::array<double, 4> q;
  std::array<double, 3> t;
  double log_scale;

  explicit Sim3Parameters(const Sim3& S) {
    const Quat rotation = Quat(S.R).normalized();
    q = {rotation.x(), rotation.y(), rotation.z(), rotation.w()};
    t = {S.t.x(), S.t.y(), S.t.z()};
    log_scale = std::log(S.s);
  }

  Sim3 toSim3() const {
    const Quat rotation = Eigen::Map<const Quat>(q.data()).normalized();
    return Sim3(std::exp(log_scale), rotation.toRotationMatrix(), Vec3(t[0], t[1], t[2]));
  }
};

// 2 * vec(q), with the sign chosen so that w >= 0 (q and -q are the same
// rotation): a rotation residual that is zero exactly at the identity.
template <typename T>
void writeRotationError(const Eigen::Quaternion<T>& q, T* residual) {
  const T sign = q.w() < T(0) ? T(-2) : T(2);
  residual[0] = sign * q.x();
  residual[1] = sign * q.y();
  residual[2] = sign * q.z();
}

}  // namespace vslam
