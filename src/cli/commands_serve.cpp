// `mosyn serve`: the live page, where the keyboard or a gamepad steers characters the model
// animates in real time (src/serve/README.md).
#include <pthread.h>
#include <signal.h>

#include <iostream>
#include <memory>
#include <mutex>

#include "cli/cli.h"
#include "serve/server.h"

namespace mosyn::cli {
namespace {

struct ServeArgs {
  std::string run_dir;
  serve::ServerOptions server;
};

void run_serve(const ServeArgs& a) {
  if (a.server.port < 0 || a.server.port > 65535) throw UsageError("--port must be in 0..65535");
  if (a.server.threads < 1) throw UsageError("--threads must be >= 1");
  if (a.server.max_connections < 1) throw UsageError("--max-connections must be >= 1");
  if (a.server.session.limits.max_characters < 1 || a.server.session.limits.max_characters > 64)
    throw UsageError("--max-characters must be in 1..64");
  // Ctrl-C and SIGTERM end the server cleanly: blocked in every thread the server starts, and
  // waited for here.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::mutex log_mutex;  // the server logs from several threads
  serve::Server server(a.run_dir, a.server, [&log_mutex](const std::string& line) {
    std::lock_guard<std::mutex> lock(log_mutex);
    std::cerr << line << std::endl;
  });
  server.start();
  std::cout << "serving " << a.run_dir << " at " << server.url() << " (open it in a browser; Ctrl-C stops)"
            << std::endl;
  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  std::cerr << "stopping" << std::endl;
  server.stop();
}

}  // namespace

void add_serve_command(CLI::App& app, Action* action) {
  auto a = std::make_shared<ServeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "serve",
      "A live page where arrow keys / WASD or a gamepad steer characters the model animates in real time "
      "(HTTP and WebSocket on one port; one stream per connection)");
  cmd->add_option("run", a->run_dir, "run or model directory of a streaming family (e.g. models/moglow-locomotion)")
      ->required();
  cmd->add_option("--port", a->server.port, "TCP port (default 8080; 0 = any free port)");
  cmd->add_option("--host", a->server.host, "address to bind (default 127.0.0.1: this machine only)");
  cmd->add_option("--threads", a->server.threads, "LibTorch threads per stream step (default 1)");
  cmd->add_option("--max-characters", a->server.session.limits.max_characters,
                  "characters per connection (default 4; each costs a model row every frame)");
  cmd->add_option("--max-connections", a->server.max_connections, "connections at once (default 4)");
  cmd->add_option("--seed", a->server.session.seed, "noise seed of the streams (default 0)");
  cmd->callback([action, a] { *action = [a] { run_serve(*a); }; });
}

}  // namespace mosyn::cli
