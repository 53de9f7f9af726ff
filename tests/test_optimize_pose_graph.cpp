#include <random>

#include <gtest/gtest.h>

#include "optimize_synthetic.hpp"
#include "vslam/optimize/pose_graph.hpp"

namespace vslam {
namespace {

void expectSim3Near(const Sim3& actual, const Sim3& expected, double tolerance, const std::string& what = "") {
  EXPECT_NEAR(actual.s, expected.s, tolerance) << what;
  EXPECT_LT(test::rotationDifference(actual.R, expected.R), tolerance) << what;
  EXPECT_LT((actual.t - expected.t).norm(), tolerance) << what;
}

// Keyframes on a 5 m circle, each turned to look along the path, plus the
// essential-graph edges computed from the ground truth: the chain, some
// covisibility edges (i -> i + 2), and a loop edge from the last to the first.
struct LoopScene {
  std::vector<Sim3> truth;  // S_cw
  std::vector<PoseGraphEdge> edges;
  int loop_edge = -1;
};

PoseGraphEdge edgeFromTruth(const std::vector<Sim3>& truth, int from, int to) {
  return {from, to, truth[to] * truth[from].inverse(), 1.0};
}

LoopScene makeLoop(int n, bool unit_scales) {
  LoopScene scene;
  for (int i = 0; i < n; ++i) {
    const double angle = 2 * M_PI * i / n;
    const Vec3 centre(5 * std::cos(angle), 0.3 * std::sin(3 * angle), 5 * std::sin(angle));
    const Mat3 R_wc = test::rotationAbout(Vec3(0, 1, 0), -angle) * test::rotationAbout(Vec3(1, 0, 0), 0.1);
    Sim3 S_cw(SE3(R_wc, centre).inverse());
    // A loop-corrected map has keyframes at other scales too.
    if (!unit_scales) S_cw = Sim3(1.0 + 0.1 * std::sin(angle), Mat3::Identity(), Vec3::Zero()) * S_cw;
    scene.truth.push_back(S_cw);
  }
  for (int i = 0; i + 1 < n; ++i) scene.edges.push_back(edgeFromTruth(scene.truth, i, i + 1));
  for (int i = 0; i + 2 < n; i += 3) scene.edges.push_back(edgeFromTruth(scene.truth, i, i + 2));
  scene.loop_edge = static_cast<int>(scene.edges.size());
  scene.edges.push_back(edgeFromTruth(scene.truth, n - 1, 0));
  return scene;
}

// Odometry-style initial guess: vertex 0 true, every next one composed from
// the true chain edge and a drift of `drift` (rotation, translation, scale).
std::vector<PoseGraphVertex> driftedVertices(const LoopScene& scene, const Sim3& drift) {
  std::vector<PoseGraphVertex> vertices;
  vertices.push_back({0, scene.truth[0], true});
  for (size_t i = 1; i < scene.truth.size(); ++i) {
    const Sim3 step = scene.truth[i] * scene.truth[i - 1].inverse();
    vertices.push_back({static_cast<long>(i), drift * step * vertices.back().S_cw, false});
  }
  return vertices;
}

Sim3 loopError(const std::vector<PoseGraphVertex>& vertices, const PoseGraphEdge& edge) {
  return edge.S_to_from.inverse() * vertices[edge.to].S_cw * vertices[edge.from].S_cw.inverse();
}

TEST(Sim3PoseGraph, ClosesTheLoopAndRecoversTruth) {
  const int n = 30;
  const LoopScene scene = makeLoop(n, /*unit_scales=*/false);
  const Sim3 drift(1.01, test::rotationAbout(Vec3(0.3, 1, -0.2), test::degrees(0.3)), Vec3(0.01, -0.005, 0.008));
  std::vector<PoseGraphVertex> vertices = driftedVertices(scene, drift);
  const Sim3 fixed_before = vertices[0].S_cw;
  // The injected drift is substantial: 35 % scale and several degrees at the end.
  ASSERT_GT(vertices[n - 1].S_cw.s / scene.truth[n - 1].s, 1.3);
  const Sim3 error_before = loopError(vertices, scene.edges[scene.loop_edge]);
  ASSERT_GT(std::abs(std::log(error_before.s)), 0.2);

  const PoseGraphResult result = optimizeSim3PoseGraph(vertices, scene.edges);
  EXPECT_GT(result.initial_cost, 1.0);
  EXPECT_LT(result.final_cost, 1e-16);
  EXPECT_EQ(vertices[0].S_cw.R, fixed_before.R);
  EXPECT_EQ(vertices[0].S_cw.t, fixed_before.t);
  EXPECT_EQ(vertices[0].S_cw.s, fixed_before.s);
  const Sim3 error_after = loopError(vertices, scene.edges[scene.loop_edge]);
  expectSim3Near(error_after, Sim3(), 1e-9, "loop error");
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(vertices[i].id, i);
    expectSim3Near(vertices[i].S_cw, scene.truth[i], 1e-6, "vertex " + std::to_string(i));
  }
}

TEST(Sim3PoseGraph, FixedScaleKeepsEveryScale) {
  const int n = 20;
  const LoopScene scene = makeLoop(n, /*unit_scales=*/true);
  const Sim3 drift(1.0, test::rotationAbout(Vec3(1, 0.2, 0), test::degrees(0.4)), Vec3(0.02, 0.0, -0.01));
  std::vector<PoseGraphVertex> vertices = driftedVertices(scene, drift);
  PoseGraphOptions options;
  options.fix_scale = true;
  optimizeSim3PoseGraph(vertices, scene.edges, options);
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(vertices[i].S_cw.s, 1.0);
    expectSim3Near(vertices[i].S_cw, scene.truth[i], 1e-6, "vertex " + std::to_string(i));
  }
}

