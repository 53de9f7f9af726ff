#pragma once
// Two-view triangulation and the checks that decide whether a triangulated
// point can be trusted.
#include <Eigen/Core>

#include "vslam/core/types.hpp"

namespace vslam {

using Mat34 = Eigen::Matrix<double, 3, 4>;

// Projection matrix P = K [R | t] of a camera with pose T_cw.
Mat34 projectionMatrix(const Mat3& K, const SE3& T_cw);

// Linear (DLT) triangulation: the 3D point X with x1 ~ P1 X and x2 ~ P2 X, as
// the null vector of the stacked 4x4 system (SVD). x1, x2 must be in the
// coordinates P1, P2 map to (pixels for K[R|t], normalised for [R|t]).
// Returns false when the solution is at infinity (|w| < 1e-12 |X|, parallel
// rays) or not finite; X is then left unspecified.
bool triangulateDlt(const Mat34& P1, const Mat34& P2, const Vec2& x1, const Vec2& x2, Vec3& X);

// Cosine of the angle at X between the rays towards the two camera centres.
double parallaxCos(const Vec3& X, const Vec3& center1, const Vec3& center2);
// The same angle in degrees.
double parallaxDeg(const Vec3& X, const Vec3& center1, const Vec3& center2);

// Squared pixel distance between `px` and the projection of X (camera frame);
// infinity when X is not in front of the camera.
double reprojectionError2(const Mat3& K, const Vec3& X_c, const Vec2& px);

// The chi-square 95 % quantile for 2 degrees of freedom, the usual bound on a
// squared reprojection error divided by sigma^2.
constexpr double kChi2_2dof_95 = 5.991;

// A triangulated point is good when it lies in front of both cameras, projects
// within chi2 < 5.991 * sigma^2 of each observation, and the rays meet at an
// angle whose cosine is below `min_parallax_cos` (i.e. the angle is larger).
bool isGoodTriangulation(const Vec3& X_world, const SE3& T_c1w, const SE3& T_c2w, const Mat3& K, const Vec2& px1,
                         const Vec2& px2, double sigma2_1, double sigma2_2, double min_parallax_cos);

}  // namespace vslam
