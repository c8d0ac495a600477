#include "serve/session.h"

#include <time.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "core/kinematics.h"
#include "nn/generator.h"
#include "nn/model.h"
#include "nn/run.h"

namespace mosyn::serve {
namespace {

constexpr size_t kMaxQueued = 256;  // messages waiting for the worker; more means a flood

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

// Rotation about +y by a heading (0 faces +z; positive turns left, towards +x).
Eigen::Quaterniond heading_rotation(double heading_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitY()));
}

// One character: its held input, labels, and where its Generator slot's origin lies in the world
// (a restart in a new style begins at the slot's origin, so the server places it where it stood).
struct Character {
  bool active = false;
  double forward = 0, turn = 0, speed_mps = 1.3;
  // Steered by a stick message (world velocity m/s and facing): held until the next stick or input.
  bool by_stick = false;
  double stick_vx_mps = 0, stick_vz_mps = 0, stick_facing_rad = 0;
  std::string style, content;
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  double origin_heading_rad = 0;
};

}  // namespace

struct Session::Stream {
  std::optional<nn::Generator> generator;
  std::vector<Character> characters;
  double fps = 30, meters_per_unit = 1;
  std::uint64_t starts = 0;  // characters started so far: each gets its own seed

  const nn::LoadedRun& run() const { return generator->run(); }

  // World root pose of character k in metres / radians.
  void world_root(int k, Eigen::Vector3d* position_m, double* heading_rad) const {
    const Character& c = characters[k];
    const nn::RootPose& r = generator->root(k);
    *position_m = c.origin_m + heading_rotation(c.origin_heading_rad) * (r.position * meters_per_unit);
    *heading_rad = c.origin_heading_rad + r.heading_rad;
  }

  // (Re)starts slot k with labels at a world pose; throws ProtocolError for an unknown label.
  void start_character(int k, const std::string& style, const std::string& content, const Eigen::Vector3d& at_m,
                       double heading_rad, std::uint64_t base_seed) {
    const auto& info = run().dataset;
    const bool labels = run().traits.labels;
    nn::CharacterOptions o;
    o.style = label_index(labels ? info.style_labels : std::vector<std::string>{}, style, "style");
    o.content = label_index(labels ? info.content_labels : std::vector<std::string>{}, content, "content");
    o.seed = base_seed + 0x9E3779B97F4A7C15ull * ++starts;
    generator->add(k, o);
    Character& c = characters[k];
    const double speed = c.speed_mps;  // the speed the client set stays
    c = Character{};
    c.active = true;
    c.speed_mps = speed;
    c.style = style;
    c.content = content;
    c.origin_m = at_m;
    c.origin_heading_rad = heading_rad;
  }

  // Character k's stick in its Generator slot's frame: its stick message turned from the world into
  // the slot's frame, or its held keys as one (forward at its speed along its heading, facing where
  // the turn takes it in half a second: a held turn key keeps the heading moving).
  std::array<float, 3> stick_of(int k, double turn_rate_rad_s) const {
    const Character& c = characters[k];
    if (!c.active) return {0, 0, 0};
    const double heading = generator->root(k).heading_rad;
    if (c.by_stick) {
      const double a = -c.origin_heading_rad, ca = std::cos(a), sa = std::sin(a);
      // Rotation about +y by a: x' = cos a x + sin a z, z' = -sin a x + cos a z.
      return {float(ca * c.stick_vx_mps + sa * c.stick_vz_mps), float(-sa * c.stick_vx_mps + ca * c.stick_vz_mps),
              float(c.stick_facing_rad - c.origin_heading_rad)};
    }
    const double v = c.forward * c.speed_mps;
    return {float(v * std::sin(heading)), float(v * std::cos(heading)),
            float(heading + 0.5 * c.turn * turn_rate_rad_s)};
  }

