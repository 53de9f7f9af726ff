// Geometry timings: the two-view initializer on 500 matches (the figure the
// tracking thread pays once per initialisation attempt), PnP and Sim(3) RANSAC.
// Median over repetitions:
//   build/bench/bench_geometry --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include "../tests/geometry_synthetic.hpp"
#include "vslam/geometry/pnp.hpp"
#include "vslam/geometry/sim3_solver.hpp"
#include "vslam/geometry/two_view_initializer.hpp"

namespace vslam {
namespace {

const SE3 kMotion(test::rotationDeg(4.0, Vec3(0.3, 1.0, 0.2)), Vec3(0.25, -0.04, 0.06));

void BM_TwoViewInitializer_NonPlanar500(benchmark::State& state) {
  const auto scene = test::makeDepthScene(kMotion, 500, 0.5, 0.1, 1);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  for (auto _ : state) {
    TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
    if (!result.success) state.SkipWithError(result.failure_reason.c_str());
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_TwoViewInitializer_NonPlanar500)->Unit(benchmark::kMillisecond);

void BM_TwoViewInitializer_Planar500(benchmark::State& state) {
  const auto scene = test::makePlanarScene(kMotion, Vec3(0.1, -0.3, 1.0).normalized(), 2.0, 500, 0.5, 0.1, 2);
  const TwoViewInitializer initializer(test::syntheticK(), InitializerParams{}, 0);
  for (auto _ : state) {
    TwoViewResult result = initializer.initialize(scene.px_ref, scene.px_cur);
    if (!result.success) state.SkipWithError(result.failure_reason.c_str());
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_TwoViewInitializer_Planar500)->Unit(benchmark::kMillisecond);

void BM_PnpRansac500(benchmark::State& state) {
  // The initializer's scene seen again: reference-frame points, current pixels.
  const auto scene = test::makeDepthScene(kMotion, 500, 0.5, 0.2, 3);
  for (auto _ : state) {
    PnpResult result = solvePnpRansac(scene.points_ref, scene.px_cur, test::syntheticK(), 300, 2.45, 30, 0);
    if (!result.success) state.SkipWithError("PnP failed");
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_PnpRansac500)->Unit(benchmark::kMillisecond);

void BM_Sim3Ransac200(benchmark::State& state) {
  // Reference-frame points as camera 2, mapped into camera 1 by a similarity.
  const auto scene = test::makeDepthScene(kMotion, 200, 0.0, 0.0, 4);
  const Sim3 S12(1.5, test::rotationDeg(10, Vec3(0, 1, 0)), Vec3(0.2, 0, 0.3));
  const Mat3 K = test::syntheticK();
  Sim3Correspondences m;
  for (size_t i = 0; i < scene.points_ref.size(); ++i) {
    const Vec3 p1 = S12 * scene.points_ref[i];
    m.points_2.push_back(scene.points_ref[i]);
    m.pixels_2.push_back(scene.px_ref[i]);
    // Every third match points at another map point: a wrong loop match.
    m.points_1.push_back(i % 3 == 0 ? S12 * scene.points_ref[(i + 50) % scene.points_ref.size()] : p1);
    m.pixels_1.push_back(test::projectPx(K, m.points_1.back()));
  }
  for (auto _ : state) {
    Sim3Result result = solveSim3Ransac(m, K, K, Sim3SolverParams{}, 0);
    if (!result.success) state.SkipWithError("Sim3 failed");
    benchmark::DoNotOptimize(result);
  }
}
BENCHMARK(BM_Sim3Ransac200)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vslam
