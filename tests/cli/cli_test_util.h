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

// The tiny committed test models (tests/models/, made by scripts/make_test_models.sh from the
// project's synthetic motion), copied into a test's folder so tests may change them:
// copy_test_model(root, "moglow", "run") copies tests/models/moglow to root/run.
inline void copy_test_model(const std::string& root, const std::string& name, const std::string& as) {
  namespace fs = std::filesystem;
  fs::copy(fs::path(MOSYN_SOURCE_DIR) / "tests" / "models" / name, fs::path(root) / as,
           fs::copy_options::recursive | fs::copy_options::overwrite_existing);
}

// A small synthetic Bandai-like source (root/source), its dataset (root/dataset: joint rotations,
// mirrored copies, windows of 40 frames) and a tiny MoGlow run (root/run) trained on it for 6
// steps: the committed test models, no training here.
inline void make_tiny_moglow_run(const std::string& root) {
  data::write_synthetic_source(root + "/source", 2, 90, 3);
  copy_test_model(root, "dataset-rotations", "dataset");
  copy_test_model(root, "moglow", "run");
}

}  // namespace mosyn::testing
