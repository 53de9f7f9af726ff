// Timings of the optimize module on synthetic problems shaped like the real
// ones. Run with:
//   build/bench/bench_optimize --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// A recorded Local Mapping problem (saveBundleProblem) is benchmarked too:
// VSLAM_BUNDLE_PROBLEM names its file, else bench/data/local_ba_fr1_xyz.txt
// (recorded with VSLAM_RECORD_BA, see docs/REPORTS.md) is used.
#include <cstdlib>
#include <filesystem>
#include <string>
#include <random>

#include <benchmark/benchmark.h>

#include "../tests/optimize_synthetic.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
#include "vslam/optimize/pose_graph.hpp"
#include "vslam/optimize/pose_optimizer.hpp"

namespace vslam {
namespace {

struct PoseOnlyInput {
  PinholeCamera camera = test::syntheticCamera();
  double bf = 0;
  SE3 T_cw_initial;
  std::vector<Vec3> points_w;
  std::vector<Observation2D> observations;
};

// Tracking-like: `count` matches with 1 px noise (times the level's sigma),
// 10 % of them wrong, the motion-model guess `offset_m` / `offset_deg` away.
PoseOnlyInput poseOnlyInput(int count, double bf, double offset_m, double offset_deg) {
  std::mt19937 rng(42);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 7);
  PoseOnlyInput input;
  input.bf = bf;
  const SE3 T_cw(test::rotationAbout(Vec3(0.2, 1, 0.1), 0.4), Vec3(0.3, -0.2, 1.0));
  input.T_cw_initial = test::perturbPose(T_cw, offset_m, test::degrees(offset_deg), rng);
  for (int i = 0; i < count; ++i) {
    const Vec3 p_w = test::pointSeenBy(input.camera, T_cw, 1.0, 10.0, rng);
    const Vec3 p_c = T_cw * p_w;
    Observation2D obs;
    obs.point = i;
    obs.inv_sigma2 = 1.0 / std::pow(1.2, 2 * level(rng));
    const double sigma = 1.0 / std::sqrt(obs.inv_sigma2);
    obs.pixel = input.camera.project(p_c) + sigma * Vec2(gauss(rng), gauss(rng));
    if (bf > 0) obs.u_right = obs.pixel.x() - bf / p_c.z() + sigma * gauss(rng);
    if (i % 10 == 0) obs.pixel += 30.0 * sigma * Vec2(1, -1);
    input.points_w.push_back(p_w);
    input.observations.push_back(obs);
  }
  return input;
}

void BM_PoseOnly(benchmark::State& state, double bf, double offset_m, double offset_deg) {
  const PoseOnlyInput input = poseOnlyInput(static_cast<int>(state.range(0)), bf, offset_m, offset_deg);
  int inliers = 0;
  for (auto _ : state) {
    const PoseOptimizationResult result =
        optimizePose(input.camera, input.bf, input.T_cw_initial, input.points_w, input.observations);
    inliers = result.n_inliers;
    benchmark::DoNotOptimize(result.T_cw.t.data());
  }
  state.counters["inliers"] = inliers;
}
BENCHMARK_CAPTURE(BM_PoseOnly, mono_2cm_1deg, 0.0, 0.02, 1.0)->Arg(300)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PoseOnly, mono_5cm_3deg, 0.0, 0.05, 3.0)->Arg(300)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_PoseOnly, stereo_2cm_1deg, 40.0, 0.02, 1.0)->Arg(300)->Unit(benchmark::kMillisecond);

void runBundle(benchmark::State& state, const PinholeCamera& camera, double bf, const BundleProblem& problem,
               BundleLinearSolver solver, RobustLoss loss = RobustLoss::Huber) {
  BundleOptions options;
  options.linear_solver = solver;
  options.robust_loss = loss;
  BundleResult result;
  for (auto _ : state) {
    state.PauseTiming();
    BundleProblem copy = problem;
    state.ResumeTiming();
    result = bundleAdjust(camera, bf, copy, options);
  }
  state.counters["observations"] = static_cast<double>(problem.observations.size());
  state.counters["outliers"] = result.n_outliers;
  state.counters["iterations"] = result.iterations;
  state.counters["final_cost"] = result.final_cost;
}

// Args: points, keyframes (half of them free). 2000 x 20 is the Local Mapping
// shape; the larger ones place the dense / sparse Schur crossover.
void BM_LocalBundleAdjustment(benchmark::State& state, BundleLinearSolver solver) {
  const PinholeCamera camera = test::syntheticCamera();
  const BundleProblem problem = test::localBundleScene(camera, static_cast<int>(state.range(1)),
                                                       static_cast<int>(state.range(0)), 1.0, 0.03, 7);
  runBundle(state, camera, 0.0, problem, solver);
}
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, automatic, BundleLinearSolver::Automatic)
    ->Args({2000, 20})->Unit(benchmark::kMillisecond);

