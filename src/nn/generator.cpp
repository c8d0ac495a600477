// The real-time Generator: one frame per input, raw <-> standardised features with the run's
// statistics around MotionModel::begin_stream / step_stream(_ahead); each character's root is
// simulated by a data::RootController, whose prediction of the path ahead feeds models that read
// one (so they stay causal).
#include "nn/generator.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <torch/types.h>
#include <torch/utils.h>

#include "core/error.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "nn/model.h"
#include "nn/request_fill.h"
#include "nn/root_planting.h"
#include "nn/standardiser.h"

namespace mosyn::nn {
namespace {

// Checks a per-character input [B, n] (control or stick): its size and, on active slots, finite values.
void check_input(const std::vector<float>& input, int64_t b, int64_t n, const std::vector<char>& active,
                 const char* what) {
  if (input.size() != static_cast<size_t>(b * n))
    throw Error(std::string("Generator::") + what + ": expected [" + std::to_string(b) + ", " + std::to_string(n) +
                "] values, got " + std::to_string(input.size()));
  for (size_t i = 0; i < input.size(); ++i)
    if (active[i / n] && !std::isfinite(input[i]))
      throw Error(std::string("Generator::") + what + ": the input holds a NaN or infinite value");
}

// The stick that steers along a control row [3] (dx, dz metres, dtheta radians in the frame of the
// heading so far): its world velocity (m/s) and the heading it leads to; advances *heading_rad.
std::array<float, 3> stick_along(const float* delta, double* heading_rad, double fps) {
  const double c = std::cos(*heading_rad), s = std::sin(*heading_rad);  // core/trajectory.h's frame
  const double x = s * delta[1] + c * delta[0], z = c * delta[1] - s * delta[0];
  *heading_rad += delta[2];
  return {static_cast<float>(x * fps), static_cast<float>(z * fps), static_cast<float>(*heading_rad)};
}

}  // namespace

struct Generator::Impl {
  LoadedRun run;
  GeneratorOptions options;
  Standardiser st;
  std::unique_ptr<StreamState> stream;
  std::vector<RootPose> roots;
  int frames = 0;
  torch::Device device{torch::kCPU};
  // Per character, its simulated root (GeneratorOptions::control_smoothing_s): the filtered
  // control and the path it predicts ahead (for models that read one, ModelTraits::control_ahead_frames).
  data::RootControllerOptions controller_options;
  std::vector<data::RootController> controllers;
  std::vector<float> last_control;
  std::vector<float> ahead;  // raw [B, K, C]: the predicted control after this frame
  std::vector<StreamingFootLock> foot_locks;  // per character, with options.foot_lock
  std::vector<RootPlanter> planters;  // per character, for a family's own root motion (run.root_planting)
  std::vector<char> active;       // per slot: filled (add / start) or free (remove)
  std::vector<float> last_pose;   // raw [B, D] of the last step (zeros for free slots)

  // Pins the planted feet of character k's raw pose [D] in place (GeneratorOptions::foot_lock).
  void lock_feet(int k, float* pose) {
    if (!foot_locks[k].has_legs()) return;
    const auto& info = run.dataset;
    const RootPose& r = roots[k];
    const std::vector<float> still(static_cast<size_t>(run.context.control_dim), 0.0f);
    const Motion frame = data::decode(info.skeleton, info.layout, pose, still.data(), 1, info.fps, r.position,
                                      r.heading_rad);
    GroundTrajectory here;
    here.positions = {r.position};
    here.headings_rad = {r.heading_rad};
    std::vector<float> locked;
    data::encode_pose_against(info.skeleton, foot_locks[k].apply(frame), info.layout, here, &locked);
    std::copy(locked.begin(), locked.end(), pose);
  }

