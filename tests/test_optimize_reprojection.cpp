// Analytic Jacobians and manifolds against central finite differences.
#include <random>

#include <gtest/gtest.h>

#include "optimize_synthetic.hpp"
#include "vslam/optimize/reprojection.hpp"

namespace vslam {
namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

const SE3 kPose(test::rotationAbout(Vec3(0.3, -1, 0.2), 0.7), Vec3(0.4, -0.3, 1.2));
const Vec3 kPointW(0.5, -0.4, 4.0);

ProjectionModel model() { return ProjectionModel(test::syntheticCamera(), 40.0); }

template <int kResiduals>
Eigen::VectorXd residualAt(const ceres::CostFunction& cost, const double* pose, const double* point) {
  Eigen::VectorXd r(kResiduals);
  const double* parameters[] = {pose, point};
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
  return r;
}

// Numeric Jacobian of the residual with respect to the tangent of `manifold` at the pose.
template <int kResiduals>
RowMajorMatrix numericPoseJacobian(const ceres::CostFunction& cost, const ceres::Manifold& manifold,
                                   const PoseParameters& pose, const Vec3& point) {
  const double h = 1e-6;
  RowMajorMatrix J(kResiduals, manifold.TangentSize());
  for (int i = 0; i < manifold.TangentSize(); ++i) {
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(manifold.TangentSize());
    PoseParameters plus, minus;
    delta[i] = h;
    manifold.Plus(pose.data(), delta.data(), plus.data());
    delta[i] = -h;
    manifold.Plus(pose.data(), delta.data(), minus.data());
    J.col(i) = (residualAt<kResiduals>(cost, plus.data(), point.data()) -
                residualAt<kResiduals>(cost, minus.data(), point.data())) /
               (2 * h);
  }
  return J;
}

// The Jacobian Ceres works with: ambient residual Jacobian times PlusJacobian.
template <int kResiduals>
RowMajorMatrix analyticTangentJacobian(const ceres::CostFunction& cost, const ceres::Manifold& manifold,
                                       const PoseParameters& pose, const Vec3& point, RowMajorMatrix* d_point) {
  Eigen::VectorXd r(kResiduals);
  RowMajorMatrix ambient(kResiduals, kPoseParameterSize);
  d_point->resize(kResiduals, 3);
  const double* parameters[] = {pose.data(), point.data()};
  double* jacobians[] = {ambient.data(), d_point->data()};
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  RowMajorMatrix plus_jacobian(kPoseParameterSize, manifold.TangentSize());
  manifold.PlusJacobian(pose.data(), plus_jacobian.data());
  return ambient * plus_jacobian;
}

// A rolling shutter's row motion (rolling_shutter.hpp): 1.5 degrees and 1 cm.
const SE3 kRowMotion(test::rotationAbout(Vec3(0.1, 1, -0.2), 0.026), Vec3(0.01, -0.002, 0.003));

template <int kResiduals>
void checkJacobians(const ceres::Manifold& manifold, bool with_row_motion = false) {
  const ProjectionModel m = model();
  const Vec3 p_c = kPose * kPointW;
  const Vec2 pixel = Vec2(m.fx * p_c.x() / p_c.z() + m.cx, m.fy * p_c.y() / p_c.z() + m.cy) + Vec2(3.0, -2.0);
  const double u_right = pixel.x() - m.bf / p_c.z() + 1.5;
  const ReprojectionCost<kResiduals> cost =
      with_row_motion ? ReprojectionCost<kResiduals>(m, pixel, u_right, 0.7, &kRowMotion)
                      : ReprojectionCost<kResiduals>(m, pixel, u_right, 0.7);
  const PoseParameters pose = poseToParameters(kPose);
  RowMajorMatrix d_point;
  const RowMajorMatrix d_pose = analyticTangentJacobian<kResiduals>(cost, manifold, pose, kPointW, &d_point);
  const RowMajorMatrix d_pose_numeric = numericPoseJacobian<kResiduals>(cost, manifold, pose, kPointW);
  EXPECT_LT((d_pose - d_pose_numeric).cwiseAbs().maxCoeff(), 1e-5 * d_pose.cwiseAbs().maxCoeff())
      << "analytic\n" << d_pose << "\nnumeric\n" << d_pose_numeric;

  const double h = 1e-6;
  RowMajorMatrix d_point_numeric(kResiduals, 3);
  for (int i = 0; i < 3; ++i) {
    const Vec3 step = h * Vec3::Unit(i);
    const Vec3 plus = kPointW + step, minus = kPointW - step;
    d_point_numeric.col(i) = (residualAt<kResiduals>(cost, pose.data(), plus.data()) -
                              residualAt<kResiduals>(cost, pose.data(), minus.data())) /
                             (2 * h);
  }
  EXPECT_LT((d_point - d_point_numeric).cwiseAbs().maxCoeff(), 1e-5 * d_point.cwiseAbs().maxCoeff());
}

TEST(Reprojection, MonoJacobiansMatchFiniteDifferences) { checkJacobians<2>(PoseManifold()); }
TEST(Reprojection, StereoJacobiansMatchFiniteDifferences) { checkJacobians<3>(PoseManifold()); }
TEST(Reprojection, JacobiansThroughFixedNormManifold) {
  checkJacobians<2>(PoseFixedTranslationNormManifold());
  checkJacobians<3>(PoseFixedTranslationNormManifold());
}

TEST(Reprojection, JacobiansWithARollingShuttersRowMotion) {
  checkJacobians<2>(PoseManifold(), true);
  checkJacobians<3>(PoseManifold(), true);
  checkJacobians<2>(PoseFixedTranslationNormManifold(), true);
}

// With a row motion the point is projected from row_motion * T_cw: the same
// residual as a plain cost at that pose, and as checkReprojection gives there.
TEST(Reprojection, RowMotionProjectsFromTheMovedPose) {
  const ProjectionModel m = model();
  const Vec2 pixel(300.0, 200.0);
  const ReprojectionCost<3> moved(m, pixel, 290.0, 0.5, &kRowMotion);
  const ReprojectionCost<3> plain(m, pixel, 290.0, 0.5);
  const PoseParameters pose = poseToParameters(kPose);
  const PoseParameters moved_pose = poseToParameters(kRowMotion * kPose);
  const Eigen::VectorXd r_moved = residualAt<3>(moved, pose.data(), kPointW.data());
  EXPECT_LT((r_moved - residualAt<3>(plain, moved_pose.data(), kPointW.data())).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT((r_moved - residualAt<3>(plain, pose.data(), kPointW.data())).cwiseAbs().maxCoeff(), 1.0);
  EXPECT_NEAR(r_moved.squaredNorm(), checkReprojection(m, kRowMotion * kPose, kPointW, pixel, 290.0, 0.5).chi2, 1e-9);
}

// The pose-only solver's term is BA's with the point held: the same residual,
// and the same Jacobian in the 6 tangent columns of the pose.
TEST(Reprojection, PoseOnlyResidualMatchesTheFullCost) {
  const ProjectionModel m = model();
  const Vec2 pixel(300.0, 200.0);
  const ReprojectionCost<3> full(m, pixel, 290.0, 0.5);
  const PoseParameters pose = poseToParameters(kPose);
  Eigen::Vector3d r_full;
  RowMajorMatrix J_full(3, 7), J_point(3, 3);
  const double* full_parameters[] = {pose.data(), kPointW.data()};
  double* full_jacobians[] = {J_full.data(), J_point.data()};
  ASSERT_TRUE(full.Evaluate(full_parameters, r_full.data(), full_jacobians));
  Eigen::Vector3d r_pose_only;
  Eigen::Matrix<double, 3, 6> J_pose_only;
  poseOnlyResidual<3>(m, std::sqrt(0.5), measurementVector<3>(pixel, 290.0), kPose * kPointW, r_pose_only,
                      J_pose_only);
  EXPECT_LT((r_full - r_pose_only).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((J_full.leftCols(6) - J_pose_only).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(J_pose_only.cwiseAbs().maxCoeff(), 1.0);
}

TEST(Reprojection, ResidualIsWhitenedPredictionMinusMeasurement) {
  const ProjectionModel m = model();
  const Vec3 p_c = kPose * kPointW;
  const Vec2 predicted(m.fx * p_c.x() / p_c.z() + m.cx, m.fy * p_c.y() / p_c.z() + m.cy);
  const double u_right_predicted = predicted.x() - m.bf / p_c.z();
  const ReprojectionCost<3> cost(m, predicted - Vec2(2, 1), u_right_predicted + 3, 0.25);
  const PoseParameters pose = poseToParameters(kPose);
  const Eigen::VectorXd r = residualAt<3>(cost, pose.data(), kPointW.data());
  EXPECT_NEAR(r[0], 1.0, 1e-9);
  EXPECT_NEAR(r[1], 0.5, 1e-9);
  EXPECT_NEAR(r[2], -1.5, 1e-9);
  const ReprojectionCheck check = checkReprojection(m, kPose, kPointW, predicted - Vec2(2, 1),
                                                    u_right_predicted + 3, 0.25);
  EXPECT_NEAR(check.chi2, 1.0 + 0.25 + 2.25, 1e-9);
  EXPECT_TRUE(check.depth_positive);
}

TEST(Reprojection, DepthGivesTheStereoRightCoordinate) {
  // bf = 40 px*m, depth 2 m: disparity 20 px.
  EXPECT_DOUBLE_EQ(rightCoordinateFromDepth(300.0, 2.0, 40.0), 280.0);
}

// Regression: "u_right < 0" used to mean monocular, so a stereo point whose
// right coordinate is negative (close, near the left border: u = 10, bf = 386,
// z = 5 gives u_R = -67) silently lost its third residual. Only
// kNoRightCoordinate marks a monocular observation now.
TEST(Reprojection, NegativeRightCoordinateIsStillStereo) {
  ProjectionModel m;
  m.fx = m.fy = 500;
  m.cx = 320;
  m.cy = 240;
  m.bf = 386;
  const Vec3 p_w(-3.1, 0.2, 5.0);  // identity pose: u = 500 * -3.1 / 5 + 320 = 10
  const Vec2 pixel = Vec2(10.0, 260.0);
  const double u_right = 10.0 - 386.0 / 5.0;  // -67.2
  const ReprojectionCheck exact = checkReprojection(m, SE3(), p_w, pixel, u_right, 1.0);
  EXPECT_NEAR(exact.chi2, 0.0, 1e-18);
  const ReprojectionCheck off = checkReprojection(m, SE3(), p_w, pixel, u_right - 2.0, 1.0);
  EXPECT_NEAR(off.chi2, 4.0, 1e-9);  // the right coordinate's error counts
  EXPECT_NEAR(checkReprojection(m, SE3(), p_w, pixel, kNoRightCoordinate, 1.0).chi2, 0.0, 1e-18);
  EXPECT_FALSE(hasRightCoordinate(kNoRightCoordinate));
  EXPECT_TRUE(hasRightCoordinate(u_right));
}

// Regression: behind the camera the residual used to be zero with a zero
// Jacobian, so the cost fell off a cliff when a point crossed the image plane.
// Now a point behind costs more than one in front that projects anywhere in
// the image, more the further behind it is, and the point Jacobian (bounded,
// pointing forward) matches finite differences there.
TEST(Reprojection, PointBehindCameraCostsMoreTheFurtherBehind) {
  const ReprojectionCost<2> cost(model(), Vec2(320, 240), -1, 1.0);
  const PoseParameters pose = poseToParameters(SE3());
  auto cost_at = [&](const Vec3& p) { return residualAt<2>(cost, pose.data(), p.data()).squaredNorm(); };
  const double in_front = cost_at(Vec3(0.1, 0.2, 3.0));
  const double image_corner = cost_at(Vec3(-320.0 / 500.0, -240.0 / 500.0, 1.0));  // measured at the centre
  const double just_behind = cost_at(Vec3(0.1, 0.2, -0.5));
  const double far_behind = cost_at(Vec3(0.1, 0.2, -3.0));
  EXPECT_GT(just_behind, in_front);
  EXPECT_GT(just_behind, image_corner);
  EXPECT_GT(far_behind, just_behind);

  const Vec3 behind(0.1, 0.2, -3.0);
  Eigen::Vector2d r;
  RowMajorMatrix d_pose(2, 7), d_point(2, 3);
  const double* parameters[] = {pose.data(), behind.data()};
  double* jacobians[] = {d_pose.data(), d_point.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  EXPECT_GT(d_point.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(d_pose.cwiseAbs().maxCoeff(), 0.0);
  const double h = 1e-3;
  for (int k = 0; k < 3; ++k) {
    Vec3 plus = behind, minus = behind;
    plus[k] += h;
    minus[k] -= h;
    const Eigen::VectorXd numeric =
        (residualAt<2>(cost, pose.data(), plus.data()) - residualAt<2>(cost, pose.data(), minus.data())) / (2 * h);
    for (int i = 0; i < 2; ++i)
      EXPECT_NEAR(d_point(i, k), numeric[i], 1e-6 * std::max(1.0, std::abs(numeric[i]))) << i << "," << k;
  }
  EXPECT_FALSE(checkReprojection(model(), SE3(), behind, Vec2(320, 240), -1, 1.0).depth_positive);
}

TEST(Reprojection, ManifoldMinusInvertsPlus) {
  const PoseParameters x = poseToParameters(kPose);
  const double delta6[] = {0.01, -0.02, 0.03, 0.05, -0.01, 0.02};
  PoseParameters y;
  double back[6];
  const PoseManifold manifold;
  manifold.Plus(x.data(), delta6, y.data());
  ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back));
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(back[i], delta6[i], 1e-12);

  const PoseFixedTranslationNormManifold fixed_norm;
  const double delta5[] = {0.01, -0.02, 0.03, 0.05, -0.01};
  fixed_norm.Plus(x.data(), delta5, y.data());
  EXPECT_NEAR(Vec3(y[4], y[5], y[6]).norm(), kPose.t.norm(), 1e-14);
  ASSERT_TRUE(fixed_norm.Minus(y.data(), x.data(), back));
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(back[i], delta5[i], 1e-12);
}

TEST(Reprojection, PoseParametersRoundTrip) {
  const SE3 back = poseFromParameters(poseToParameters(kPose).data());
  EXPECT_LT((back.R - kPose.R).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(back.t, kPose.t);
}

}  // namespace
}  // namespace vslam
