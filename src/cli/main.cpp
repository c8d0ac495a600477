// mosyn: probabilistic human-motion synthesis from the command line.
// Exit codes: 0 ok, 1 runtime or input error, 2 usage error.
#include <iostream>

#include "cli/cli.h"
#include "core/error.h"

int main(int argc, char** argv) {
  CLI::App app{"mosyn: probabilistic human-motion synthesis (BVH in, many natural motions out)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("mosyn 0.1.0"));
  mosyn::cli::Action action;
  mosyn::cli::add_info_command(app, &action);
  mosyn::cli::add_convert_command(app, &action);
  mosyn::cli::add_data_commands(app, &action);
  mosyn::cli::add_model_commands(app, &action);
  mosyn::cli::add_eval_commands(app, &action);
  mosyn::cli::add_serve_command(app, &action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints the message (or the help text); any usage problem exits with 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (action) action();
    return 0;
  } catch (const mosyn::cli::UsageError& e) {
    std::cerr << "mosyn: " << e.what() << "\n(see --help)\n";
    return 2;
  } catch (const mosyn::InvalidArgument& e) {  // a job's option check: a usage error too
    std::cerr << "mosyn: " << e.what() << "\n(see --help)\n";
    return 2;
  } catch (const mosyn::Error& e) {
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