  // One frame of every character from last_control (families that take control; already filtered)
  // or the family's own root motion: the model's step, the roots moved, feet locked. Returns
  // last_pose.
  const std::vector<float>& advance() {
    const int64_t b = options.batch, c = run.context.control_dim, d = run.context.pose_dim;
    torch::Tensor pose;
    if (run.traits.control == InputUse::kTakes) {
      auto ctrl = st.control(from_vector(last_control, b, c)).to(device);
      const int64_t k_ahead = run.traits.control_ahead_frames;
      if (k_ahead > 0) {
        for (int64_t k = 0; k < b; ++k) controllers[k].predict(static_cast<int>(k_ahead), ahead.data() + k * k_ahead * c);
        auto predicted = st.control(from_vector(ahead, b * k_ahead, c)).view({b, k_ahead, c}).to(device);
        pose = run.model->step_stream_ahead(*stream, ctrl, predicted).pose;
      } else {
        pose = run.model->step_stream(*stream, ctrl).pose;
      }
    } else {
      const StreamFrame frame = run.model->step_stream(*stream, torch::Tensor());
      pose = frame.pose;
      const auto made = st.uncontrol(frame.control.to(torch::kCPU, torch::kFloat32)).contiguous();
      last_control.assign(made.data_ptr<float>(), made.data_ptr<float>() + b * c);
    }
    pose = st.unpose(pose.to(torch::kCPU, torch::kFloat32)).contiguous();
    for (size_t k = 0; k < planters.size(); ++k)
      if (active[k]) plant_root_frame(run, &planters[k], pose.data_ptr<float>() + k * d, last_control.data() + k * c);
    move_roots();
    ++frames;
    float* p = pose.data_ptr<float>();
    if (options.foot_lock)
      for (int64_t k = 0; k < b; ++k)
        if (active[k]) lock_feet(static_cast<int>(k), p + k * d);
    last_pose.assign(p, p + b * d);
    for (int64_t k = 0; k < b; ++k)
      if (!active[k]) std::fill_n(last_pose.begin() + k * d, d, 0.0f);
    return last_pose;
  }

  // Root poses: each character's delta (metres -> skeleton units) from its previous root pose.
  void move_roots() {
    const int64_t c = run.context.control_dim;
    if (c < 3) return;
    const auto& sk = run.dataset.skeleton;
    const double units = sk.meters_per_unit > 0 ? 1.0 / sk.meters_per_unit : 1.0;
    for (int64_t k = 0; k < options.batch; ++k) {
      RootDelta delta;
      delta.sideways = last_control[k * c + 0] * units;
      delta.forward = last_control[k * c + 1] * units;
      delta.turn_rad = last_control[k * c + 2];
      auto& r = roots[k];
      auto traj = integrate_root_deltas(sk, {RootDelta{}, delta}, r.position, r.heading_rad);
      r.position = traj.positions.back();
      r.heading_rad = traj.headings_rad.back();
    }
  }

  Impl(LoadedRun r, const GeneratorOptions& o) : run(std::move(r)), options(o), st(run.stats) {
    if (!run.model) throw Error("Generator: run has no model");
    if (!run.traits.streaming)
      throw Error("Generator: model family '" + run.family + "' cannot generate frame by frame");
    if (options.batch < 1) throw Error("Generator: batch must be >= 1");
    if (options.warmup_frames < 0) throw Error("Generator: warmup_frames must be >= 0");
    device = model_device(*run.model);
    if (run.model->is_training()) run.model->eval();  // load_run's already is: a shared model is not written
    controller_options.fps = run.dataset.fps;
    controller_options.smoothing_s =
        options.control_smoothing_s < 0 ? run.dataset.layout.root_smoothing_s : options.control_smoothing_s;
    if (run.traits.control == InputUse::kTakes && run.context.control_dim != 3)
      throw Error("Generator: a model steered by its root needs controls of 3 values (dx, dz, dtheta), this one takes " +
                  std::to_string(run.context.control_dim));
    start(options.seed);
  }

  // A stream of b characters with the given prefix, labels and seeds, warmed up.
  std::unique_ptr<StreamState> begin(int b, const std::vector<float>& prefix_pose,
                                     const std::vector<float>& prefix_control, const std::vector<int>& content,
                                     const std::vector<int>& style, std::vector<std::uint64_t> seeds) {
    SampleRequest req;
    fill_request(req, run, st, b, prefix_pose, prefix_control, content, style);
    if (req.prefix_pose.defined()) req.prefix_pose = req.prefix_pose.to(device);
    if (req.prefix_control.defined()) req.prefix_control = req.prefix_control.to(device);
    req.content = req.content.to(device);
    req.style = req.style.to(device);
    req.temperature = options.temperature;
    req.seed = seeds.front();
    if (run.traits.independent_rows) req.seeds = std::move(seeds);
    auto s = run.model->begin_stream(req);
    // Standing warm-up (see SampleExtras::warmup_frames): zero raw control, outputs dropped.
    if (options.warmup_frames > 0 && run.traits.control == InputUse::kTakes) {
      const auto still = st.control(torch::zeros({b, run.context.control_dim})).to(device);
      for (int k = 0; k < options.warmup_frames; ++k) run.model->step_stream(*s, still);
    }
    return s;
  }

