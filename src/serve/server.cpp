#include "serve/server.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <thread>
#include <vector>
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include "core/error.h"
#include "nn/run.h"
#include "render/view.h"

namespace mosyn::serve {
namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Handle = websocketpp::connection_hdl;
namespace close_code = websocketpp::close::status;

bool loopback(const std::string& host) { return host == "127.0.0.1" || host == "::1" || host == "localhost"; }

std::string format_stats(const SessionStats& s) {
  char line[160];
  std::snprintf(line, sizeof line, "%ld frames in %.1f s (%.1f fps), CPU %.1f%% of a core, %ld late", s.frames,
                s.wall_s, s.wall_s > 0 ? s.frames / s.wall_s : 0.0, s.wall_s > 0 ? 100 * s.cpu_s / s.wall_s : 0.0,
                s.late_frames);
  return line;
}

}  // namespace

struct Server::Impl {
  std::string run_dir;
  std::shared_ptr<const nn::LoadedRun> run;  // loaded once; every session streams over its model
  ServerOptions options;
  Log log;
  std::string page;
  WsServer ws;
  std::thread io;
  bool running = false;
  int bound_port = 0;
  std::atomic<int> open{0};
  // Touched by the network thread only while it runs (then by stop()).
  std::map<Handle, std::shared_ptr<Session>, std::owner_less<Handle>> sessions;
  std::vector<std::shared_ptr<Session>> closing;  // stopped, waiting for their workers to end

  void say(const std::string& line) const {
    if (log) log(line);
  }

  // A loopback server answers only requests addressed to loopback names (DNS rebinding), and a
  // browser's WebSocket only from its own page (Origin), so other sites cannot drive it.
  bool trusted(const WsServer::connection_ptr& con) const {
    const std::string host = con->get_request_header("Host");
    if (loopback(options.host)) {
      const std::string p = ":" + std::to_string(bound_port);
      if (host != "127.0.0.1" + p && host != "localhost" + p && host != "[::1]" + p) return false;
    }
    const std::string origin = con->get_request_header("Origin");
    return origin.empty() || origin == "http://" + host;
  }

  void on_http(Handle hdl) {
    auto con = ws.get_con_from_hdl(hdl);
    const std::string resource = con->get_resource();
    if (!trusted(con)) {
      con->set_status(websocketpp::http::status_code::forbidden);
    } else if (con->get_request().get_method() != "GET") {
      con->set_status(websocketpp::http::status_code::method_not_allowed);
    } else if (resource == "/" || resource.rfind("/?", 0) == 0) {
      con->set_status(websocketpp::http::status_code::ok);
      con->append_header("Content-Type", "text/html; charset=utf-8");
      con->append_header("Cache-Control", "no-store");
      con->set_body(page);
    } else {
      con->set_status(websocketpp::http::status_code::not_found);
    }
  }

  bool on_validate(Handle hdl) {
    auto con = ws.get_con_from_hdl(hdl);
    if (!trusted(con)) {
      con->set_status(websocketpp::http::status_code::forbidden);
      return false;
    }
    if (static_cast<int>(sessions.size()) >= options.max_connections) {
      con->set_status(websocketpp::http::status_code::service_unavailable);
      say("refused a connection: already " + std::to_string(sessions.size()) + " open");
      return false;
    }
    return true;
  }

  void on_open(Handle hdl) {
    auto con = ws.get_con_from_hdl(hdl);
    SessionOptions so = options.session;
    so.threads = options.threads;
    if (con->get_resource().find("positions=0") != std::string::npos) so.positions = false;
    WsServer* server = &ws;
    const size_t max_buffered = options.max_buffered_bytes;
    auto send = [server, hdl, max_buffered](const std::string& text, bool droppable) {
      websocketpp::lib::error_code ec;
      auto c = server->get_con_from_hdl(hdl, ec);
      if (ec || c->get_state() != websocketpp::session::state::open) return;
      if (droppable && c->get_buffered_amount() > max_buffered) return;  // a client that does not read
      c->send(text, websocketpp::frame::opcode::text);
    };
    auto close = [server, hdl](const std::string& reason) {
      websocketpp::lib::error_code ec;
      server->close(hdl, close_code::policy_violation, reason, ec);
    };
    auto finished = [this](const SessionStats& stats) { say("connection closed: " + format_stats(stats)); };
    auto session = std::make_shared<Session>(run, so, send, close, finished);
    sessions[hdl] = session;
    open = static_cast<int>(sessions.size());
    session->start();
    say("connection from " + con->get_remote_endpoint() + " (" + std::to_string(sessions.size()) + " open)");
  }

  void on_message(Handle hdl, WsServer::message_ptr message) {
    const auto it = sessions.find(hdl);
    if (it == sessions.end()) return;
    if (message->get_opcode() != websocketpp::frame::opcode::text) {
      websocketpp::lib::error_code ec;
      ws.close(hdl, close_code::unsupported_data, "text messages only", ec);
      return;
    }
    it->second->receive(message->get_payload());
  }

