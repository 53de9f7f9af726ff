#include "vslam/geometry/two_view_initializer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "vslam/geometry/triangulation.hpp"

namespace vslam {
namespace {

// Chi-square 95 % quantiles: 1 dof for the distance to an epipolar line, 2 dof
// for a point-to-point transfer error. F is scored against the 2-dof value too,
// so that the two scores are on the same scale (ORB-SLAM's idea).
constexpr double kChi2_1dof = 3.841;
constexpr double kChi2_2dof = 5.991;
constexpr int kMinimalSetSize = 8;
// Least-squares re-fits of the best RANSAC model on its own inliers.
constexpr int kRefinementRounds = 2;

double toDeg(double rad) { return rad * 180.0 / M_PI; }
double toRad(double deg) { return deg * M_PI / 180.0; }

// Hartley normalisation: centroid to the origin, mean distance sqrt(2).
Mat3 normalisingTransform(const std::vector<Vec2>& points) {
  Vec2 centroid = Vec2::Zero();
  for (const Vec2& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  double mean_distance = 0;
  for (const Vec2& p : points) mean_distance += (p - centroid).norm();
  mean_distance /= static_cast<double>(points.size());
  const double scale = mean_distance > 0 ? std::sqrt(2.0) / mean_distance : 1.0;
  Mat3 T;
  T << scale, 0, -scale * centroid.x(), 0, scale, -scale * centroid.y(), 0, 0, 1;
  return T;
}

std::vector<Vec2> transformPoints(const Mat3& T, const std::vector<Vec2>& points) {
  std::vector<Vec2> out;
  out.reserve(points.size());
  for (const Vec2& p : points) out.push_back((T * p.homogeneous()).hnormalized());
  return out;
}

// Right null vector of A (the singular vector of the smallest singular value).
Eigen::Matrix<double, 9, 1> nullVector(const Eigen::Matrix<double, Eigen::Dynamic, 9>& A) {
  const Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 9>> svd(A, Eigen::ComputeFullV);
  return svd.matrixV().col(8);
}

Mat3 reshapeRowMajor(const Eigen::Matrix<double, 9, 1>& v) {
  Mat3 M;
  M << v(0), v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8);
  return M;
}

// Sum of (threshold - chi2) over the accepted errors; a match is an inlier
// when it is accepted in both images.
struct ModelScore {
  double score = 0;
  int n_inliers = 0;
  std::vector<bool> inliers;
};

struct Matches {
  const std::vector<Vec2>& ref;
  const std::vector<Vec2>& cur;
  std::vector<double> inv_sigma2_ref;
  std::vector<double> inv_sigma2_cur;
  size_t size() const { return ref.size(); }
};

ModelScore scoreHomography(const Mat3& H_cur_ref, const Matches& m) {
  ModelScore result;
  result.inliers.assign(m.size(), false);
  const Eigen::FullPivLU<Mat3> lu(H_cur_ref);
  if (!lu.isInvertible()) return result;
  const Mat3 H_ref_cur = lu.inverse();
  for (size_t i = 0; i < m.size(); ++i) {
    bool inlier = true;
    const Vec3 to_cur = H_cur_ref * m.ref[i].homogeneous();
    const double chi2_cur = (m.cur[i] - to_cur.hnormalized()).squaredNorm() * m.inv_sigma2_cur[i];
    if (chi2_cur < kChi2_2dof && std::isfinite(chi2_cur)) {
      result.score += kChi2_2dof - chi2_cur;
    } else {
      inlier = false;
    }
    const Vec3 to_ref = H_ref_cur * m.cur[i].homogeneous();
    const double chi2_ref = (m.ref[i] - to_ref.hnormalized()).squaredNorm() * m.inv_sigma2_ref[i];
    if (chi2_ref < kChi2_2dof && std::isfinite(chi2_ref)) {
      result.score += kChi2_2dof - chi2_ref;
    } else {
      inlier = false;
    }
    result.inliers[i] = inlier;
    result.n_inliers += inlier;
  }
  return result;
}

// Squared distance of `point` to the line l (a x + b y + c = 0).
double squaredLineDistance(const Vec3& line, const Vec2& point) {
  const double numerator = line.x() * point.x() + line.y() * point.y() + line.z();
  const double norm2 = line.x() * line.x() + line.y() * line.y();
  return norm2 > 0 ? numerator * numerator / norm2 : std::numeric_limits<double>::infinity();
}

ModelScore scoreFundamental(const Mat3& F_cur_ref, const Matches& m) {
  ModelScore result;
  result.inliers.assign(m.size(), false);
  for (size_t i = 0; i < m.size(); ++i) {
    bool inlier = true;
    const Vec3 line_cur = F_cur_ref * m.ref[i].homogeneous();
    const double chi2_cur = squaredLineDistance(line_cur, m.cur[i]) * m.inv_sigma2_cur[i];
    if (chi2_cur < kChi2_1dof) {
      result.score += kChi2_2dof - chi2_cur;
    } else {
      inlier = false;
    }
    const Vec3 line_ref = F_cur_ref.transpose() * m.cur[i].homogeneous();
    const double chi2_ref = squaredLineDistance(line_ref, m.ref[i]) * m.inv_sigma2_ref[i];
    if (chi2_ref < kChi2_1dof) {
      result.score += kChi2_2dof - chi2_ref;
    } else {
      inlier = false;
    }
    result.inliers[i] = inlier;
    result.n_inliers += inlier;
  }
  return result;
}

// `iterations` sets of 8 distinct indices in [0, n), drawn by partial
// Fisher-Yates. Plain modulo on mt19937 output (bias ~n/2^32) keeps the draw
// identical on every standard library, unlike std::uniform_int_distribution.
std::vector<std::array<int, kMinimalSetSize>> drawMinimalSets(int n, int iterations, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<int> pool(n);
  std::vector<std::array<int, kMinimalSetSize>> sets(iterations);
  for (auto& set : sets) {
    std::iota(pool.begin(), pool.end(), 0);
    for (int k = 0; k < kMinimalSetSize; ++k) {
      const int pick = k + static_cast<int>(rng() % static_cast<uint32_t>(n - k));
      std::swap(pool[k], pool[pick]);
      set[k] = pool[k];
    }
  }
  return sets;
}

template <typename Estimate, typename Score>
std::pair<Mat3, ModelScore> ransac(const Matches& m, const std::vector<std::array<int, kMinimalSetSize>>& sets,
                                   Estimate estimate, Score score) {
  Mat3 best_model = Mat3::Zero();
  ModelScore best;
  best.inliers.assign(m.size(), false);
  std::vector<Vec2> sample_ref(kMinimalSetSize), sample_cur(kMinimalSetSize);
  for (const auto& set : sets) {
    for (int k = 0; k < kMinimalSetSize; ++k) {
      sample_ref[k] = m.ref[set[k]];
      sample_cur[k] = m.cur[set[k]];
    }
    const Mat3 model = estimate(sample_ref, sample_cur);
    if (!model.allFinite()) continue;
    ModelScore candidate = score(model, m);
    if (candidate.score > best.score) {
      best = std::move(candidate);
      best_model = model;
    }
  }
  // Local optimisation: the least-squares fit on all inliers is more accurate
  // than the best minimal one; keep it only while it scores better.
  for (int round = 0; round < kRefinementRounds && best.n_inliers >= kMinimalSetSize; ++round) {
    std::vector<Vec2> inlier_ref, inlier_cur;
    for (size_t i = 0; i < m.size(); ++i) {
      if (!best.inliers[i]) continue;
      inlier_ref.push_back(m.ref[i]);
      inlier_cur.push_back(m.cur[i]);
    }
    const Mat3 model = estimate(inlier_ref, inlier_cur);
    if (!model.allFinite()) break;
    ModelScore candidate = score(model, m);
    if (candidate.score <= best.score) break;
    best = std::move(candidate);
    best_model = model;
  }
  return {best_model, std::move(best)};
}

// Sampson distance (pixels, divided by sigma) of a match to the epipolar
// geometry of the motion (rotation as angle-axis, unit translation).
struct SampsonResidual {
  SampsonResidual(const Vec3& ray_ref, const Vec3& ray_cur, const Mat3& K, double inv_sigma)
      : ray_ref(ray_ref), ray_cur(ray_cur), K(K), inv_sigma(inv_sigma) {}

