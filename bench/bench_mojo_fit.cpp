// MOJO's recursive projection: one body fit per predicted frame and sample. The Ceres fit the
// projection uses (nn/mojo/ceres_fit.h) against the Eigen fit of core/markers.h on the same
// problem: a synthetic walk's markers, warm-started from the previous frame, 10 iterations, the
// projection's default prior; and a 50-sample batch of one predicted frame through MarkerProjector.
#include <benchmark/benchmark.h>

#include "core/kinematics.h"
#include "core/markers.h"
#include "core/synthetic.h"
#include "nn/mojo/ceres_fit.h"
#include "nn/mojo/projection.h"

using namespace mosyn;

namespace {

struct Walk {
  Skeleton skeleton = make_synthetic_biped();
  Motion motion = make_synthetic_walk(skeleton, 31, 15.0);
  MarkerSet markers = cmu41_markers(skeleton);
  std::vector<std::vector<Eigen::Vector3d>> targets;
  Walk() {
    const WorldPoses world = forward_kinematics(skeleton, motion);
    for (int t = 0; t < motion.num_frames; ++t) targets.push_back(marker_positions(markers, world, t));
  }
};

const Walk& walk() {
  static const Walk w;
  return w;
}

void BM_CeresFitWarmStart(benchmark::State& state) {
  const Walk& w = walk();
  nn::mojo::CeresFitOptions options;
  options.max_iterations = 10;
  int t = 1;
  for (auto _ : state) {
    Motion m = w.motion;  // frame t starts from frame t - 1
    for (int j = 0; j < m.num_joints; ++j) m.rotation(t, j) = m.rotation(t - 1, j);
    m.translation(t, 0) = m.translation(t - 1, 0);
    benchmark::DoNotOptimize(nn::mojo::fit_markers_ceres(w.skeleton, w.markers, w.targets[t], &m, t, options));
    t = t % (w.motion.num_frames - 1) + 1;
  }
}
BENCHMARK(BM_CeresFitWarmStart)->Unit(benchmark::kMicrosecond);

void BM_EigenFitWarmStart(benchmark::State& state) {
  const Walk& w = walk();
  MarkerFitOptions options;
  options.max_iterations = 10;
  options.pose_prior = 1e-4;
  int t = 1;
  for (auto _ : state) {
    Motion m = w.motion;
    for (int j = 0; j < m.num_joints; ++j) m.rotation(t, j) = m.rotation(t - 1, j);
    m.translation(t, 0) = m.translation(t - 1, 0);
    benchmark::DoNotOptimize(fit_markers(w.skeleton, w.markers, w.targets[t], &m, t, options));
    t = t % (w.motion.num_frames - 1) + 1;
  }
}
BENCHMARK(BM_EigenFitWarmStart)->Unit(benchmark::kMicrosecond);

// One predicted frame of a 50-sample batch through the projection, on `threads` threads.
void BM_ProjectFiftySamples(benchmark::State& state) {
  const Walk& w = walk();
  nn::mojo::ProjectionOptions options;
  options.threads = static_cast<int>(state.range(0));
  const std::vector<double> mean(123, 0.0), std(123, 1.0);
  nn::mojo::MarkerProjector projector(w.skeleton, mean, std, 50, options);
  auto rows_at = [&](int t) {
    std::vector<float> rows;
    for (int r = 0; r < 50; ++r)
      for (const auto& p : w.targets[t])
        for (int k = 0; k < 3; ++k) rows.push_back(static_cast<float>(p[k] * w.skeleton.meters_per_unit));
    return rows;
  };
  auto first = rows_at(0);
  projector.project(first.data(), 123);  // the start fit from the canonical pose, not timed
  int t = 1;
  for (auto _ : state) {
    state.PauseTiming();
    auto rows = rows_at(t);
    state.ResumeTiming();
    projector.project(rows.data(), 123);
    t = t % (w.motion.num_frames - 1) + 1;
  }
  state.counters["sample_frames_per_s"] = benchmark::Counter(50.0 * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ProjectFiftySamples)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
