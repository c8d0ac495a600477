// Runs the mosyn binary in a subprocess and captures its exit code and output.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <algorithm>
#include <string>

#include "data/prepare.h"

namespace mosyn::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

inline std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// args is appended to the binary path as-is (quote paths yourself when they contain spaces).
inline CommandResult run_mosyn(const std::string& args) {
  namespace fs = std::filesystem;
  static int counter = 0;
  const fs::path dir = fs::temp_directory_path() / ("mosyn_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string out = (dir / ("out" + std::to_string(counter))).string();
  const std::string err = (dir / ("err" + std::to_string(counter++))).string();
  const std::string cmd = std::string(MOSYN_CLI_PATH) + " " + args + " >" + out + " 2>" + err + " </dev/null";
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

// A fresh empty temporary directory for one test.
inline std::filesystem::path fresh_dir(const std::string& name) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("mosyn_test_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A small synthetic Bandai-like source (root/source), its dataset (root/dataset, windows of 40
// frames) and a tiny MoGlow run trained for a few steps (root/run), made through the CLI.
// Returns "" on success, else the failing command's stderr. extra_prepare_flags go to
// `data prepare`.
inline std::string make_tiny_moglow_run(const std::string& root, const std::string& extra_prepare_flags = "",
                                        int steps = 4) {
  data::write_synthetic_source(root + "/source", 2, 90, 3);
  const auto prep = run_mosyn("data prepare " + root + "/source --out " + root +
                              "/dataset --window 40 --hop 10 --val 0.25 --threads 1 " + extra_prepare_flags);
  if (prep.exit_code != 0) return "data prepare: " + prep.err;
  std::ofstream(root + "/tiny.json") << R"({"model": {"num_steps": 2, "hidden": 16, "tau": 4}})";
  const int every = std::max(1, steps / 2);
  const auto train = run_mosyn("train moglow --data " + root + "/dataset --out " + root + "/run --config " + root +
                               "/tiny.json --steps " + std::to_string(steps) + " --batch 4 --window 20 --warmup 0" +
                               " --validate-every " + std::to_string(every) + " --checkpoint-every " +
                               std::to_string(every) + " --threads 1");
  if (train.exit_code != 0) return "train: " + train.err;
  return "";
}

}  // namespace mosyn::testing
