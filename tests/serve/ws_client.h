// A WebSocket test client (websocketpp's asio client on a thread of its own) that records what a
// mosyn server sends: frames counted, the last frame and every other message kept, the close code.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

namespace mosyn::serve::testing {

class WsClient {
 public:
  using Endpoint = websocketpp::client<websocketpp::config::asio_client>;

  // Connects to url (e.g. "ws://127.0.0.1:PORT/ws"); origin: an Origin header to send ("" = none).
  explicit WsClient(const std::string& url, const std::string& origin = "") {
    client_.clear_access_channels(websocketpp::log::alevel::all);
    client_.clear_error_channels(websocketpp::log::elevel::all);
    client_.init_asio();
    client_.set_open_handler([this](websocketpp::connection_hdl) { opened_ = true; });
    client_.set_fail_handler([this](websocketpp::connection_hdl h) {
      failed_ = true;
      http_status_ = client_.get_con_from_hdl(h)->get_response_code();
    });
    client_.set_close_handler([this](websocketpp::connection_hdl h) {
      close_code_ = client_.get_con_from_hdl(h)->get_remote_close_code();
      closed_ = true;
    });
    client_.set_message_handler([this](websocketpp::connection_hdl, Endpoint::message_ptr m) { on_message(m->get_payload()); });
    websocketpp::lib::error_code ec;
    auto con = client_.get_connection(url, ec);
    if (ec) throw std::runtime_error("bad url " + url + ": " + ec.message());
    if (!origin.empty()) con->append_header("Origin", origin);
    hdl_ = con->get_handle();
    client_.connect(con);
    thread_ = std::thread([this] { client_.run(); });
  }
  ~WsClient() {
    websocketpp::lib::error_code ec;
    if (opened_ && !closed_) client_.close(hdl_, websocketpp::close::status::normal, "bye", ec);
    for (int i = 0; i < 100 && opened_ && !closed_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    client_.stop();
    thread_.join();
  }

  void send(const std::string& text) {
    websocketpp::lib::error_code ec;
    client_.send(hdl_, text, websocketpp::frame::opcode::text, ec);
  }
  void send_binary(const std::string& bytes) {
    websocketpp::lib::error_code ec;
    client_.send(hdl_, bytes, websocketpp::frame::opcode::binary, ec);
  }

  // Waits up to `seconds` for pred() (checked every 10 ms); returns its last value.
  bool wait_for(const std::function<bool()>& pred, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!pred()) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return true;
  }

  long frames() const { return frames_; }
  bool opened() const { return opened_; }
  bool closed() const { return closed_; }
  bool failed() const { return failed_; }
  int close_code() const { return close_code_; }
  int http_status() const { return http_status_; }
  nlohmann::json last_frame() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_frame_;
  }
  std::vector<nlohmann::json> others() const {  // hello, errors, added
    std::lock_guard<std::mutex> lock(mutex_);
    return others_;
  }
  size_t errors() const {
    size_t n = 0;
    for (const auto& m : others()) n += m["type"] == "error";
    return n;
  }

 private:
  void on_message(const std::string& text) {
    auto j = nlohmann::json::parse(text);
    std::lock_guard<std::mutex> lock(mutex_);
    if (j["type"] == "frame") {
      last_frame_ = std::move(j);
      ++frames_;
    } else {
      others_.push_back(std::move(j));
    }
  }

  Endpoint client_;
  websocketpp::connection_hdl hdl_;
  std::thread thread_;
  std::atomic<bool> opened_{false}, closed_{false}, failed_{false};
  std::atomic<int> close_code_{0}, http_status_{0};
  std::atomic<long> frames_{0};
  mutable std::mutex mutex_;
  nlohmann::json last_frame_;
  std::vector<nlohmann::json> others_;
};

}  // namespace mosyn::serve::testing
