// mosyn-torch: every `mosyn` command, including those that run models (LibTorch). The light
// `mosyn` binary hands model commands to this one; it can also be called directly.
// Exit codes: 0 ok, 1 runtime or input error, 2 usage error.
#include "cli/cli.h"

int main(int argc, char** argv) {
  CLI::App app;
  mosyn::cli::Action action;
  mosyn::cli::add_common_setup_and_file_commands(app, &action);
  mosyn::cli::add_model_commands(app, &action);
  mosyn::cli::add_eval_commands(app, &action);
  mosyn::cli::add_serve_command(app, &action);
  return mosyn::cli::run_app(app, action, argc, argv);
}
