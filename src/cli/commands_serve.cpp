// `mosyn serve`: the live page, where the keyboard or a gamepad steers characters the model
// animates in real time (src/serve/README.md).
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <memory>
#include <mutex>

#include "cli/cli.h"
#include "core/error.h"
#include "serve/server.h"

namespace mosyn::cli {
namespace {

struct ServeArgs {
  std::string run_dir;
  serve::ServerOptions server;
};

// Written by the stop signals' handler, read by run_serve (a self-pipe: write() is safe in a
// signal handler).
int stop_pipe[2] = {-1, -1};

void write_stop_byte(int signal_number) {
  const char byte = static_cast<char>(signal_number);
  const ssize_t written = ::write(stop_pipe[1], &byte, 1);
  (void)written;
}

void run_serve(const ServeArgs& a) {
  if (a.server.port < 0 || a.server.port > 65535) throw UsageError("--port must be in 0..65535");
  if (a.server.threads < 1) throw UsageError("--threads must be >= 1");
  if (a.server.max_connections < 1) throw UsageError("--max-connections must be >= 1");
  if (a.server.session.limits.max_characters < 1 || a.server.session.limits.max_characters > 64)
    throw UsageError("--max-characters must be in 1..64");
  // Ctrl-C and SIGTERM end the server cleanly. A handler (not sigwait with the signals blocked)
  // so that a signal reaching any thread counts, including threads that existed before this
  // function (a sanitizer's, a thread pool's) and would otherwise swallow it; and so that a
  // shell's background job, started with SIGINT ignored, still stops on it.
  if (::pipe(stop_pipe) != 0) throw Error(std::string("serve: cannot create a pipe: ") + std::strerror(errno));
  struct sigaction on_stop = {};
  on_stop.sa_handler = write_stop_byte;
  sigemptyset(&on_stop.sa_mask);
  on_stop.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &on_stop, nullptr);
  ::sigaction(SIGTERM, &on_stop, nullptr);
  std::mutex log_mutex;  // the server logs from several threads
  serve::Server server(a.run_dir, a.server, [&log_mutex](const std::string& line) {
    std::lock_guard<std::mutex> lock(log_mutex);
    std::cerr << line << std::endl;
  });
  server.start();
  std::cout << "serving " << a.run_dir << " at " << server.url() << " (open it in a browser; Ctrl-C stops)"
            << std::endl;
  char signal_byte = 0;
  while (::read(stop_pipe[0], &signal_byte, 1) < 0 && errno == EINTR) {
  }
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
  cmd->add_option("run", a->run_dir, "run or model directory of a streaming family (e.g. models/moglow-realtime)")
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