  // Everything the client sees of character k after the last step.
  CharacterFrame frame_of(int k, bool positions) const {
    const auto& sk = run().dataset.skeleton;
    const Character& c = characters[k];
    CharacterFrame f;
    f.id = k;
    f.style = c.style;
    f.content = c.content;
    world_root(k, &f.root_m, &f.heading_rad);
    const nn::JointTransforms jt = generator->joint_transforms(k);
    const Eigen::Quaterniond turn = heading_rotation(c.origin_heading_rad);
    f.hips_m = c.origin_m + turn * (jt.root_translation * meters_per_unit);
    f.rotations_wxyz = jt.rotations_wxyz;
    const Eigen::Quaterniond root_world =
        turn * Eigen::Quaterniond(jt.rotations_wxyz[0], jt.rotations_wxyz[1], jt.rotations_wxyz[2], jt.rotations_wxyz[3]);
    f.rotations_wxyz[0] = static_cast<float>(root_world.w());
    f.rotations_wxyz[1] = static_cast<float>(root_world.x());
    f.rotations_wxyz[2] = static_cast<float>(root_world.y());
    f.rotations_wxyz[3] = static_cast<float>(root_world.z());
    if (positions) {
      Motion m = Motion::rest(sk, 1, fps);
      for (int j = 0; j < m.num_joints; ++j) {
        const float* q = &f.rotations_wxyz[static_cast<size_t>(j) * 4];
        m.rotation(0, j) = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
      }
      m.translation(0, 0) = f.hips_m / meters_per_unit;
      const WorldPoses world = forward_kinematics(sk, m);
      for (int j = 0; j < m.num_joints; ++j) f.positions_m.push_back(world.position(0, j) * meters_per_unit);
    }
    return f;
  }
};

Session::Session(std::string run_dir, const SessionOptions& options, Send send, Close close, Finished finished)
    : run_dir_(std::move(run_dir)),
      options_(options),
      send_(std::move(send)),
      close_(std::move(close)),
      finished_callback_(std::move(finished)),
      tokens_(options.message_burst),
      last_receive_(std::chrono::steady_clock::now()) {}

Session::Session(std::shared_ptr<const nn::LoadedRun> run, const SessionOptions& options, Send send, Close close,
                 Finished finished)
    : Session(run ? run->run_dir : std::string(), options, std::move(send), std::move(close), std::move(finished)) {
  run_ = std::move(run);
}

Session::~Session() {
  stop();
  join();
}

void Session::start() { worker_ = std::thread([this] { work(); }); }

void Session::stop() {
  stop_ = true;
  wake_.notify_all();
}

void Session::join() {
  if (worker_.joinable() && worker_.get_id() != std::this_thread::get_id()) worker_.join();
}

SessionStats Session::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void Session::receive(const std::string& text) {
  std::string refusal, fatal;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closing_) return;
    // Token bucket: a burst of message_burst, refilled at max_messages_per_s.
    const auto now = std::chrono::steady_clock::now();
    const double dt = std::chrono::duration<double>(now - last_receive_).count();
    last_receive_ = now;
    tokens_ = std::min(options_.message_burst, tokens_ + dt * options_.max_messages_per_s);
    if (tokens_ < 1) {
      fatal = "too many messages";
    } else {
      tokens_ -= 1;
      try {
        const ClientMessage m = parse_client_message(text, options_.limits);
        if (inbox_.size() >= kMaxQueued) fatal = "too many messages waiting";
        else inbox_.push_back(m);
      } catch (const ProtocolError& e) {
        refusal = e.what();
        if (++errors_ > options_.max_errors) fatal = "too many refused messages";
      }
    }
    if (!fatal.empty()) closing_ = true;
  }
  if (!fatal.empty()) {
    close_(fatal);
    stop();
  } else if (!refusal.empty()) {
    send_(error_json(refusal), false);
  }
}

void Session::apply(Stream& s, const ClientMessage& m) {
  const int k = m.character;
  if (m.type != MessageType::kAdd && !s.characters[k].active)
    throw ProtocolError("character " + std::to_string(k) + " is not on stage");
  Character& c = s.characters[k];
  switch (m.type) {
    case MessageType::kInput:
      c.by_stick = false;
      c.forward = m.forward;
      c.turn = m.turn;
      if (m.speed_mps) c.speed_mps = *m.speed_mps;
      break;
    case MessageType::kStick:
      c.by_stick = true;
      c.stick_vx_mps = m.velocity_x_mps;
      c.stick_vz_mps = m.velocity_z_mps;
      c.stick_facing_rad = m.facing_rad;
      break;
    case MessageType::kStyle: {
      Eigen::Vector3d at;
      double heading;
      s.world_root(k, &at, &heading);
      s.start_character(k, m.style.value_or(c.style), m.content.value_or(c.content), at, heading, options_.seed);
      break;
    }
    case MessageType::kAdd: {
      int slot = 0;
      while (slot < options_.limits.max_characters && s.characters[slot].active) ++slot;
      if (slot == options_.limits.max_characters)
        throw ProtocolError("already " + std::to_string(slot) + " characters, the most this server allows");
      // Beside the others: a metre and a half apart along x, facing +z.
      s.start_character(slot, m.style.value_or(""), m.content.value_or(""), Eigen::Vector3d(1.5 * slot, 0, 0), 0,
                        options_.seed);
      send_(added_json(slot), false);
      break;
    }
    case MessageType::kRemove:
      s.generator->remove(k);
      c.active = false;
      break;
  }
}

