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

// What `mosyn` alone prints: every command with one example, from the repository root.
constexpr const char* kOverview = R"(mosyn: probabilistic human-motion synthesis (BVH in, many natural motions out)

Draw motions from a shipped model (models/*/README.md):
  mosyn sample models/moglow-lookahead --out walks --n 4 --path "0,0 0,3 2,5" --content walk --style elderly
  mosyn sample models/moglow-realtime --realtime --out live --path "0,0,3 0,5"   # frame by frame, as a game runs it
  mosyn serve models/moglow-realtime             # steer characters live at http://127.0.0.1:8080
Look at motion:
  mosyn info take.bvh                            # joints, frames, fps, units
  mosyn render walks/*.bvh --out walks.png --filmstrip 8 --camera side --follow
  mosyn view walks/*.bvh --out walks.html        # a page that plays them in the browser
  mosyn metrics walks/*.bvh --reference takes/*.bvh   # footsteps, foot skating, bone lengths
Convert:
  mosyn convert take.bvh take.glb                # glTF for Blender and game engines (also .npy, .csv, .bvh)
  mosyn retarget take.bvh --to character.glb --out take-on-character.glb   # onto your own skeleton (BVH or glTF)
Train your own (docs/training.md):
  mosyn data prepare mocap/ --out data/loco --form positions --contents walk,run --fps 20 --mirror \
      --root-smoothing 0.7 --stats-from models/moglow-lookahead   # its features, to continue its weights
  mosyn train moglow --data data/loco --out runs/loco --init-from models/moglow-lookahead
  mosyn eval runs/loco --data data/loco          # beside the held-out takes
  mosyn compare runs/loco models/moglow-lookahead --data data/loco --out compared
  mosyn export runs/loco --out models/my-model

mosyn COMMAND --help tells every option of a command.
)";

}  // namespace

int main(int argc, char** argv) {
  if (argc == 1) {  // no command: what mosyn can do (still a usage error for scripts)
    std::cout << kOverview;
    return 2;
  }
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
  // A misspelt command would otherwise read as a stray argument (and with --help exit 0).
  if (argv[1][0] != '-') {
    const auto known = app.get_subcommands([&](CLI::App* sub) { return sub->get_name() == argv[1]; });
    if (known.empty()) {
      std::cerr << "mosyn: error: unknown command '" << argv[1] << "' (`mosyn` alone lists every command)\n";
      return 2;
    }
  }
  return mosyn::cli::run_app(app, action, argc, argv);
}