TEST(Sim3PoseGraph, WeightsAverageConflictingMeasurements) {
  // Two measurements of the same relative translation, weights 1 and 3: the
  // least-squares answer is their weighted mean, rotation and scale untouched.
  std::vector<PoseGraphVertex> vertices{{0, Sim3(), true}, {1, Sim3(1.0, Mat3::Identity(), Vec3(5, 5, 5)), false}};
  const Vec3 t_a(1.0, 0.0, 0.0), t_b(0.0, 2.0, 0.0);
  const std::vector<PoseGraphEdge> edges{{0, 1, Sim3(1.0, Mat3::Identity(), t_a), 1.0},
                                         {0, 1, Sim3(1.0, Mat3::Identity(), t_b), 3.0}};
  optimizeSim3PoseGraph(vertices, edges);
  // The minimum has non-zero cost, so Levenberg-Marquardt stops on Ceres'
  // relative function tolerance (1e-6) about 1e-4 of the first step short of
  // it; the unweighted mean would be 0.56 away.
  EXPECT_LT((vertices[1].S_cw.t - (t_a + 3.0 * t_b) / 4.0).norm(), 1e-3);
  EXPECT_NEAR(vertices[1].S_cw.s, 1.0, 1e-9);
  EXPECT_LT(test::rotationDifference(vertices[1].S_cw.R, Mat3::Identity()), 1e-9);
}

TEST(Sim3PoseGraph, VertexWithoutEdgesIsUntouched) {
  const LoopScene scene = makeLoop(8, true);
  std::vector<PoseGraphVertex> vertices = driftedVertices(scene, Sim3());
  vertices.push_back({99, Sim3(2.0, test::rotationAbout(Vec3(0, 0, 1), 0.3), Vec3(1, 2, 3)), false});
  const Sim3 lonely = vertices.back().S_cw;
  optimizeSim3PoseGraph(vertices, scene.edges);
  EXPECT_EQ(vertices.back().S_cw.R, lonely.R);
  EXPECT_EQ(vertices.back().S_cw.t, lonely.t);
  EXPECT_EQ(vertices.back().S_cw.s, lonely.s);
}

TEST(Sim3PoseGraph, RejectsBadEdges) {
  std::vector<PoseGraphVertex> vertices(2);
  EXPECT_THROW(optimizeSim3PoseGraph(vertices, {{0, 2, Sim3(), 1.0}}), std::invalid_argument);
  EXPECT_THROW(optimizeSim3PoseGraph(vertices, {{1, 1, Sim3(), 1.0}}), std::invalid_argument);
  EXPECT_THROW(optimizeSim3PoseGraph(vertices, {{0, 1, Sim3(), 0.0}}), std::invalid_argument);
  vertices[1].S_cw.s = 0.0;
  EXPECT_THROW(optimizeSim3PoseGraph(vertices, {{0, 1, Sim3(), 1.0}}), std::invalid_argument);
}

