// Headless Chromium driven over the DevTools protocol through --remote-debugging-pipe (requests
// as NUL-terminated JSON on fd 3, replies and events on fd 4): open a page, evaluate script in it,
// press and release real keys, take screenshots. For the live page's browser test.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace mosyn::serve::testing {

class Chromium {
 public:
  // Starts `chromium` headless (software WebGL) at width x height with a profile in profile_dir,
  // showing url, and attaches to that page.
  Chromium(const std::string& chromium, const std::string& url, int width, int height, const std::string& profile_dir) {
    int to_browser[2], from_browser[2];
    // Close-on-exec: chromium gets only fds 3 and 4 (dup2 clears the flag there).
    if (pipe2(to_browser, O_CLOEXEC) != 0 || pipe2(from_browser, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    std::vector<std::string> args{chromium, "--headless", "--no-sandbox", "--use-angle=swiftshader",
                                  "--enable-unsafe-swiftshader", "--disable-gpu", "--remote-debugging-pipe",
                                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                                  "--no-first-run", "--hide-scrollbars", "--user-data-dir=" + profile_dir,
                                  "--window-size=" + std::to_string(width) + "," + std::to_string(height), url};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    if (pid_ == 0) {  // only async-signal-safe calls until exec
      const int reads = fcntl(to_browser[0], F_DUPFD_CLOEXEC, 10);  // above 4 first: one may be 3 or 4
      const int writes = fcntl(from_browser[1], F_DUPFD_CLOEXEC, 10);
      dup2(reads, 3);
      dup2(writes, 4);
      const int null = open("/dev/null", O_WRONLY);
      dup2(null, 1);
      dup2(null, 2);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(to_browser[0]);
    close(from_browser[1]);
    out_ = to_browser[1];
    in_ = from_browser[0];
    attach();
  }

  ~Chromium() {
    try {
      call("Browser.close", {}, false);
    } catch (...) {
    }
    for (int i = 0; i < 50 && waitpid(pid_, nullptr, WNOHANG) == 0; ++i) usleep(100000);
    if (waitpid(pid_, nullptr, WNOHANG) == 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    close(out_);
    close(in_);
  }

  // A DevTools command (on the page when `page`, else on the browser); returns its result.
  nlohmann::json call(const std::string& method, const nlohmann::json& params = {}, bool page = true,
                      double timeout_s = 30) {
    nlohmann::json request{{"id", ++id_}, {"method", method}, {"params", params.is_null() ? nlohmann::json::object() : params}};
    if (page) request["sessionId"] = session_;
    const std::string text = request.dump() + '\0';
    if (write(out_, text.data(), text.size()) != static_cast<ssize_t>(text.size()))
      throw std::runtime_error("cannot write to chromium");
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      const size_t nul = buffer_.find('\0');
      if (nul != std::string::npos) {
        const auto reply = nlohmann::json::parse(buffer_.substr(0, nul));
        buffer_.erase(0, nul + 1);
        if (reply.value("id", -1) != id_) continue;  // an event or an older reply
        if (reply.contains("error")) throw std::runtime_error(method + ": " + reply["error"].dump());
        return reply["result"];
      }
      const int left = static_cast<int>(std::chrono::duration<double, std::milli>(end - std::chrono::steady_clock::now()).count());
      pollfd p{in_, POLLIN, 0};
      if (left <= 0 || poll(&p, 1, left) <= 0) throw std::runtime_error(method + ": no reply from chromium");
      char chunk[65536];
      const ssize_t n = read(in_, chunk, sizeof chunk);
      if (n <= 0) throw std::runtime_error("chromium closed its pipe");
      buffer_.append(chunk, static_cast<size_t>(n));
    }
  }

  // Value of a script expression in the page (JSON-serialisable).
  nlohmann::json evaluate(const std::string& expression) {
    const auto r = call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}});
    if (r.contains("exceptionDetails")) throw std::runtime_error("script error: " + r["exceptionDetails"].dump());
    return r["result"].value("value", nlohmann::json());
  }

  // A real key event: type "keyDown" or "keyUp"; code as KeyboardEvent.code (e.g. "ArrowUp").
  void key(const std::string& type, const std::string& code, int virtual_key_code) {
    call("Input.dispatchKeyEvent", {{"type", type}, {"code", code}, {"key", code}, {"windowsVirtualKeyCode", virtual_key_code}});
  }

  // The page as PNG bytes.
  std::string screenshot_png() {
    return call("Page.captureScreenshot", {{"format", "png"}})["data"].get<std::string>();  // base64
  }

 private:
  void attach() {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < end) {
      const nlohmann::json targets = call("Target.getTargets", {}, false);
      for (const auto& t : targets["targetInfos"])
        if (t["type"] == "page") {
          session_ = call("Target.attachToTarget", {{"targetId", t["targetId"]}, {"flatten", true}}, false)["sessionId"];
          return;
        }
      usleep(100000);
    }
    throw std::runtime_error("chromium opened no page");
  }

  pid_t pid_ = -1;
  int out_ = -1, in_ = -1;
  int id_ = 0;
  std::string buffer_, session_;
};

}  // namespace mosyn::serve::testing
