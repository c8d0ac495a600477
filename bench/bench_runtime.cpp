// Crowd runtime: per-step latency of nn::Generator (the game-loop API) with the shipped
// models/moglow-locomotion at batch 1, 64 and 512 characters, every character walking at 1.2 m/s
// and turning at its own rate. Reports the median and 90th / 99th percentile of one step
// (control in, raw poses out, roots integrated) in milliseconds; 30 fps needs p99 <= 33 ms.
// LibTorch runs with 2 threads (MOSYN_BENCH_THREADS overrides); MOSYN_MODEL_DIR overrides the
// model (default: models/moglow-locomotion relative to the source tree).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <string>
#include <vector>

#include "nn/generator.h"
#include "nn/run.h"

namespace {

const int kThreads = std::getenv("MOSYN_BENCH_THREADS") ? std::atoi(std::getenv("MOSYN_BENCH_THREADS")) : 2;

std::string model_dir() {
  const char* env = std::getenv("MOSYN_MODEL_DIR");
  return env ? env : MOSYN_SOURCE_DIR "/models/moglow-locomotion";
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

void BM_GeneratorStep(benchmark::State& state) {
  const int batch = static_cast<int>(state.range(0));
  mosyn::nn::GeneratorOptions options;
  options.batch = batch;
  options.threads = kThreads;
  options.seed = 7;
  mosyn::nn::Generator generator(model_dir(), options);
  const double fps = generator.run().dataset.fps;
  std::vector<float> control(static_cast<size_t>(batch) * 3);
  for (int b = 0; b < batch; ++b) {
    control[3 * b + 1] = static_cast<float>(1.2 / fps);
    control[3 * b + 2] = static_cast<float>(0.5 * (b % 8 - 4) / 8 / fps);
  }
  for (int k = 0; k < 3; ++k) generator.step(control);  // first-touch allocations
  std::vector<double> ms;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(generator.step(control));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(s);
    ms.push_back(1000 * s);
  }
  state.counters["p50_ms"] = percentile(ms, 0.5);
  state.counters["p90_ms"] = percentile(ms, 0.9);
  state.counters["p99_ms"] = percentile(ms, 0.99);
  state.counters["min_ms"] = *std::min_element(ms.begin(), ms.end());
  state.SetLabel("batch " + std::to_string(batch) + ", " + std::to_string(kThreads) + " threads");
}

}  // namespace

BENCHMARK(BM_GeneratorStep)->Arg(1)->Arg(64)->Arg(512)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(3.0);

BENCHMARK_MAIN();