  template <typename T>
  bool operator()(const T* angle_axis, const T* translation, T* residual) const {
    // E = [t]x R on normalised rays; the gradients are taken in pixels (through
    // K) so that the residual has the unit of the thresholds.
    T R[9];
    ceres::AngleAxisToRotationMatrix(angle_axis, ceres::RowMajorAdapter3x3(R));
    Eigen::Matrix<T, 3, 3> rotation;
    rotation << R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8];
    Eigen::Matrix<T, 3, 3> t_cross;
    t_cross << T(0), -translation[2], translation[1], translation[2], T(0), -translation[0], -translation[1],
        translation[0], T(0);
    const Eigen::Matrix<T, 3, 3> K_inv = K.inverse().cast<T>();
    const Eigen::Matrix<T, 3, 3> F = K_inv.transpose() * t_cross * rotation * K_inv;
    const Eigen::Matrix<T, 3, 1> x_ref = (K * ray_ref).cast<T>();
    const Eigen::Matrix<T, 3, 1> x_cur = (K * ray_cur).cast<T>();
    const Eigen::Matrix<T, 3, 1> line_cur = F * x_ref;
    const Eigen::Matrix<T, 3, 1> line_ref = F.transpose() * x_cur;
    const T algebraic = x_cur.dot(line_cur);
    const T gradient2 = line_cur(0) * line_cur(0) + line_cur(1) * line_cur(1) + line_ref(0) * line_ref(0) +
                        line_ref(1) * line_ref(1);
    residual[0] = T(inv_sigma) * algebraic / sqrt(gradient2 + T(1e-300));
    return true;
  }

