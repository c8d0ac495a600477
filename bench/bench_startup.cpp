// Start-up of the command line: the light `mosyn` (no LibTorch) against `mosyn-torch`, each run as
// a subprocess that prints its version, and `mosyn info` on a small BVH file. Wall-clock per run.
#include <benchmark/benchmark.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/synthetic.h"
#include "io/bvh.h"

namespace {

void run_command(benchmark::State& state, const std::string& command) {
  for (auto _ : state) {
    const int status = std::system((command + " >/dev/null 2>&1").c_str());
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      state.SkipWithError(("failed: " + command).c_str());
      break;
    }
  }
}

const std::string kDir = MOSYN_CLI_DIR;

void BM_MosynVersion(benchmark::State& state) { run_command(state, kDir + "/mosyn --version"); }
BENCHMARK(BM_MosynVersion)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MosynTorchVersion(benchmark::State& state) { run_command(state, kDir + "/mosyn-torch --version"); }
BENCHMARK(BM_MosynTorchVersion)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MosynInfo(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / "mosyn_bench_startup.bvh";
  const mosyn::Skeleton skeleton = mosyn::make_synthetic_biped();
  mosyn::io::write_bvh(path.string(), mosyn::io::from_clip({skeleton, mosyn::make_synthetic_walk(skeleton, 60, 30.0)}));
  run_command(state, kDir + "/mosyn info " + path.string());
}
BENCHMARK(BM_MosynInfo)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
