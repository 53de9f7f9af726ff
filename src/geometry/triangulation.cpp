#include "vslam/geometry/triangulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/SVD>

namespace vslam {

Mat34 projectionMatrix(const Mat3& K, const SE3& T_cw) {
  Mat34 Rt;
  Rt.leftCols<3>() = T_cw.R;
  Rt.col(3) = T_cw.t;
  return K * Rt;
}

bool triangulateDlt(const Mat34& P1, const Mat34& P2, const Vec2& x1, const Vec2& x2, Vec3& X) {
  // Each observation gives two rows of A X = 0 (the cross product x ^ P X).
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  // Unit rows: pixel rows are ~500x larger than the others, and equal weights
  // improve the conditioning without changing the exact solution.
  for (int r = 0; r < 4; ++r) {
    const double norm = A.row(r).norm();
    if (norm > 0) A.row(r) /= norm;
  }
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Vec4 Xh = svd.matrixV().col(3);
  // Parallel rays give Xh(3) = 0 up to rounding (~1e-16); 1e-12 is a point
  // 1e12 units away, which no image pair can locate.
  if (std::abs(Xh(3)) <= 1e-12 * Xh.head<3>().norm()) return false;
  X = Xh.head<3>() / Xh(3);
  return X.allFinite();
}

double parallaxCos(const Vec3& X, const Vec3& center1, const Vec3& center2) {
  const Vec3 ray1 = X - center1;
  const Vec3 ray2 = X - center2;
  const double norms = ray1.norm() * ray2.norm();
  if (norms <= 0) return 1.0;
  return std::clamp(ray1.dot(ray2) / norms, -1.0, 1.0);
}

double parallaxDeg(const Vec3& X, const Vec3& center1, const Vec3& center2) {
  return std::acos(parallaxCos(X, center1, center2)) * 180.0 / M_PI;
}

double reprojectionError2(const Mat3& K, const Vec3& X_c, const Vec2& px) {
  if (!(X_c.z() > 0)) return std::numeric_limits<double>::infinity();
  const Vec3 projected = K * X_c;
  return (projected.head<2>() / projected.z() - px).squaredNorm();
}

bool isGoodTriangulation(const Vec3& X_world, const SE3& T_c1w, const SE3& T_c2w, const Mat3& K, const Vec2& px1,
                         const Vec2& px2, double sigma2_1, double sigma2_2, double min_parallax_cos) {
  if (!X_world.allFinite()) return false;
  const Vec3 X_c1 = T_c1w * X_world;
  const Vec3 X_c2 = T_c2w * X_world;
  if (!(X_c1.z() > 0) || !(X_c2.z() > 0)) return false;
  if (reprojectionError2(K, X_c1, px1) > kChi2_2dof_95 * sigma2_1) return false;
  if (reprojectionError2(K, X_c2, px2) > kChi2_2dof_95 * sigma2_2) return false;
  const Vec3 center1 = T_c1w.inverse().t;
  const Vec3 center2 = T_c2w.inverse().t;
  return parallaxCos(X_world, center1, center2) < min_parallax_cos;
}

}  // namespace vslam
