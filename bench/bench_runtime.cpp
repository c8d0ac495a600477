// Crowd runtime: per-step latency of nn::Generator (the game-loop API) with the shipped
// models/moglow-realtime at batch 1, 64 and 512 characters, every character steered by a stick
// (1.2 m/s, each facing its own way). Reports the median and 90th / 99th percentile of one step
// (stick in, raw poses out, roots integrated) in milliseconds; 20 fps needs p99 <= 50 ms.
// BM_StepStages splits one step at 512 characters into where its time goes: the controllers
// (filters and the second they predict ahead), the model's step (the look-ahead features and the
// flow's reverse) and the rest (standardising, roots). LibTorch runs with 2 threads
// (MOSYN_BENCH_THREADS overrides); MOSYN_MODEL_DIR overrides the model.
#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "data/root_controller.h"
#include "nn/generator.h"
#include "nn/model.h"
#include "nn/run.h"
#include "nn/standardiser.h"

namespace {

using Clock = std::chrono::steady_clock;

const int kThreads = std::getenv("MOSYN_BENCH_THREADS") ? std::atoi(std::getenv("MOSYN_BENCH_THREADS")) : 2;

std::string model_dir() {
  const char* env = std::getenv("MOSYN_MODEL_DIR");
  return env ? env : MOSYN_SOURCE_DIR "/models/moglow-realtime";
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Character b walks at 1.2 m/s facing its own way.
std::vector<float> sticks(int batch) {
  std::vector<float> s(static_cast<size_t>(batch) * 3);
  for (int b = 0; b < batch; ++b) {
    const double facing = 0.3 * (b % 16);
    s[3 * b] = static_cast<float>(1.2 * std::sin(facing));
    s[3 * b + 1] = static_cast<float>(1.2 * std::cos(facing));
    s[3 * b + 2] = static_cast<float>(facing);
  }
  return s;
}

void BM_GeneratorStep(benchmark::State& state) {
  const int batch = static_cast<int>(state.range(0));
  mosyn::nn::GeneratorOptions options;
  options.batch = batch;
  options.threads = kThreads;
  options.seed = 7;
  mosyn::nn::Generator generator(model_dir(), options);
  const auto input = sticks(batch);
  for (int k = 0; k < 3; ++k) generator.step_stick(input);  // first-touch allocations
  std::vector<double> ms;
  for (auto _ : state) {
    const auto start = Clock::now();
    benchmark::DoNotOptimize(generator.step_stick(input));
    const double s = seconds_since(start);
    state.SetIterationTime(s);
    ms.push_back(1000 * s);
  }
  state.counters["p50_ms"] = percentile(ms, 0.5);
  state.counters["p90_ms"] = percentile(ms, 0.9);
  state.counters["p99_ms"] = percentile(ms, 0.99);
  state.counters["min_ms"] = *std::min_element(ms.begin(), ms.end());
  state.SetLabel("batch " + std::to_string(batch) + ", " + std::to_string(kThreads) + " threads");
}

// One step of 512 characters in its stages, the way Generator::step_stick runs them.
void BM_StepStages(benchmark::State& state) {
  const int batch = 512;
  mosyn::nn::set_num_threads(kThreads);
  const auto run = mosyn::nn::load_run(model_dir(), {"checkpoint.pt", "cpu", kThreads});
  const int64_t c = run.context.control_dim, k_ahead = std::max(1, run.traits.control_ahead_frames);
  mosyn::nn::Standardiser st(run.stats);
  mosyn::data::RootControllerOptions co;
  co.fps = run.dataset.fps;
  co.smoothing_s = run.dataset.layout.root_smoothing_s;
  std::vector<mosyn::data::RootController> controllers(batch, mosyn::data::RootController(co));
  mosyn::nn::SampleRequest req;
  req.batch = batch;
  auto stream = run.model->begin_stream(req);
  const auto input = sticks(batch);
  std::vector<float> control(batch * c), ahead(batch * k_ahead * c);
  double controllers_s = 0, model_s = 0, rest_s = 0;
  for (auto _ : state) {
    auto t0 = Clock::now();
    for (int b = 0; b < batch; ++b) {
      const auto u = controllers[b].step(mosyn::data::StickInput{input[3 * b], input[3 * b + 1], input[3 * b + 2]});
      for (int i = 0; i < 3; ++i) control[b * c + i] = static_cast<float>(u[i]);
      controllers[b].predict(static_cast<int>(k_ahead), ahead.data() + b * k_ahead * c);
    }
    controllers_s += seconds_since(t0);
    t0 = Clock::now();
    auto ctrl = st.control(torch::from_blob(control.data(), {batch, c}).clone());
    auto pred = st.control(torch::from_blob(ahead.data(), {batch * k_ahead, c}).clone()).view({batch, k_ahead, c});
    rest_s += seconds_since(t0);
    t0 = Clock::now();
    auto pose = run.model->step_stream_ahead(*stream, ctrl, pred).pose;
    model_s += seconds_since(t0);
    t0 = Clock::now();
    benchmark::DoNotOptimize(st.unpose(pose).contiguous());
    rest_s += seconds_since(t0);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["controllers_ms"] = 1000 * controllers_s / n;
  state.counters["model_ms"] = 1000 * model_s / n;
  state.counters["standardise_ms"] = 1000 * rest_s / n;
  state.SetLabel("batch 512, " + std::to_string(kThreads) + " threads");
}

}  // namespace

BENCHMARK(BM_GeneratorStep)->Arg(1)->Arg(64)->Arg(512)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(3.0);
BENCHMARK(BM_StepStages)->Unit(benchmark::kMillisecond)->MinTime(3.0);

BENCHMARK_MAIN();
