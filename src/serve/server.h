// `mosyn serve`: a local HTTP + WebSocket server (websocketpp over Boost.Asio, one port) that
// serves the live page at "/" and streams one Generator per WebSocket connection (any other
// path), each advanced on its own worker thread (serve/session.h). The network runs on one
// thread of its own, which never runs the model. Protocol: serve/protocol.h and README.md here.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "serve/session.h"

namespace mosyn::serve {

struct ServerOptions {
  std::string host = "127.0.0.1";  // an IP address or "localhost"; loopback keeps others out
  int port = 8080;                 // 0 = any free port (port() says which)
  int threads = 1;                 // LibTorch threads each stream's step uses (set process-wide)
  int max_connections = 4;         // WebSocket connections at once; more are refused (HTTP 503)
  size_t max_buffered_bytes = 1 << 20;  // frames are dropped while a client leaves this much unread
  SessionOptions session;          // per connection: characters, limits, message rates
};

// A line for the operator (connections opened and closed, with their frame rate and CPU use);
// called from the network thread and from the streams' workers, so it must be thread-safe.
using Log = std::function<void(const std::string& line)>;

class Server {
 public:
  // Loads run_dir once to check it (and to set LibTorch's threads). Throws mosyn::Error when the
  // run cannot be loaded, its family cannot stream frame by frame, the live page is unavailable
  // (built without npm) or an option is out of range.
  Server(const std::string& run_dir, const ServerOptions& options, Log log = {});
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds host:port and serves on a thread of its own; returns once listening. Throws mosyn::Error
  // when the address is not valid or cannot be bound (e.g. the port is taken).
  void start();
  // Closes every connection, ends their streams and the network thread. Safe to call twice.
  void stop();
  int port() const;         // the bound port (after start)
  std::string url() const;  // "http://host:port/"
  int connections() const;  // open WebSocket connections

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mosyn::serve
