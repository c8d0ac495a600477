#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <thread>

#include "cli/cli.h"
#include "core/error.h"

namespace mosyn::cli {

ProgressLine::ProgressLine() : tty_(isatty(fileno(stderr)) != 0), last_(std::chrono::steady_clock::now()) {}

ProgressLine::~ProgressLine() { finish(); }

void ProgressLine::update(const std::string& text, bool force) {
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_).count();
  if (tty_) {
    if (!force && printed_any_ && since < 0.1) return;
    std::fprintf(stderr, "\r\033[K%s", text.c_str());
    open_ = true;
  } else {
    if (!force && printed_any_ && since < 5.0) return;
    std::fprintf(stderr, "%s\n", text.c_str());
  }
  std::fflush(stderr);
  printed_any_ = true;
  last_ = now;
}

void ProgressLine::finish() {
  if (tty_ && open_) std::fprintf(stderr, "\n");
  open_ = false;
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  char buf[32];
  if (seconds < 60) {
    std::snprintf(buf, sizeof buf, "%.1fs", seconds);
  } else if (seconds < 3600) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(seconds) / 60, static_cast<int>(seconds) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(seconds) / 3600, (static_cast<int>(seconds) / 60) % 60);
  }
  return buf;
}

int default_threads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? static_cast<int>(n) : 1;
}

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  for (char c : text + ",") {
    if (c == ',') {
      if (!item.empty()) out.push_back(item);
      item.clear();
    } else if (c != ' ') {
      item += c;
    }
  }
  return out;
}

void add_common_setup_and_file_commands(CLI::App& app, Action* action) {
  app.description("mosyn: probabilistic human-motion synthesis (BVH in, many natural motions out)");
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("mosyn 0.1.0"));
  add_info_command(app, action);
  add_convert_command(app, action);
  add_retarget_command(app, action);
  add_data_commands(app, action);
  add_view_commands(app, action);
}

const std::vector<std::string>& torch_commands() {
  static const std::vector<std::string> kCommands = {"train", "sample", "export", "eval", "report", "compare", "serve"};
  return kCommands;
}

int run_app(CLI::App& app, const Action& action, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the message (or the help text); any usage problem exits with 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (action) action();
    return 0;
  } catch (const UsageError& e) {
    std::cerr << "mosyn: " << e.what() << "\n(see --help)\n";
    return 2;
  } catch (const InvalidArgument& e) {  // a job's option check: a usage error too
    std::cerr << "mosyn: " << e.what() << "\n(see --help)\n";
    return 2;
  } catch (const Error& e) {
    std::cerr << "mosyn: error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "mosyn: error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "mosyn: error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace mosyn::cli
