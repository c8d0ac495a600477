// `mosyn train` and `mosyn sample` (wired once the nn layer lands).
#include "cli/cli.h"

namespace mosyn::cli {

void add_model_commands(CLI::App& app, Action* action) {}

}  // namespace mosyn::cli
