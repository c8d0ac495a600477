// Shared pieces of the `mosyn` command line: error kinds, progress rendering, registration of
// sub-commands. Only main() turns errors into exit codes.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "io/file_name.h"

namespace mosyn::cli {

// A wrong flag value or flag combination found after parsing: exit code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Renders progress on stderr: a single rewritten line on a terminal, plain lines otherwise
// (at most one every few seconds, so logs stay short).
class ProgressLine {
 public:
  ProgressLine();
  ~ProgressLine();
  // Shows `text`; `force` prints even when throttled (e.g. the final state).
  void update(const std::string& text, bool force = false);
  // Ends the rewritten line so later output starts on a fresh line.
  void finish();

 private:
  bool tty_;
  bool open_ = false;
  std::chrono::steady_clock::time_point last_;
  bool printed_any_ = false;
};

// "1h02m", "3m05s", "12.3s".
std::string format_duration(double seconds);

// Each command group adds its sub-commands and the action to run once parsing succeeded.
using Action = std::function<void()>;
void add_info_command(CLI::App& app, Action* action);
void add_convert_command(CLI::App& app, Action* action);
void add_retarget_command(CLI::App& app, Action* action);  // retarget (no LibTorch)
void add_data_commands(CLI::App& app, Action* action);
void add_model_commands(CLI::App& app, Action* action);  // train, sample
void add_view_commands(CLI::App& app, Action* action);   // metrics, render, view (no LibTorch)
void add_eval_commands(CLI::App& app, Action* action);   // eval, report, compare
void add_serve_command(CLI::App& app, Action* action);   // the live page

// What both binaries' apps share: description, version flag, one sub-command required, and the
// commands that need no LibTorch (info, convert, data, metrics, render, view).
void add_common_setup_and_file_commands(CLI::App& app, Action* action);

// The commands that run models and so need LibTorch: the light `mosyn` binary hands them, with the
// whole command line, to `mosyn-torch` beside it (which also runs every light command).
const std::vector<std::string>& torch_commands();

// Parses argv into `app` and runs the registered action; maps errors to exit codes (0 ok, 1
// runtime or input error, 2 usage) and prints them. What both binaries' main() do.
int run_app(CLI::App& app, const Action& action, int argc, char** argv);

// The file name of a path ("a/b.bvh" -> "b.bvh").
std::string base_name(const std::string& path);

// Reads BVH files as clips, with a progress line for many files. Throws mosyn::Error naming the
// file for a malformed one.
std::vector<Clip> read_clips(const std::vector<std::string>& paths);

// Number of hardware threads, at least 1.
int default_threads();

// "a, b,c" -> {"a", "b", "c"}: comma-separated items, spaces dropped, empty items skipped.
std::vector<std::string> split_commas(const std::string& text);

using io::extension_of;  // io/file_name.h

}  // namespace mosyn::cli
