// mosyn: probabilistic human-motion synthesis from the command line. This binary links no LibTorch,
// so commands that only read, convert, measure or draw files start at once; the commands that run
// models (cli.h torch_commands()) are handed, with the whole command line, to `mosyn-torch` in the
// same folder. Exit codes: 0 ok, 1 runtime or input error, 2 usage error.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <iostream>
#include <string>

#include "cli/cli.h"

namespace {

// The first argument that is not an option: the sub-command, or "" when there is none.
std::string subcommand_of(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (argv[i][0] != '-') return argv[i];
  return "";
}

// mosyn-torch beside this executable (/proc/self/exe, else argv[0]).
std::string torch_binary(const char* argv0) {
  char self[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  std::string path = n > 0 ? std::string(self, static_cast<size_t>(n)) : std::string(argv0);
  const size_t slash = path.rfind('/');
  return (slash == std::string::npos ? std::string() : path.substr(0, slash + 1)) + "mosyn-torch";
}

}  // namespace

int main(int argc, char** argv) {
  const std::string command = subcommand_of(argc, argv);
  const auto& heavy = mosyn::cli::torch_commands();
  if (std::find(heavy.begin(), heavy.end(), command) != heavy.end()) {
    const std::string target = torch_binary(argv[0]);
    execv(target.c_str(), argv);  // returns only on failure
    std::cerr << "mosyn: error: '" << command << "' runs models and needs " << target << ": " << std::strerror(errno)
              << " (build the mosyn-torch target)\n";
    return 1;
  }
  CLI::App app;
  mosyn::cli::Action action;
  mosyn::cli::add_common_setup_and_file_commands(app, &action);
  std::string models = "Commands that run models (see mosyn <command> --help):";
  for (const auto& c : heavy) models += " " + c;
  app.footer(models);
  return mosyn::cli::run_app(app, action, argc, argv);
}