void BM_LocalBundleAdjustmentCauchy(benchmark::State& state) {
  const PinholeCamera camera = test::syntheticCamera();
  const BundleProblem problem = test::localBundleScene(camera, 20, 2000, 1.0, 0.03, 7);
  runBundle(state, camera, 0.0, problem, BundleLinearSolver::Automatic, RobustLoss::Cauchy);
}
BENCHMARK(BM_LocalBundleAdjustmentCauchy)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, dense_schur, BundleLinearSolver::DenseSchur)
    ->Args({2000, 20})->Args({3000, 40})->Args({4000, 80})->Args({8000, 160})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, sparse_schur, BundleLinearSolver::SparseSchur)
    ->Args({2000, 20})->Args({3000, 40})->Args({4000, 80})->Args({8000, 160})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, iterative_schur, BundleLinearSolver::IterativeSchur)
    ->Args({2000, 20})->Unit(benchmark::kMillisecond);

void BM_RecordedBundleAdjustment(benchmark::State& state) {
  const char* env_path = std::getenv("VSLAM_BUNDLE_PROBLEM");
  const std::string path =
      env_path ? std::string(env_path) : std::string(VSLAM_SOURCE_DIR) + "/bench/data/local_ba_fr1_xyz.txt";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError((path + " not found: set VSLAM_BUNDLE_PROBLEM to a file written by saveBundleProblem").c_str());
    return;
  }
  const RecordedBundleProblem recorded = loadBundleProblem(path);
  state.SetLabel(std::to_string(recorded.problem.keyframes.size()) + " keyframes, " +
                 std::to_string(recorded.problem.points.size()) + " points, " +
                 std::to_string(recorded.problem.observations.size()) + " observations");
  runBundle(state, recorded.camera, recorded.bf, recorded.problem, BundleLinearSolver::Automatic);
}
BENCHMARK(BM_RecordedBundleAdjustment)->Unit(benchmark::kMillisecond);

// Loop closing on a ring of `n` keyframes: chain edges, covisibility edges to
// the next 2 and 3 keyframes, one loop edge, and 0.1 % scale / 0.03 degree / 2 mm drift
// per keyframe in the initial guess (35 % scale and 9 degrees around the loop).
void BM_Sim3PoseGraph(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::vector<Sim3> truth;
  for (int i = 0; i < n; ++i) {
    const double angle = 2 * M_PI * i / n;
    const Vec3 centre(20 * std::cos(angle), 0.0, 20 * std::sin(angle));
    truth.push_back(Sim3(SE3(test::rotationAbout(Vec3(0, 1, 0), -angle), centre).inverse()));
  }
  std::vector<PoseGraphEdge> edges;
  auto addEdge = [&](int from, int to) { edges.push_back({from, to, truth[to] * truth[from].inverse(), 1.0}); };
  for (int i = 0; i + 1 < n; ++i) addEdge(i, i + 1);
  for (int i = 0; i + 3 < n; ++i) {
    addEdge(i, i + 2);
    addEdge(i, i + 3);
  }
  addEdge(n - 1, 0);
  const Sim3 drift(1.001, test::rotationAbout(Vec3(0.3, 1, -0.2), test::degrees(0.03)), Vec3(0.002, 0.0, 0.002));
  std::vector<PoseGraphVertex> initial{{0, truth[0], true}};
  for (int i = 1; i < n; ++i) {
    initial.push_back({i, drift * truth[i] * truth[i - 1].inverse() * initial.back().S_cw, false});
  }
  PoseGraphResult result;
  for (auto _ : state) {
    std::vector<PoseGraphVertex> vertices = initial;
    result = optimizeSim3PoseGraph(vertices, edges);
  }
  state.counters["edges"] = static_cast<double>(edges.size());
  state.counters["iterations"] = result.iterations;
  state.counters["final_cost"] = result.final_cost;
}
BENCHMARK(BM_Sim3PoseGraph)->Arg(300)->Unit(benchmark::kMillisecond);

// Loop-candidate refinement with 100 matches, 10 % of them wrong.
void BM_OptimizeSim3(benchmark::State& state) {
  std::mt19937 rng(3);
  const PinholeCamera camera = test::syntheticCamera();
  const Sim3 S12_true(1.3, test::rotationAbout(Vec3(0.1, 1, 0), test::degrees(10)), Vec3(0.5, 0.05, -0.1));
  std::vector<Sim3Match> matches;
  for (int i = 0; i < state.range(0); ++i) {
    Sim3Match match;
    match.point1_c1 = test::pointSeenBy(camera, SE3(), 3.0, 8.0, rng);
    match.point2_c2 = S12_true.inverse() * match.point1_c1;
    match.pixel1 = camera.project(match.point1_c1);
    match.pixel2 = camera.project(match.point2_c2) + (i % 10 == 0 ? Vec2(20, 0) : Vec2(0, 0));
    matches.push_back(match);
  }
  const Sim3 S12_initial(1.3 * 1.05, test::rotationAbout(Vec3(1, 0, 0), test::degrees(2)) * S12_true.R,
                         S12_true.t + Vec3(0.03, 0.0, 0.03));
  int inliers = 0;
  for (auto _ : state) {
    Sim3 S12 = S12_initial;
    inliers = optimizeSim3(camera, matches, S12).n_inliers;
  }
  state.counters["inliers"] = inliers;
}
BENCHMARK(BM_OptimizeSim3)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