  void start(std::uint64_t seed) {
    std::vector<std::uint64_t> seeds;
    for (int k = 0; k < options.batch; ++k) seeds.push_back(row_seed(seed, k));
    stream = begin(options.batch, options.prefix_pose, options.prefix_control, options.content, options.style, seeds);
    roots.assign(options.batch, RootPose{});
    active.assign(options.batch, 1);
    last_pose.assign(static_cast<size_t>(options.batch) * run.context.pose_dim, 0.0f);
    frames = 0;
    const size_t values = static_cast<size_t>(options.batch) * run.context.control_dim;
    controllers.assign(options.batch, data::RootController(controller_options));
    last_control.assign(values, 0.0f);
    ahead.assign(values * std::max(0, run.traits.control_ahead_frames), 0.0f);
    foot_locks.clear();
    if (options.foot_lock)
      for (int k = 0; k < options.batch; ++k)
        foot_locks.emplace_back(run.dataset.skeleton, run.dataset.fps, options.foot_lock_options);
    planters.clear();
    if (plants_root(run, options.raw_root)) planters.assign(options.batch, planter_after(run, options.prefix_pose));
  }
};

Generator::Generator(const std::string& run_dir, const GeneratorOptions& options)
    : Generator(load_run(run_dir, LoadOptions{options.checkpoint, options.device, options.threads}), options) {}

Generator::Generator(LoadedRun run, const GeneratorOptions& options)
    : impl_(std::make_unique<Impl>(std::move(run), options)) {}

Generator::~Generator() = default;
Generator::Generator(Generator&&) noexcept = default;
Generator& Generator::operator=(Generator&&) noexcept = default;

std::vector<float> Generator::step(const std::vector<float>& given) {
  auto& m = *impl_;
  const int64_t b = m.options.batch, c = m.run.context.control_dim;
  if (m.run.traits.control != InputUse::kTakes) {
    if (!given.empty())
      throw Error("Generator::step: this " + m.run.family + " model makes its own root motion; give no control");
    return m.advance();
  }
  check_input(given, b, c, m.active, "step: control");
  for (int64_t k = 0; k < b; ++k) {  // free slots stand still, whatever the caller passes for them
    data::RootController::Control delta{0, 0, 0};
    if (m.active[k]) delta = {given[k * c], given[k * c + 1], given[k * c + 2]};
    const auto shaped = m.controllers[k].step(delta);
    for (int i = 0; i < 3; ++i) m.last_control[k * c + i] = static_cast<float>(shaped[i]);
  }
  return m.advance();
}

std::vector<float> Generator::step_stick(const std::vector<float>& stick) {
  auto& m = *impl_;
  const int64_t b = m.options.batch, c = m.run.context.control_dim;
  if (m.run.traits.control != InputUse::kTakes)
    throw Error("Generator::step_stick: this " + m.run.family + " model makes its own root motion; use step()");
  check_input(stick, b, 3, m.active, "step_stick: stick");
  for (int64_t k = 0; k < b; ++k) {
    data::StickInput in;
    if (m.active[k]) in = {stick[k * 3], stick[k * 3 + 1], stick[k * 3 + 2]};
    else in.facing_rad = m.controllers[k].heading_rad();
    const auto shaped = m.controllers[k].step(in);
    for (int i = 0; i < 3; ++i) m.last_control[k * c + i] = static_cast<float>(shaped[i]);
  }
  return m.advance();
}

void Generator::reset(std::uint64_t seed) { impl_->start(seed); }

void Generator::add(int slot, const CharacterOptions& character) {
  auto& m = *impl_;
  if (slot < 0 || slot >= m.options.batch)
    throw Error("Generator::add: slot " + std::to_string(slot) + " is not in [0, " + std::to_string(m.options.batch) + ")");
  if (!m.run.traits.independent_rows)
    throw Error("Generator::add: the " + m.run.family + " family computes its batch as one state; characters "
                "cannot be added one by one (use reset)");
  auto one = m.begin(1, character.prefix_pose, character.prefix_control, {character.content}, {character.style},
                     {character.seed});
  m.run.model->copy_stream_row(*m.stream, slot, *one, 0);
  m.roots[slot] = RootPose{};
  const int64_t c = m.run.context.control_dim, d = m.run.context.pose_dim;
  m.controllers[slot].reset();
  std::fill_n(m.last_control.begin() + slot * c, c, 0.0f);
  std::fill_n(m.last_pose.begin() + slot * d, d, 0.0f);
  if (m.options.foot_lock)
    m.foot_locks[slot] = StreamingFootLock(m.run.dataset.skeleton, m.run.dataset.fps, m.options.foot_lock_options);
  if (!m.planters.empty()) m.planters[slot] = planter_after(m.run, character.prefix_pose);
  m.active[slot] = 1;
}

void Generator::start_from(int slot, const Generator& warmed, int from_slot, std::uint64_t seed) {
  auto& m = *impl_;
  const auto& w = *warmed.impl_;
  if (slot < 0 || slot >= m.options.batch || from_slot < 0 || from_slot >= w.options.batch)
    throw Error("Generator::start_from: slot " + std::to_string(slot) + " or " + std::to_string(from_slot) +
                " is out of range");
  if (w.run.model != m.run.model) throw Error("Generator::start_from: the two Generators run different models");
  if (!m.run.traits.independent_rows)
    throw Error("Generator::start_from: the " + m.run.family + " family computes its batch as one state");
  m.run.model->copy_stream_row(*m.stream, slot, *w.stream, from_slot);
  m.run.model->reseed_stream_row(*m.stream, slot, seed);
  m.controllers[slot] = w.controllers[from_slot];
  m.roots[slot] = w.roots[from_slot];
  const int64_t c = m.run.context.control_dim, d = m.run.context.pose_dim;
  std::copy_n(w.last_control.begin() + from_slot * c, c, m.last_control.begin() + slot * c);
  std::copy_n(w.last_pose.begin() + from_slot * d, d, m.last_pose.begin() + slot * d);
  if (m.options.foot_lock && w.options.foot_lock) m.foot_locks[slot] = w.foot_locks[from_slot];
  if (!m.planters.empty()) m.planters[slot] = w.planters.empty() ? planter_after(m.run, {}) : w.planters[from_slot];
  m.active[slot] = 1;
}

void Generator::remove(int slot) {
  auto& m = *impl_;
  if (slot < 0 || slot >= m.options.batch)
    throw Error("Generator::remove: slot " + std::to_string(slot) + " is not in [0, " + std::to_string(m.options.batch) + ")");
  m.active[slot] = 0;
  m.controllers[slot].reset();  // stands still at once: no filtered control left
}

bool Generator::active(int slot) const { return impl_->active.at(slot) != 0; }

Motion Generator::pose_motion(int slot) const {
  const auto& m = *impl_;
  const auto& info = m.run.dataset;
  const int64_t d = m.run.context.pose_dim;
  const RootPose& r = m.roots.at(slot);
  if (m.frames == 0 || !m.active[slot]) return Motion::rest(info.skeleton, 1, info.fps);
  const std::vector<float> still(static_cast<size_t>(m.run.context.control_dim), 0.0f);
  return data::decode(info.skeleton, info.layout, m.last_pose.data() + slot * d, still.data(), 1, info.fps, r.position,
                      r.heading_rad);
}

JointTransforms Generator::joint_transforms(int slot) const { return joint_transforms_of(pose_motion(slot)); }

JointTransforms joint_transforms_of(const Motion& frame) {
  JointTransforms out;
  out.rotations_wxyz.reserve(static_cast<size_t>(frame.num_joints) * 4);
  for (int j = 0; j < frame.num_joints; ++j) {
    const auto& q = frame.rotation(0, j);
    out.rotations_wxyz.insert(out.rotations_wxyz.end(), {float(q.w()), float(q.x()), float(q.y()), float(q.z())});
  }
  if (frame.num_joints > 0) out.root_translation = frame.translation(0, 0);
  return out;
}
int Generator::batch() const { return impl_->options.batch; }
int Generator::pose_dim() const { return impl_->run.context.pose_dim; }
int Generator::control_dim() const { return impl_->run.context.control_dim; }
int Generator::frames() const { return impl_->frames; }
const std::vector<float>& Generator::last_control() const { return impl_->last_control; }
const RootPose& Generator::root(int b) const { return impl_->roots.at(b); }
const LoadedRun& Generator::run() const { return impl_->run; }

std::vector<SampledMotion> stream_motions(const LoadedRun& run, const std::vector<float>& control, int n,
                                          std::uint64_t seed, double temperature, const SampleExtras& extras,
                                          bool foot_lock) {
  if (!run.model) throw Error(run.run_dir + ": the " + run.family + " family does not generate motion");
  if (n < 1) throw Error("stream_motions: n must be >= 1");
  const int64_t c = run.context.control_dim, d = run.context.pose_dim;
  if (control.empty() || control.size() % c != 0)
    throw Error("stream_motions: control is not [T, " + std::to_string(c) + "]");
  GeneratorOptions g;
  g.batch = n;
  g.seed = seed;
  g.temperature = temperature;
  g.prefix_pose = extras.prefix_pose;
  g.prefix_control = extras.prefix_control;
  g.raw_root = extras.raw_root;
  g.content = {extras.content};
  g.style = {extras.style};
  g.foot_lock = foot_lock;
  int lead_in = extras.warmup_frames == kFamilyWarmup
                    ? static_cast<int>(std::lround(run.traits.default_warmup_s * run.dataset.fps))
                    : std::max(0, extras.warmup_frames);
  const bool takes = run.traits.control == InputUse::kTakes;
  if (!extras.prefix_pose.empty()) lead_in = 0;  // the real prefix is the start
  if (!takes) g.warmup_frames = lead_in, lead_in = 0;  // no control to lead in along
  Generator generator(run, g);
  const int64_t t = static_cast<int64_t>(control.size()) / c;
  std::vector<SampledMotion> out(n);
  const auto stick_of = [&](const float* delta, double* heading_rad, int rows) {  // the same for every row
    const auto stick = stick_along(delta, heading_rad, run.dataset.fps);
    std::vector<float> sticks(static_cast<size_t>(rows) * 3);
    for (int k = 0; k < rows; ++k) std::copy(stick.begin(), stick.end(), sticks.begin() + k * 3);
    return sticks;
  };
  if (takes && lead_in > 0) {
    // The lead-in holds the control's first step (its row 1), as sample_motions' does: a character
    // that starts as the control starts, standing for a drawn path, walking for a take's control.
    GeneratorOptions wo = g;
    wo.batch = std::min(n, kWarmedCharacters);
    Generator warming(run, wo);
    const float still[3] = {0, 0, 0};
    double facing = 0;
    const std::vector<float> held = stick_of(t > 1 ? control.data() + c : still, &facing, wo.batch);
    for (int f = 0; f < lead_in; ++f) warming.step_stick(held);
    for (int k = 0; k < n; ++k) generator.start_from(k, warming, k % wo.batch, row_seed(seed, k));
  }
  for (auto& m : out) {
    m.pose.reserve(static_cast<size_t>(t * d));
    m.control.reserve(static_cast<size_t>(t * c));
  }
  double heading_rad = 0;  // of the given control, integrated
  for (int64_t f = 0; f < t; ++f) {
    const std::vector<float>& pose =
        takes ? generator.step_stick(stick_of(control.data() + f * c, &heading_rad, n)) : generator.step({});
    for (int k = 0; k < n; ++k) {
      out[k].pose.insert(out[k].pose.end(), pose.begin() + k * d, pose.begin() + (k + 1) * d);
      const auto& made = generator.last_control();
      out[k].control.insert(out[k].control.end(), made.begin() + k * c, made.begin() + (k + 1) * c);
    }
  }
  return out;
}

}  // namespace mosyn::nn
