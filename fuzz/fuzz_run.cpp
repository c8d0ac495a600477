// libFuzzer harness: run directories (nn/run.h): config.json, stats.json and checkpoint.pt from one
// input (fuzz_input.h), loaded with nn::load_run as `mosyn sample` does. Needs LibTorch; the
// checkpoint is a LibTorch archive, whose own parser is not instrumented.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "fuzz_check.h"
#include "fuzz_input.h"
#include "nn/run.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  static const std::vector<std::string> kNames = {"config.json", "stats.json", "checkpoint.pt"};
  const auto dir = fuzz::scratch_dir("run");
  fuzz::write_files(dir, kNames, fuzz::split_input(data, size, kNames.size()));
  try {
    nn::load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
  } catch (const Error&) {
  }
  return 0;
}
