// MoGlow speed: one training step (batch 100 x 60 frames) and per-frame sampling latency at
// batch 1 and 64, for
//   shipped  K=8, hidden 128, tau=10 on Bandai-Namco joint rotations, D=127 (the first shipped
//            model; models/moglow-locomotion now has this network on D=63 positions + 11 labels)
//   k8_h128  the same network on D=63 (21 joint positions): the shipped model's size up to its
//            11 label inputs. Not the public PyTorch code's "K=8 / hidden 128", which always builds
//            two LSTM layers per coupling (bench/README.md has the side-by-side figures)
//   paper    the paper config (K=16, two 512-unit LSTM layers, tau=10) on D=63
// C=3. LibTorch runs with 2 threads (MOSYN_BENCH_THREADS overrides) and, as in `mosyn train`, the
// CPU block cache (nn/cpu_block_cache.h; MOSYN_BENCH_NO_BLOCK_CACHE=1 leaves it out). A training
// step is timed after one untimed step. Also a 1024^2 float matmul to confirm the BLAS backend.
#include <benchmark/benchmark.h>
#include <cstdlib>
#include <torch/optim/adam.h>
#include <torch/utils.h>

#include "nn/cpu_block_cache.h"
#include "nn/model.h"

using namespace mosyn::nn;

namespace {

int pose_dim_of(int which) { return which == 0 ? 127 : 63; }
// MOSYN_BENCH_THREADS overrides the thread count.
const int kThreads = std::getenv("MOSYN_BENCH_THREADS") ? std::atoi(std::getenv("MOSYN_BENCH_THREADS")) : 2;

nlohmann::json config_of(int which) {
  switch (which) {
    case 0:
    case 1: return {{"num_steps", 8}, {"hidden", 128}, {"lstm_layers", 1}, {"tau", 10}};
    default: return {{"preset", "paper"}};
  }
}
const char* name_of(int which) { return which == 0 ? "shipped" : which == 1 ? "k8_h128" : "paper"; }

std::shared_ptr<MotionModel> make(int which) {
  set_num_threads(kThreads);
  if (!std::getenv("MOSYN_BENCH_NO_BLOCK_CACHE")) use_cpu_block_cache();  // as the trainer does
  torch::manual_seed(0);
  ModelContext ctx;
  ctx.pose_dim = pose_dim_of(which);
  ctx.control_dim = 3;
  ctx.pose_form = which == 0 ? mosyn::data::PoseForm::kRotations : mosyn::data::PoseForm::kPositions;
  return create_model("moglow", config_of(which), ctx);
}

void BM_Matmul1024(benchmark::State& state) {
  torch::set_num_threads(kThreads);
  auto a = torch::randn({1024, 1024}), b = torch::randn({1024, 1024});
  for (auto _ : state) benchmark::DoNotOptimize(a.matmul(b));
  state.counters["GFLOP/s"] = benchmark::Counter(2.0 * 1024 * 1024 * 1024, benchmark::Counter::kIsIterationInvariantRate);
  state.SetLabel(torch::get_parallel_info().find("OpenMP") != std::string::npos ? "openmp" : "");
}

void BM_TrainStep(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  auto model = make(which);
  model->train();
  torch::optim::Adam opt(model->parameters(), torch::optim::AdamOptions(1e-4));
  Batch b{torch::randn({100, 60, pose_dim_of(which)}), torch::randn({100, 60, 3}), {}, {}};
  auto step = [&] {
    auto terms = model->loss(b);
    opt.zero_grad();
    terms.loss().backward();
    opt.step();
  };
  step();  // untimed: ActNorm initialisation, Adam's state and the first allocations, as in training
  for (auto _ : state) step();
  state.SetLabel(name_of(which));
}

void BM_SampleFrame(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const int batch = static_cast<int>(state.range(1));
  auto model = make(which);
  model->eval();
  SampleRequest req;
  req.batch = batch;
  req.seed = 1;
  auto stream = model->begin_stream(req);
  auto control = torch::randn({batch, 3});
  for (auto _ : state) benchmark::DoNotOptimize(model->step_stream(*stream, control).pose);
  state.SetLabel(std::string(name_of(which)) + " batch " + std::to_string(batch));
}

}  // namespace

BENCHMARK(BM_Matmul1024)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TrainStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(5.0);
BENCHMARK(BM_TrainStep)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_SampleFrame)->Args({0, 1})->Args({0, 64})->Args({1, 1})->Args({1, 64})->Args({2, 1})->Args({2, 64})
    ->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK_MAIN();