  Vec3 ray_ref, ray_cur;
  Mat3 K;
  double inv_sigma;
};

// Gauss-Newton on the Sampson distances of the given matches: the linear
// 8-point/DLT estimates minimise an algebraic error, this minimises (to first
// order) the geometric one, over the 5 degrees of freedom of a calibrated
// motion. Huber-robust at the F inlier bound.
// A calibrated motion as Ceres parameters (angle-axis rotation, unit
// translation on the sphere) with one Sampson residual per used match.
struct SampsonProblem {
  double angle_axis[3];
  double translation[3];
  ceres::Problem problem;
  int n_used = 0;

  // `robust`: Huber at the F inlier bound, for solving; plain squares for a covariance.
  SampsonProblem(const SE3& motion, const Mat3& K, const Matches& m, const std::vector<bool>& use, bool robust)
      : translation{motion.t.x(), motion.t.y(), motion.t.z()} {
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R_row = motion.R;
    ceres::RotationMatrixToAngleAxis(ceres::RowMajorAdapter3x3(R_row.data()), angle_axis);
    const Mat3 K_inv = K.inverse();
    for (size_t i = 0; i < m.size(); ++i) {
      if (!use[i]) continue;
      const double inv_sigma = std::sqrt(std::min(m.inv_sigma2_ref[i], m.inv_sigma2_cur[i]));
      auto* cost = new ceres::AutoDiffCostFunction<SampsonResidual, 1, 3, 3>(
          new SampsonResidual(K_inv * m.ref[i].homogeneous(), K_inv * m.cur[i].homogeneous(), K, inv_sigma));
      problem.AddResidualBlock(cost, robust ? new ceres::HuberLoss(std::sqrt(kChi2_1dof)) : nullptr, angle_axis,
                               translation);
      ++n_used;
    }
    // The sphere needs a translation of length > 0; callers check usable() first.
    if (usable(motion)) problem.SetManifold(translation, new ceres::SphereManifold<3>());
  }
  bool usable(const SE3& motion) const { return n_used >= kMinimalSetSize && motion.t.norm() > 0; }
};

SE3 refineMotion(const SE3& initial, const Mat3& K, const Matches& m, const std::vector<bool>& use) {
  SampsonProblem sampson(initial, K, m, use, true);
  if (!sampson.usable(initial)) return initial;
  ceres::Solver::Options options;
  options.max_num_iterations = 20;
  options.linear_solver_type = ceres::DENSE_QR;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &sampson.problem, &summary);
  if (!summary.IsSolutionUsable()) return initial;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R_refined;
  ceres::AngleAxisToRotationMatrix(sampson.angle_axis, ceres::RowMajorAdapter3x3(R_refined.data()));
  const Vec3 t_refined(sampson.translation[0], sampson.translation[1], sampson.translation[2]);
  if (!R_refined.allFinite() || !t_refined.allFinite()) return initial;
  return SE3(R_refined, t_refined.normalized());
}

