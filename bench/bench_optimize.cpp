// Timings of the optimize module on synthetic problems shaped like the real
// ones. Run with:
//   build/bench/bench_optimize --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// A recorded Local Mapping problem (saveBundleProblem) is benchmarked too when
// VSLAM_BUNDLE_PROBLEM names its file.
#include <cstdlib>
#include <random>

#include <benchmark/benchmark.h>

#include "../tests/optimize_synthetic.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"
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
               BundleLinearSolver solver) {
  BundleOptions options;
  options.linear_solver = solver;
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

void BM_LocalBundleAdjustment(benchmark::State& state, BundleLinearSolver solver) {
  const PinholeCamera camera = test::syntheticCamera();
  const BundleProblem problem = test::localBundleScene(camera, 20, static_cast<int>(state.range(0)), 1.0, 0.03, 7);
  runBundle(state, camera, 0.0, problem, solver);
}
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, automatic, BundleLinearSolver::Automatic)
    ->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, dense_schur, BundleLinearSolver::DenseSchur)
    ->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, sparse_schur, BundleLinearSolver::SparseSchur)
    ->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LocalBundleAdjustment, iterative_schur, BundleLinearSolver::IterativeSchur)
    ->Arg(2000)->Unit(benchmark::kMillisecond);

void BM_RecordedBundleAdjustment(benchmark::State& state) {
  const char* path = std::getenv("VSLAM_BUNDLE_PROBLEM");
  if (!path) {
    state.SkipWithError("set VSLAM_BUNDLE_PROBLEM to a file written by saveBundleProblem");
    return;
  }
  const RecordedBundleProblem recorded = loadBundleProblem(path);
  runBundle(state, recorded.camera, recorded.bf, recorded.problem, BundleLinearSolver::Automatic);
}
BENCHMARK(BM_RecordedBundleAdjustment)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