  void on_close(Handle hdl) {
    const auto it = sessions.find(hdl);
    if (it == sessions.end()) return;
    it->second->stop();
    closing.push_back(it->second);
    sessions.erase(it);
    open = static_cast<int>(sessions.size());
    reap();
  }

  // Joins the workers that have ended (at once).
  void reap() {
    for (auto it = closing.begin(); it != closing.end();) {
      if (!(*it)->finished()) {
        ++it;
        continue;
      }
      (*it)->join();
      it = closing.erase(it);
    }
  }

  void listen() {
    websocketpp::lib::error_code ec;
    websocketpp::lib::asio::error_code asio_ec;
    const auto address = boost::asio::ip::make_address(options.host == "localhost" ? "127.0.0.1" : options.host, asio_ec);
    if (asio_ec) throw Error("--host " + options.host + ": not an IP address (" + asio_ec.message() + ")");
    ws.listen(boost::asio::ip::tcp::endpoint(address, static_cast<unsigned short>(options.port)), ec);
    if (ec) throw Error("cannot listen on " + options.host + ":" + std::to_string(options.port) + ": " + ec.message());
    ws.start_accept(ec);
    if (ec) throw Error("cannot accept connections: " + ec.message());
    bound_port = ws.get_local_endpoint(asio_ec).port();
  }
};

Server::Server(const std::string& run_dir, const ServerOptions& options, Log log) : impl_(std::make_unique<Impl>()) {
  if (options.port < 0 || options.port > 65535) throw Error("port " + std::to_string(options.port) + " is not in 0..65535");
  if (options.max_connections < 1) throw Error("at least one connection must be allowed");
  if (options.threads < 1) throw Error("threads must be >= 1");
  if (options.session.limits.max_characters < 1 || options.session.limits.max_characters > 64)
    throw Error("max characters " + std::to_string(options.session.limits.max_characters) + " is not in 1..64");
  auto run = std::make_shared<const nn::LoadedRun>(nn::load_run(run_dir, {"checkpoint.pt", "cpu", options.threads}));
  if (!run->model || !run->traits.streaming)
    throw Error(run_dir + ": the " + run->family + " family cannot generate frame by frame, so it cannot be steered live");
  impl_->run = std::move(run);
  impl_->run_dir = run_dir;
  impl_->options = options;
  impl_->log = std::move(log);
  impl_->page = render::live_page("mosyn live: " + run_dir);
}

Server::~Server() { stop(); }

void Server::start() {
  auto& m = *impl_;
  if (m.running) return;
  m.ws.clear_access_channels(websocketpp::log::alevel::all);  // the library never prints
  m.ws.clear_error_channels(websocketpp::log::elevel::all);
  m.ws.init_asio();
  m.ws.set_reuse_addr(true);
  m.ws.set_max_message_size(kMaxMessageBytes);
  m.ws.set_max_http_body_size(kMaxMessageBytes);
  m.ws.set_http_handler([&m](Handle h) { m.on_http(h); });
  m.ws.set_validate_handler([&m](Handle h) { return m.on_validate(h); });
  m.ws.set_open_handler([&m](Handle h) { m.on_open(h); });
  m.ws.set_message_handler([&m](Handle h, WsServer::message_ptr msg) { m.on_message(h, msg); });
  m.ws.set_close_handler([&m](Handle h) { m.on_close(h); });
  m.ws.set_fail_handler([&m](Handle h) { m.on_close(h); });
  m.listen();
  m.running = true;
  m.io = std::thread([&m] {
    m.ws.run();  // returns once stop() stops the io service
  });
}

void Server::stop() {
  auto& m = *impl_;
  if (!m.running) return;
  m.running = false;
  boost::asio::post(m.ws.get_io_service(), [&m] {
    websocketpp::lib::error_code ec;
    m.ws.stop_listening(ec);
    for (auto& [hdl, session] : m.sessions) {
      session->stop();
      m.ws.close(hdl, close_code::going_away, "server stopping", ec);
    }
  });
  // Let the close handshakes go out (a client that does not answer is cut off after 1 s).
  for (int i = 0; i < 100 && m.open > 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  m.ws.stop();
  m.io.join();
  for (auto& [hdl, session] : m.sessions) m.closing.push_back(session);
  m.sessions.clear();
  m.open = 0;
  for (auto& session : m.closing) {
    session->stop();
    session->join();
  }
  m.reap();
}

int Server::port() const { return impl_->bound_port; }

std::string Server::url() const {
  const std::string& h = impl_->options.host;
  return "http://" + (h.find(':') != std::string::npos ? "[" + h + "]" : h) + ":" + std::to_string(impl_->bound_port) + "/";
}

int Server::connections() const { return impl_->open; }

}  // namespace mosyn::serve