// First-order standard deviation (degrees) of the translation direction of
// `motion`: the largest axis of its covariance from the Sampson residuals of
// the used matches (each scaled by its sigma), with the rotation
// marginalised. +inf when the direction is not constrained at all.
double translationDirectionStdDeg(const SE3& motion, const Mat3& K, const Matches& m, const std::vector<bool>& use) {
  SampsonProblem sampson(motion, K, m, use, false);
  if (!sampson.usable(motion)) return std::numeric_limits<double>::infinity();
  ceres::Covariance::Options options;
  options.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(options);
  const double* translation = sampson.translation;
  const std::vector<std::pair<const double*, const double*>> blocks = {{translation, translation}};
  if (!covariance.Compute(blocks, &sampson.problem)) return std::numeric_limits<double>::infinity();
  Mat3 cov;  // Ceres writes it row-major; symmetric, so the storage order does not matter
  covariance.GetCovarianceBlock(translation, translation, cov.data());
  const Eigen::SelfAdjointEigenSolver<Mat3> eigen(cov);
  return toDeg(std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff())));
}

// Triangulation of the inlier matches under one motion hypothesis.
struct MotionCheck {
  SE3 T_cur_ref;
  int n_good = 0;
  std::vector<Vec3> points;          // per match, zero where triangulation failed
  std::vector<bool> good;            // per match
  std::vector<double> good_parallax_deg;
  std::vector<double> consistent_parallax_deg;  // all points that reproject, whatever their parallax
};

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

MotionCheck checkMotion(const SE3& T_cur_ref, const Mat3& K, const Matches& m, const std::vector<bool>& inliers,
                        double min_point_parallax_cos) {
  MotionCheck check;
  check.T_cur_ref = T_cur_ref;
  check.points.assign(m.size(), Vec3::Zero());
  check.good.assign(m.size(), false);
  const Mat34 P_ref = projectionMatrix(K, SE3::identity());
  const Mat34 P_cur = projectionMatrix(K, T_cur_ref);
  const Vec3 center_ref = Vec3::Zero();
  const Vec3 center_cur = T_cur_ref.inverse().t;
  for (size_t i = 0; i < m.size(); ++i) {
    if (!inliers[i]) continue;
    Vec3 X;
    if (!triangulateDlt(P_ref, P_cur, m.ref[i], m.cur[i], X)) continue;
    check.points[i] = X;
    const Vec3 X_cur = T_cur_ref * X;
    const double cos_parallax = parallaxCos(X, center_ref, center_cur);
    const bool enough_parallax = cos_parallax < min_point_parallax_cos;
    // Depth sign is only meaningful with parallax: nearly parallel rays meet
    // behind the cameras as easily as in front of them.
    const bool in_front = X.z() > 0 && X_cur.z() > 0;
    if (enough_parallax && !in_front) continue;
    // Reprojection of a point at negative depth: use |z| so that low-parallax
    // points are still judged by how well their ray fits.
    const Vec3 X_ref_abs(X.x(), X.y(), std::abs(X.z()));
    const Vec3 X_cur_abs(X_cur.x(), X_cur.y(), std::abs(X_cur.z()));
    if (reprojectionError2(K, X_ref_abs, m.ref[i]) * m.inv_sigma2_ref[i] > kChi2_2dof) continue;
    if (reprojectionError2(K, X_cur_abs, m.cur[i]) * m.inv_sigma2_cur[i] > kChi2_2dof) continue;
    const double parallax_deg = toDeg(std::acos(cos_parallax));
    check.consistent_parallax_deg.push_back(parallax_deg);
    if (!enough_parallax) continue;
    check.good[i] = true;
    ++check.n_good;
    check.good_parallax_deg.push_back(parallax_deg);
  }
  return check;
}

