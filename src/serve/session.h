// One live connection's stream: its own Generator (one slot per character), advanced on its own
// worker thread at the run's frame rate, so a slow connection never holds up another and the
// network thread never runs the model. Knows nothing of sockets: it sends and closes through
// callbacks (src/serve/server.h wires them to WebSocket connections; tests call them directly).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <memory>
#include <string>
#include <thread>

#include "nn/run.h"
#include "serve/protocol.h"

namespace mosyn::serve {

struct SessionOptions {
  Limits limits;                   // bounds of client messages; max_characters = the Generator's batch
  int threads = 1;                 // LibTorch (and OpenMP BLAS) threads of the worker's steps
  int warmup_frames = -1;          // standing frames dropped when a character starts; -1 = the model's default
  std::uint64_t seed = 0;          // character n's noise seed derives from it (same inputs, same motion)
  bool positions = true;           // frames carry joint world positions (the page draws from them)
  double max_messages_per_s = 50;  // sustained client message rate; beyond it (and the burst) the
  double message_burst = 100;      // connection is closed as a flood
  int max_errors = 20;             // refused messages tolerated before the connection is closed
  double initial_speed_mps = 1.3;  // walking speed until the client sets one
};

// What a stream did, for the server's log: frames sent, wall and CPU seconds of its worker while
// streaming (from the first frame on: loading the run and warming up excluded).
struct SessionStats {
  long frames = 0;
  double wall_s = 0, cpu_s = 0;
  long late_frames = 0;  // steps that ended after the next frame was due (an overloaded machine)
};

class Session {
 public:
  // send(text, droppable): deliver a text message; droppable (frames) may be dropped when the client
  // does not keep up. close(reason): end the connection. Both are called from the worker thread,
  // close also from receive()'s caller; neither may call back into the Session.
  using Send = std::function<void(const std::string& text, bool droppable)>;
  using Close = std::function<void(const std::string& reason)>;
  // Called by the worker as it ends, with its final stats.
  using Finished = std::function<void(const SessionStats& stats)>;

  Session(std::string run_dir, const SessionOptions& options, Send send, Close close, Finished finished = {});
  // The same over a run already loaded (nn::load_run), shared with other sessions: its model is
  // const, and the session holds only its own stream state (a server loads its weights once).
  Session(std::shared_ptr<const nn::LoadedRun> run, const SessionOptions& options, Send send, Close close,
          Finished finished = {});
  ~Session();  // stop() and join()
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Starts the worker: loads the run, sends "hello", starts character 0, then one "frame" per period
  // of the run's fps until stop(). A load or model error is sent as an "error" and closes.
  void start();
  // One client text message (any thread). Refused messages get an "error" reply; a flood (more
  // than the burst beyond max_messages_per_s), more than max_errors refusals or a full queue close
  // the connection. Valid ones are applied by the worker before its next step.
  void receive(const std::string& text);
  // Asks the worker to end after its current step (does not wait).
  void stop();
  // Waits for the worker to end (call stop() first, or from a thread other than the worker).
  void join();
  // True once the worker has ended (join() then returns at once).
  bool finished() const { return finished_; }
  SessionStats stats() const;

 private:
  struct Stream;  // the worker's state (Generator and characters): only the worker touches it
  void work();
  void loop(Stream& stream);  // steps and sends at the run's fps until stop()
  void apply(Stream& stream, const ClientMessage& message);

  std::string run_dir_;
  std::shared_ptr<const nn::LoadedRun> run_;  // the shared run, or null: the worker loads run_dir_
  SessionOptions options_;
  Send send_;
  Close close_;
  Finished finished_callback_;
  std::thread worker_;
  std::atomic<bool> stop_{false}, finished_{false};
  mutable std::mutex mutex_;  // guards the members below
  std::condition_variable wake_;
  std::deque<ClientMessage> inbox_;
  double tokens_;
  std::chrono::steady_clock::time_point last_receive_;
  int errors_ = 0;
  bool closing_ = false;
  SessionStats stats_;
};

}  // namespace mosyn::serve
