// The light `mosyn` binary links no LibTorch (so file commands start at once) and hands the model
// commands to mosyn-torch beside it; without mosyn-torch those commands fail clearly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

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

namespace {

// The sub-commands of a CLI11 help text (the first word of each line under "Subcommands:").
std::vector<std::string> subcommands_in_help(const std::string& help) {
  std::vector<std::string> out;
  const size_t start = help.find("Subcommands:");
  if (start == std::string::npos) return out;
  size_t line = help.find('\n', start);
  while (line != std::string::npos && line + 3 < help.size() && help.compare(line + 1, 2, "  ") == 0) {
    const size_t begin = help.find_first_not_of(' ', line + 1);
    out.push_back(help.substr(begin, help.find_first_of(" \n", begin) - begin));
    line = help.find('\n', line + 1);
  }
  return out;
}

}  // namespace

// Every command of mosyn-torch is reachable from the light binary: listed as its own sub-command
// or handed over (cli.h torch_commands(), shown in the footer) — the two lists cannot drift.
TEST(CliStartup, EveryMosynTorchCommandIsReachableFromMosyn) {
  const std::string torch_bin = (fs::path(MOSYN_CLI_PATH).parent_path() / "mosyn-torch").string();
  const std::vector<std::string> all = subcommands_in_help(output_of(torch_bin + " --help"));
  const std::string light_help = output_of(std::string(MOSYN_CLI_PATH) + " --help");
  const std::vector<std::string> light = subcommands_in_help(light_help);
  const size_t footer = light_help.find("Commands that run models");
  ASSERT_NE(footer, std::string::npos);
  const std::string handed = light_help.substr(footer) + " ";
  EXPECT_GE(all.size(), 13u);
  for (const std::string& command : all) {
    const bool own = std::find(light.begin(), light.end(), command) != light.end();
    const bool handed_over = handed.find(" " + command + " ") != std::string::npos ||
                             handed.find(" " + command + "\n") != std::string::npos;
    EXPECT_TRUE(own != handed_over) << command << ": own " << own << ", handed over " << handed_over;
  }
}
