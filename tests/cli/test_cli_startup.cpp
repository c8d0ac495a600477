// The light `mosyn` binary links no LibTorch (so file commands start at once) and hands the model
// commands to mosyn-torch beside it; without mosyn-torch those commands fail clearly.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "cli_test_util.h"

using namespace mosyn::testing;
namespace fs = std::filesystem;

namespace {

std::string output_of(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
  pclose(pipe);
  return out;
}

}  // namespace

TEST(CliStartup, LightBinaryNeedsNoLibTorch) {
  const std::string needed = output_of("readelf -d " + std::string(MOSYN_CLI_PATH) + " 2>&1");
  ASSERT_NE(needed.find("NEEDED"), std::string::npos) << needed;  // readelf ran and found the list
  for (const char* lib : {"libtorch", "libc10", "libgomp", "libopenblas"})
    EXPECT_EQ(needed.find(lib), std::string::npos) << lib << " in\n" << needed;
  const std::string torch_bin = (fs::path(MOSYN_CLI_PATH).parent_path() / "mosyn-torch").string();
  EXPECT_NE(output_of("readelf -d " + torch_bin + " 2>&1").find("libtorch"), std::string::npos);
}

TEST(CliStartup, ModelCommandsGoToMosynTorchWithTheWholeCommandLine) {
  const auto help = run_mosyn("sample --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--temperature"), std::string::npos);  // mosyn-torch's sample help
  const auto listed = run_mosyn("--help");
  EXPECT_EQ(listed.exit_code, 0);
  EXPECT_NE(listed.out.find("train sample export eval report compare serve"), std::string::npos);
  const auto usage = run_mosyn("train");  // a usage error reported by mosyn-torch keeps its code
  EXPECT_EQ(usage.exit_code, 2);
}

TEST(CliStartup, WithoutMosynTorchModelCommandsFailClearly) {
  const fs::path dir = fresh_dir("startup_alone");
  fs::copy_file(MOSYN_CLI_PATH, dir / "mosyn");
  const std::string cmd = (dir / "mosyn").string() + " sample run --out x 2>&1; echo rc=$?";
  const std::string out = output_of(cmd);
  EXPECT_NE(out.find("needs " + (dir / "mosyn-torch").string()), std::string::npos) << out;
  EXPECT_NE(out.find("rc=1"), std::string::npos) << out;
  const std::string info = output_of((dir / "mosyn").string() + " --version; echo rc=$?");
  EXPECT_NE(info.find("rc=0"), std::string::npos) << info;  // file commands still work alone
}