std::string formatDeg(double value) {
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

}  // namespace

Mat3 computeHomography(const std::vector<Vec2>& p1, const std::vector<Vec2>& p2) {
  const Mat3 T1 = normalisingTransform(p1);
  const Mat3 T2 = normalisingTransform(p2);
  const std::vector<Vec2> n1 = transformPoints(T1, p1);
  const std::vector<Vec2> n2 = transformPoints(T2, p2);
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(2 * n1.size(), 9);
  for (size_t i = 0; i < n1.size(); ++i) {
    const double x = n1[i].x(), y = n1[i].y(), u = n2[i].x(), v = n2[i].y();
    A.row(2 * i) << 0, 0, 0, -x, -y, -1, v * x, v * y, v;
    A.row(2 * i + 1) << x, y, 1, 0, 0, 0, -u * x, -u * y, -u;
  }
  const Mat3 H_normalised = reshapeRowMajor(nullVector(A));
  const Mat3 H = T2.inverse() * H_normalised * T1;
  return H / H.norm();
}

Mat3 computeFundamental(const std::vector<Vec2>& p1, const std::vector<Vec2>& p2) {
  const Mat3 T1 = normalisingTransform(p1);
  const Mat3 T2 = normalisingTransform(p2);
  const std::vector<Vec2> n1 = transformPoints(T1, p1);
  const std::vector<Vec2> n2 = transformPoints(T2, p2);
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(n1.size(), 9);
  for (size_t i = 0; i < n1.size(); ++i) {
    const double x = n1[i].x(), y = n1[i].y(), u = n2[i].x(), v = n2[i].y();
    A.row(i) << u * x, u * y, u, v * x, v * y, v, x, y, 1;
  }
  const Mat3 F_full_rank = reshapeRowMajor(nullVector(A));
  // A fundamental matrix has rank 2: drop the smallest singular value.
  const Eigen::JacobiSVD<Mat3> svd(F_full_rank, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Vec3 singular = svd.singularValues();
  singular(2) = 0;
  const Mat3 F_normalised = svd.matrixU() * singular.asDiagonal() * svd.matrixV().transpose();
  const Mat3 F = T2.transpose() * F_normalised * T1;
  return F / F.norm();
}

Mat3 nearestCalibratedFundamental(const Mat3& F, const Mat3& K) {
  const Mat3 E = K.transpose() * F * K;
  const Eigen::JacobiSVD<Mat3> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 essential_singular(1, 1, 0);
  const Mat3 E_projected = svd.matrixU() * essential_singular.asDiagonal() * svd.matrixV().transpose();
  const Mat3 K_inv = K.inverse();
  const Mat3 F_calibrated = K_inv.transpose() * E_projected * K_inv;
  return F_calibrated / F_calibrated.norm();
}

std::vector<SE3> motionsFromEssential(const Mat3& E) {
  const Eigen::JacobiSVD<Mat3> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  Mat3 V = svd.matrixV();
  // E is defined up to sign, so U and V may be flipped to make them rotations.
  if (U.determinant() < 0) U = -U;
  if (V.determinant() < 0) V = -V;
  Mat3 W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Mat3 R1 = U * W * V.transpose();
  const Mat3 R2 = U * W.transpose() * V.transpose();
  const Vec3 t = U.col(2).normalized();
  return {SE3(R1, t), SE3(R1, -t), SE3(R2, t), SE3(R2, -t)};
}

std::vector<SE3> motionsFromHomography(const Mat3& H, const Mat3& K) {
  cv::Mat H_cv, K_cv;
  cv::eigen2cv(H, H_cv);
  cv::eigen2cv(K, K_cv);
  std::vector<cv::Mat> rotations, translations, normals;
  cv::decomposeHomographyMat(H_cv, K_cv, rotations, translations, normals);
  std::vector<SE3> motions;
  for (size_t k = 0; k < rotations.size(); ++k) {
    Mat3 R;
    Vec3 t;
    cv::cv2eigen(rotations[k], R);
    cv::cv2eigen(translations[k], t);
    // Pure rotation gives t = 0; keep it, the parallax check rejects it later.
    const double norm = t.norm();
    motions.emplace_back(R, norm > 0 ? Vec3(t / norm) : t);
  }
  return motions;
}

double medianDepth(const std::vector<Vec3>& points, const std::vector<bool>& use) {
  std::vector<double> depths;
  for (size_t i = 0; i < points.size(); ++i) {
    if (use.empty() || use[i]) depths.push_back(points[i].z());
  }
  return median(depths);
}

TwoViewInitializer::TwoViewInitializer(const Mat3& K, const InitializerParams& params, uint32_t seed)
    : K_(K), params_(params), seed_(seed) {}

TwoViewResult TwoViewInitializer::initialize(const std::vector<Vec2>& pts_ref,
                                             const std::vector<Vec2>& pts_cur) const {
  return initialize(pts_ref, pts_cur, {}, {});
}

TwoViewResult TwoViewInitializer::initialize(const std::vector<Vec2>& pts_ref, const std::vector<Vec2>& pts_cur,
                                             const std::vector<double>& sigma2_ref,
                                             const std::vector<double>& sigma2_cur) const {
  TwoViewResult result;
  const int n = static_cast<int>(pts_ref.size());
  const int min_matches = std::max(kMinimalSetSize, params_.min_matches);
  if (pts_cur.size() != pts_ref.size() || (!sigma2_ref.empty() && sigma2_ref.size() != pts_ref.size()) ||
      (!sigma2_cur.empty() && sigma2_cur.size() != pts_cur.size())) {
    result.failure_reason = "inconsistent input sizes";
    return result;
  }
  if (n < min_matches) {
    result.failure_reason = "too few matches (" + std::to_string(n) + " < " + std::to_string(min_matches) + ")";
    return result;
  }

  const double default_inv_sigma2 = 1.0 / (params_.sigma_px * params_.sigma_px);
  Matches matches{pts_ref, pts_cur, {}, {}};
  matches.inv_sigma2_ref.assign(n, default_inv_sigma2);
  matches.inv_sigma2_cur.assign(n, default_inv_sigma2);
  for (int i = 0; i < n; ++i) {
    if (!sigma2_ref.empty()) matches.inv_sigma2_ref[i] = 1.0 / sigma2_ref[i];
    if (!sigma2_cur.empty()) matches.inv_sigma2_cur[i] = 1.0 / sigma2_cur[i];
  }

  // The same minimal sets for both models, so that neither is luckier.
  const auto sets = drawMinimalSets(n, std::max(1, params_.ransac_iterations), seed_);
  auto [H, score_h] = ransac(matches, sets, computeHomography, scoreHomography);
  const Mat3 K = K_;
  const bool calibrated = params_.score_calibrated_f;
  const auto estimate_f = [&K, calibrated](const std::vector<Vec2>& ref, const std::vector<Vec2>& cur) {
    // Score F as the calibrated motion it implies: on near-planar scenes the
    // 8-point F is poorly constrained and its free directions fit noise, so
    // that raw F wins inliers that no camera motion explains.
    const Mat3 F = computeFundamental(ref, cur);
    return calibrated ? nearestCalibratedFundamental(F, K) : F;
  };
  auto [F, score_f] = ransac(matches, sets, estimate_f, scoreFundamental);
  result.score_h = score_h.score;
  result.score_f = score_f.score;
  if (score_h.score + score_f.score <= 0) {
    result.failure_reason = "neither a homography nor a fundamental matrix has any inlier";
    return result;
  }
  result.score_ratio = score_h.score / (score_h.score + score_f.score);
  result.used_homography = result.score_ratio > params_.homography_ratio;
  const ModelScore& chosen = result.used_homography ? score_h : score_f;
  result.model_inliers = chosen.inliers;
  result.n_model_inliers = chosen.n_inliers;

  const std::vector<SE3> hypotheses =
      result.used_homography ? motionsFromHomography(H, K_) : motionsFromEssential(K_.transpose() * F * K_);
  const double min_point_parallax_cos = std::cos(toRad(params_.min_point_parallax_deg));
  std::vector<MotionCheck> checks;
  for (const SE3& T : hypotheses) checks.push_back(checkMotion(T, K_, matches, chosen.inliers, min_point_parallax_cos));
  if (checks.empty()) {
    result.failure_reason = "homography decomposition gave no motion";
    return result;
  }
  // The hypothesis with the most good points; ties go to the first (fixed order).
  std::stable_sort(checks.begin(), checks.end(),
                   [](const MotionCheck& a, const MotionCheck& b) { return a.n_good > b.n_good; });
  MotionCheck& best = checks.front();
  // Polish the winner on the points it explains and keep the result if it
  // explains at least as many.
  if (params_.refine_motion && best.n_good >= kMinimalSetSize) {
    std::vector<bool> explained = best.good;
    const SE3 refined = refineMotion(best.T_cur_ref, K_, matches, explained);
    MotionCheck refined_check = checkMotion(refined, K_, matches, chosen.inliers, min_point_parallax_cos);
    if (refined_check.n_good >= best.n_good) best = std::move(refined_check);
  }
  const int second_good = checks.size() > 1 ? checks[1].n_good : 0;
  result.translation_direction_std_deg = translationDirectionStdDeg(best.T_cur_ref, K_, matches, best.good);

  result.T_cur_ref = best.T_cur_ref;
  result.points_ref = best.points;
  result.triangulated = best.good;
  result.n_triangulated = best.n_good;
  result.median_parallax_deg = median(best.good_parallax_deg);

  const std::string model_name = result.used_homography ? "H" : "F";
  if (best.n_good < params_.min_triangulated) {
    const double consistent_parallax = median(best.consistent_parallax_deg);
    if (consistent_parallax < params_.min_parallax_deg) {
      result.failure_reason = "insufficient parallax (median " + formatDeg(consistent_parallax) + " deg over " +
                              std::to_string(best.consistent_parallax_deg.size()) + " points < " +
                              formatDeg(params_.min_parallax_deg) + " deg)";
    } else {
      result.failure_reason = "too few triangulated points from " + model_name + " (" + std::to_string(best.n_good) +
                              " < " + std::to_string(params_.min_triangulated) + ")";
    }
    return result;
  }
  if (result.median_parallax_deg < params_.min_parallax_deg) {
    result.failure_reason = "insufficient parallax (median " + formatDeg(result.median_parallax_deg) + " deg < " +
                            formatDeg(params_.min_parallax_deg) + " deg)";
    return result;
  }
  // The motion must explain (nearly) all of its model's inliers; a wrong F or
  // H decomposition leaves many of them behind a camera or off their rays.
  const int n_consistent = static_cast<int>(best.consistent_parallax_deg.size());
  if (n_consistent < params_.min_consistent_fraction * result.n_model_inliers) {
    result.failure_reason = "motion from " + model_name + " explains only " + std::to_string(n_consistent) + " of " +
                            std::to_string(result.n_model_inliers) + " inliers";
    return result;
  }
  if (second_good > params_.max_second_best_ratio * best.n_good) {
    result.failure_reason = "ambiguous motion from " + model_name + " (runner-up triangulates " +
                            std::to_string(second_good) + " of the best's " + std::to_string(best.n_good) + ")";
    return result;
  }
  // A short baseline under rotation leaves F's translation direction barely
  // determined; the best of several nearly equal motions can then be far from
  // the true one (docs/GEOMETRY.md). Wait for a longer baseline instead.
  if (!result.used_homography && result.translation_direction_std_deg > params_.max_translation_direction_std_deg) {
    result.failure_reason = "translation direction from F uncertain (standard deviation " +
                            formatDeg(result.translation_direction_std_deg) + " deg > " +
                            formatDeg(params_.max_translation_direction_std_deg) + " deg)";
    return result;
  }
  result.success = true;
  return result;
}

}  // namespace vslam