void Session::loop(Stream& s) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / s.fps));
  const int batch = s.generator->batch(), dims = s.generator->control_dim();
  const bool takes_control = s.run().traits.control == nn::InputUse::kTakes && dims >= 3;
  std::vector<float> sticks(static_cast<size_t>(batch) * 3, 0.0f);
  auto next = Clock::now();
  for (long frame = 0; !stop_; ++frame) {
    std::deque<ClientMessage> messages;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      messages.swap(inbox_);
    }
    for (const auto& m : messages) {
      try {
        apply(s, m);
      } catch (const Error& e) {  // a label the model lacks, a family that cannot add characters
        send_(error_json(e.what()), false);
      }
    }
    if (takes_control) {
      for (int k = 0; k < batch; ++k) {
        const auto u = s.stick_of(k, options_.limits.turn_rate_rad_s);
        std::copy(u.begin(), u.end(), sticks.begin() + static_cast<size_t>(k) * 3);
      }
      s.generator->step_stick(sticks);
    } else {
      s.generator->step({});
    }
    std::vector<CharacterFrame> frames;
    for (int k = 0; k < batch; ++k)
      if (s.characters[k].active) frames.push_back(s.frame_of(k, options_.positions));
    send_(frame_json(frame, frame / s.fps, frames), true);
    next += period;
    std::unique_lock<std::mutex> lock(mutex_);
    ++stats_.frames;
    const auto now = Clock::now();
    if (now > next) {
      ++stats_.late_frames;
      if (now > next + 5 * period) next = now;  // far behind (a stalled machine): no burst to catch up
    }
    wake_.wait_until(lock, next, [this] { return stop_.load(); });
  }
}

// Makes the stream over the shared run (or loads run_dir): a Generator with one slot per character,
// all free but the first.
static void open_stream(const std::shared_ptr<const nn::LoadedRun>& shared, const std::string& run_dir,
                        const SessionOptions& options, std::optional<nn::Generator>* out) {
  // Threads set here, in the worker: OpenMP's thread count is per calling thread, and a thread
  // that never set it would run BLAS on a team as wide as the machine.
  nn::set_num_threads(options.threads);
  // A copy of a loaded run shares its model (LoadedRun::model is a shared pointer).
  nn::LoadedRun run = shared ? *shared : nn::load_run(run_dir, {"checkpoint.pt", "cpu", options.threads});
  nn::GeneratorOptions g;
  g.batch = options.limits.max_characters;
  g.seed = options.seed;
  g.warmup_frames = options.warmup_frames >= 0 ? options.warmup_frames
                                               : static_cast<int>(run.traits.default_warmup_s * run.dataset.fps + 0.5);
  out->emplace(std::move(run), g);
}

void Session::work() {
  double cpu0 = thread_cpu_seconds();
  auto wall0 = std::chrono::steady_clock::now();
  try {
    Stream s;
    open_stream(run_, run_dir_, options_, &s.generator);
    s.fps = s.run().dataset.fps;
    s.meters_per_unit = s.run().dataset.skeleton.meters_per_unit > 0 ? s.run().dataset.skeleton.meters_per_unit : 1.0;
    Character idle;
    idle.speed_mps = options_.initial_speed_mps;
    s.characters.assign(options_.limits.max_characters, idle);
    for (int k = 0; k < s.generator->batch(); ++k) s.generator->remove(k);
    send_(hello_json(s.run(), options_.limits), false);
    s.start_character(0, "", "", Eigen::Vector3d::Zero(), 0, options_.seed);
    cpu0 = thread_cpu_seconds();  // the stats are those of streaming, without loading and warm-up
    wall0 = std::chrono::steady_clock::now();
    loop(s);
  } catch (const std::exception& e) {  // a broken run or model: this connection ends, the server goes on
    if (!stop_) {
      send_(error_json(std::string("the stream stopped: ") + e.what()), false);
      close_("stream error");
    }
  }
  SessionStats stats;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.cpu_s = thread_cpu_seconds() - cpu0;
    stats_.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    stats = stats_;
  }
  if (finished_callback_) finished_callback_(stats);
  finished_ = true;
}

}  // namespace mosyn::serve
