// Recurrent VAE speed: one training step and the generation of a whole motion, for
//   shipped  the shipped model (models/rvae-locomotion: the paper's channels, latent 128, kernel
//            13 at 30 fps) on its data, 21 joint positions, D = 63; batch 32 x 120 frames
//   paper    the paper's network (kernel 25) on its 240-frame clips at 60 Hz, D = 63
// Generation: a 10-s control (300 frames) from the prior, one latent then free running, at batch
// 1 and 64 (the model is not causal: it makes the whole motion at once). C = 3. LibTorch runs with
// 2 threads (MOSYN_BENCH_THREADS overrides).
#include <benchmark/benchmark.h>
#include <cstdlib>
#include <torch/optim/adam.h>
#include <torch/utils.h>

#include "nn/model.h"

using namespace mosyn::nn;

namespace {

const int kThreads = std::getenv("MOSYN_BENCH_THREADS") ? std::atoi(std::getenv("MOSYN_BENCH_THREADS")) : 2;
constexpr int kPoseDim = 63;

std::shared_ptr<MotionModel> make(int which) {
  set_num_threads(kThreads);
  torch::manual_seed(0);
  ModelContext ctx;
  ctx.pose_dim = kPoseDim;
  ctx.control_dim = 3;
  ctx.pose_form = mosyn::data::PoseForm::kPositions;
  return create_model("rvae", {{"kernel", which == 0 ? 13 : 25}}, ctx);
}
const char* name_of(int which) { return which == 0 ? "shipped" : "paper"; }

void BM_RvaeTrainStep(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  auto model = make(which);
  model->train();
  torch::optim::Adam opt(model->parameters(), torch::optim::AdamOptions(5e-4));
  const int frames = which == 0 ? 120 : 240;
  Batch b{torch::randn({32, frames, kPoseDim}), torch::randn({32, frames, 3}), {}, {}};
  for (auto _ : state) {
    auto terms = model->loss(b);
    opt.zero_grad();
    terms.loss().backward();
    opt.step();
  }
  state.SetLabel(std::string(name_of(which)) + " batch 32 x " + std::to_string(frames));
}

void BM_RvaeSample10s(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const int batch = static_cast<int>(state.range(1));
  auto model = make(which);
  model->eval();
  SampleRequest req;
  req.control = torch::randn({batch, 300, 3});
  req.seed = 1;
  for (auto _ : state) benchmark::DoNotOptimize(model->sample(req).pose);
  state.SetLabel(std::string(name_of(which)) + " batch " + std::to_string(batch) + ", 300 frames");
}

}  // namespace

BENCHMARK(BM_RvaeTrainStep)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(3.0);
BENCHMARK(BM_RvaeSample10s)->Args({0, 1})->Args({0, 64})->Args({1, 1})->Args({1, 64})
    ->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK_MAIN();