TEST(Sim3PoseGraph, RigidPoseKeepsRotationAndCameraCentre) {
  const SE3 T_cw(test::rotationAbout(Vec3(1, 2, 3), 0.5), Vec3(0.4, -1.0, 2.0));
  const Sim3 S_cw = Sim3(2.5, Mat3::Identity(), Vec3::Zero()) * Sim3(T_cw);
  const SE3 back = rigidPoseFromSim3(S_cw);
  EXPECT_LT((back.R - T_cw.R).norm(), 1e-15);
  EXPECT_LT((back.t - T_cw.t).norm(), 1e-15);
}

// ---------------------------------------------------------------------------

struct Sim3Scene {
  PinholeCamera camera = test::syntheticCamera();
  Sim3 S12_true;
  std::vector<Sim3Match> matches;
  std::vector<bool> is_outlier;
};

Sim3Scene makeSim3Scene(int count, double scale, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> level(0, 7);
  Sim3Scene scene;
  // Camera 2 is 0.5 m to the side of camera 1 and turned 10 degrees, in a map
  // whose scale differs by `scale`.
  scene.S12_true = Sim3(scale, test::rotationAbout(Vec3(0.1, 1, 0), test::degrees(10)), Vec3(0.5, 0.05, -0.1));
  const Sim3 S21 = scene.S12_true.inverse();
  const SE3 camera1;
  for (int i = 0; i < count; ++i) {
    Sim3Match match;
    match.point1_c1 = test::pointSeenBy(scene.camera, camera1, 3.0, 8.0, rng);
    match.point2_c2 = S21 * match.point1_c1;
    match.pixel1 = scene.camera.project(match.point1_c1);
    match.pixel2 = scene.camera.project(match.point2_c2);
    match.inv_sigma2_1 = 1.0 / std::pow(1.2, 2 * level(rng));
    match.inv_sigma2_2 = 1.0 / std::pow(1.2, 2 * level(rng));
    scene.matches.push_back(match);
    scene.is_outlier.push_back(false);
  }
  return scene;
}

Sim3 perturbSim3(const Sim3& S, std::mt19937& rng) {
  return Sim3(S.s * 1.05, test::rotationAbout(test::randomUnitVector(rng), test::degrees(3)) * S.R,
              S.t + 0.05 * test::randomUnitVector(rng));
}

TEST(OptimizeSim3, RecoversKnownSimilarity) {
  const Sim3Scene scene = makeSim3Scene(100, 1.4, 1);
  std::mt19937 rng(2);
  Sim3 S12 = perturbSim3(scene.S12_true, rng);
  const Sim3OptimizationResult result = optimizeSim3(scene.camera, scene.matches, S12);
  EXPECT_EQ(result.n_inliers, 100);
  expectSim3Near(S12, scene.S12_true, 1e-6);
}

TEST(OptimizeSim3, FlagsWrongMatchesExactly) {
  Sim3Scene scene = makeSim3Scene(100, 0.7, 3);
  std::mt19937 rng(4);
  for (int i = 0; i < 100; i += 7) {
    // Alternate which image's keypoint is wrong; 15 pixels (in sigma) is far beyond chi2 10.
    Vec2& pixel = (i / 7) % 2 ? scene.matches[i].pixel1 : scene.matches[i].pixel2;
    const Vec3 d = test::randomUnitVector(rng);
    pixel += 15.0 * Vec2(d.x(), d.y()).normalized() / std::sqrt(std::min(scene.matches[i].inv_sigma2_1,
                                                                         scene.matches[i].inv_sigma2_2));
    scene.is_outlier[i] = true;
  }
  Sim3 S12 = perturbSim3(scene.S12_true, rng);
  const Sim3OptimizationResult result = optimizeSim3(scene.camera, scene.matches, S12);
  EXPECT_EQ(result.n_inliers, 100 - 15);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(result.inlier[i], !scene.is_outlier[i]) << i;
  expectSim3Near(S12, scene.S12_true, 1e-6);
}

TEST(OptimizeSim3, FixedScaleOptimisesRigidMotionOnly) {
  const Sim3Scene scene = makeSim3Scene(60, 1.0, 5);
  std::mt19937 rng(6);
  Sim3 S12 = perturbSim3(scene.S12_true, rng);
  S12.s = 1.0;
  Sim3OptimizationOptions options;
  options.fix_scale = true;
  const Sim3OptimizationResult result = optimizeSim3(scene.camera, scene.matches, S12, options);
  EXPECT_EQ(S12.s, 1.0);
  EXPECT_EQ(result.n_inliers, 60);
  expectSim3Near(S12, scene.S12_true, 1e-6);
}

}  // namespace
}  // namespace vslam
