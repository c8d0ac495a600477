// Offline sampling (sample_motions) and the real-time Generator: both convert raw <-> standardised
// features with the run's statistics around MotionModel::sample / begin_stream / step_stream.
#include "nn/sampling.h"

#include <cmath>

#include <torch/types.h>
#include <torch/utils.h>

#include "core/error.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "nn/generator.h"
#include "nn/model.h"
#include "nn/standardiser.h"

namespace mosyn::nn {

namespace {

torch::Tensor from_vector(const std::vector<float>& v, int64_t rows, int64_t cols) {
  return torch::from_blob(const_cast<float*>(v.data()), {rows, cols}, torch::kFloat32).clone();
}

torch::Device model_device(MotionModel& m) {
  auto params = m.parameters();
  return params.empty() ? torch::Device(torch::kCPU) : params.front().device();
}

// Labels [b] from none, one label for all, or one per entry; checked against the run.
torch::Tensor label_tensor(const LoadedRun& run, const std::vector<int>& labels, int64_t b, int vocabulary,
                           const char* what) {
  if (!labels.empty() && labels.size() != 1 && static_cast<int64_t>(labels.size()) != b)
    throw Error(std::string(what) + " labels: give none, one, or one per character (" + std::to_string(b) + ")");
  std::vector<int64_t> ids(static_cast<size_t>(b), -1);
  for (int64_t i = 0; i < b && !labels.empty(); ++i) ids[i] = labels.size() == 1 ? labels[0] : labels[i];
  for (int64_t id : ids) {
    if (id == -1) continue;
    if (!run.traits.labels)
      throw Error(run.run_dir + ": this " + run.family + " model was trained without labels; a " + what +
                  " label needs a model trained with \"labels\": true");
    if (id < 0 || id >= vocabulary)
      throw Error(run.run_dir + ": " + what + " label " + std::to_string(id) + " is not in the model's vocabulary of " +
                  std::to_string(vocabulary));
  }
  return torch::tensor(ids, torch::kInt64);
}

// Fills the prefix and label fields of a request for batch size b.
void fill_request(SampleRequest& req, const LoadedRun& run, const Standardiser& st, int64_t b,
                  const std::vector<float>& prefix_pose, const std::vector<float>& prefix_control,
                  const std::vector<int>& content, const std::vector<int>& style) {
  const int64_t d = run.context.pose_dim, c = run.context.control_dim;
  if (!prefix_pose.empty()) {
    if (!run.traits.prefix)
      throw Error(run.run_dir + ": this " + run.family + " model cannot continue a given motion (no prefix)");
    if (prefix_pose.size() % d != 0) throw Error("prefix pose is not [P, " + std::to_string(d) + "]");
    const int64_t p = static_cast<int64_t>(prefix_pose.size()) / d;
    req.prefix_pose = st.pose(from_vector(prefix_pose, p, d)).unsqueeze(0).expand({b, p, d}).contiguous();
    if (!prefix_control.empty()) {
      if (prefix_control.size() != static_cast<size_t>(p * c))
        throw Error("prefix control must be [" + std::to_string(p) + ", " + std::to_string(c) + "]");
      req.prefix_control = st.control(from_vector(prefix_control, p, c)).unsqueeze(0).expand({b, p, c}).contiguous();
    }
  }
  req.content = label_tensor(run, content, b, run.context.num_content, "content");
  req.style = label_tensor(run, style, b, run.context.num_style, "style");
  req.batch = static_cast<int>(b);
}

// control [T, C] raw, preceded by w rows of its first step (row 1; zeros when T < 2): the
// warm-up of SampleExtras::warmup_frames.
std::vector<float> with_lead_in(const std::vector<float>& control, int64_t c, int64_t w) {
  std::vector<float> first_step(static_cast<size_t>(c), 0.0f);
  if (static_cast<int64_t>(control.size()) >= 2 * c) first_step.assign(control.begin() + c, control.begin() + 2 * c);
  std::vector<float> out;
  out.reserve(static_cast<size_t>(w * c) + control.size());
  for (int64_t k = 0; k < w; ++k) out.insert(out.end(), first_step.begin(), first_step.end());
  out.insert(out.end(), control.begin(), control.end());
  return out;
}

}  // namespace

std::vector<SampledMotion> sample_motions(const LoadedRun& run, const std::vector<float>& control, int n,
                                          std::uint64_t seed, double temperature, const SampleExtras& extras) {
  if (!run.model)
    throw Error(run.run_dir + ": the " + run.family + " family does not generate motion (it scores motions: use it with "
                "mosyn eval --classifier)");
  if (n < 1) throw Error("sample_motions: n must be >= 1");
  const int64_t d = run.context.pose_dim, c = run.context.control_dim;
  if (control.empty() || control.size() % c != 0)
    throw Error("sample_motions: control is not [T, " + std::to_string(c) + "]");
  if (extras.warmup_frames < 0 && extras.warmup_frames != kFamilyWarmup)
    throw Error("sample_motions: warmup_frames must be >= 0 or kFamilyWarmup");
  const int64_t t = static_cast<int64_t>(control.size()) / c;
  int64_t w = extras.warmup_frames;
  if (w == kFamilyWarmup) w = std::lround(run.traits.default_warmup_s * run.dataset.fps);
  // The real prefix is the start; a family that makes its own root motion takes no control lead-in.
  if (!extras.prefix_pose.empty() || run.traits.control != InputUse::kTakes) w = 0;
  std::vector<float> full_control = with_lead_in(control, c, w);
  Standardiser st(run.stats);
  auto& model = *run.model;
  const auto device = model_device(model);
  SampleRequest req;
  req.control =
      st.control(from_vector(full_control, w + t, c)).unsqueeze(0).expand({n, w + t, c}).contiguous().to(device);
  fill_request(req, run, st, n, extras.prefix_pose, extras.prefix_control, {extras.content}, {extras.style});
  if (req.prefix_pose.defined()) req.prefix_pose = req.prefix_pose.to(device);
  if (req.prefix_control.defined()) req.prefix_control = req.prefix_control.to(device);
  req.content = req.content.to(device);
  req.style = req.style.to(device);
  req.temperature = temperature;
  req.seed = seed;
  model.eval();
  const SampleOutput out = model.sample(req);
  const auto poses = st.unpose(out.pose.narrow(1, w, t).to(torch::kCPU, torch::kFloat32)).contiguous();
  std::vector<SampledMotion> result(n);
  if (run.traits.control == InputUse::kTakes) {  // exactly the caller's control, not a round trip
    for (auto& r : result) r.control = control;
  } else {
    const auto controls = st.uncontrol(out.control.narrow(1, w, t).to(torch::kCPU, torch::kFloat32)).contiguous();
    for (int i = 0; i < n; ++i) {
      const float* p = controls[i].data_ptr<float>();
      result[i].control.assign(p, p + t * c);
    }
  }
  for (int i = 0; i < n; ++i) {
    const float* p = poses[i].data_ptr<float>();
    result[i].pose.assign(p, p + t * d);
  }
  return result;
}

// ---------------------------------------------------------------------------------------------
// Generator

struct Generator::Impl {
  LoadedRun run;
  GeneratorOptions options;
  Standardiser st;
  std::unique_ptr<StreamState> stream;
  std::vector<RootPose> roots;
  int frames = 0;
  torch::Device device{torch::kCPU};
  // Control shaping (GeneratorOptions::control_smoothing_s): per character and channel, the
  // filter's output value and its rate of change per frame.
  double omega_per_frame = 0;  // 0 = no shaping
  std::vector<double> shaped, shaped_rate;
  std::vector<float> last_control;
  std::vector<StreamingFootLock> foot_locks;  // per character, with options.foot_lock
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

  // One frame of a critically damped second-order filter x'' = w^2 (u - x) - 2 w x' (exact
  // discretisation of its free response over one frame, input held constant).
  void shape(std::vector<float>& control) {
    if (omega_per_frame <= 0) return;
    const double w = omega_per_frame, e = std::exp(-w);
    for (size_t i = 0; i < control.size(); ++i) {
      const double x0 = shaped[i] - control[i], v0 = shaped_rate[i];
      // x(t) = (x0 + (v0 + w x0) t) e^{-w t}, at t = 1 frame.
      const double x1 = (x0 + (v0 + w * x0)) * e;
      const double v1 = (v0 - w * (v0 + w * x0)) * e;
      shaped[i] = control[i] + x1;
      shaped_rate[i] = v1;
      control[i] = static_cast<float>(shaped[i]);
    }
  }

  Impl(LoadedRun r, const GeneratorOptions& o) : run(std::move(r)), options(o), st(run.stats) {
    if (!run.model) throw Error("Generator: run has no model");
    if (!run.traits.streaming)
      throw Error("Generator: model family '" + run.family + "' cannot generate frame by frame");
    if (options.batch < 1) throw Error("Generator: batch must be >= 1");
    if (options.warmup_frames < 0) throw Error("Generator: warmup_frames must be >= 0");
    device = model_device(*run.model);
    run.model->eval();
    const double sigma_s =
        options.control_smoothing_s < 0 ? run.dataset.layout.root_smoothing_s : options.control_smoothing_s;
    if (sigma_s > 0) omega_per_frame = 1.31 / (sigma_s * run.dataset.fps);
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
    shaped.assign(values, 0.0);
    shaped_rate.assign(values, 0.0);
    last_control.assign(values, 0.0f);
    foot_locks.clear();
    if (options.foot_lock)
      for (int k = 0; k < options.batch; ++k)
        foot_locks.emplace_back(run.dataset.skeleton, run.dataset.fps, options.foot_lock_options);
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
  const int64_t b = m.options.batch, c = m.run.context.control_dim, d = m.run.context.pose_dim;
  const bool takes_control = m.run.traits.control == InputUse::kTakes;
  if (takes_control ? given.size() != static_cast<size_t>(b * c) : !given.empty())
    throw Error(takes_control ? "Generator::step: control must be [" + std::to_string(b) + ", " + std::to_string(c) + "]"
                              : "Generator::step: this " + m.run.family + " model makes its own root motion; give no control");
  for (size_t i = 0; i < given.size(); ++i)
    if (m.active[i / c] && !std::isfinite(given[i]))
      throw Error("Generator::step: the control holds a NaN or infinite value");
  torch::Tensor pose;
  if (takes_control) {
    m.last_control = given;
    for (int64_t k = 0; k < b; ++k)  // free slots stand still, whatever the caller passes for them
      if (!m.active[k]) std::fill_n(m.last_control.begin() + k * c, c, 0.0f);
    m.shape(m.last_control);
    auto ctrl = m.st.control(from_vector(m.last_control, b, c)).to(m.device);
    pose = m.run.model->step_stream(*m.stream, ctrl).pose;
  } else {
    const StreamFrame frame = m.run.model->step_stream(*m.stream, torch::Tensor());
    pose = frame.pose;
    const auto made = m.st.uncontrol(frame.control.to(torch::kCPU, torch::kFloat32)).contiguous();
    m.last_control.assign(made.data_ptr<float>(), made.data_ptr<float>() + b * c);
  }
  pose = m.st.unpose(pose.to(torch::kCPU, torch::kFloat32)).contiguous();
  const std::vector<float>& control = m.last_control;
  // Root pose: integrate the delta (metres -> skeleton units) from the previous root pose.
  const auto& sk = m.run.dataset.skeleton;
  const double units = sk.meters_per_unit > 0 ? 1.0 / sk.meters_per_unit : 1.0;
  for (int64_t k = 0; k < b && c >= 3; ++k) {
    RootDelta delta;
    delta.sideways = control[k * c + 0] * units;
    delta.forward = control[k * c + 1] * units;
    delta.turn_rad = control[k * c + 2];
    auto& r = m.roots[k];
    auto traj = integrate_root_deltas(sk, {RootDelta{}, delta}, r.position, r.heading_rad);
    r.position = traj.positions.back();
    r.heading_rad = traj.headings_rad.back();
  }
  ++m.frames;
  float* p = pose.data_ptr<float>();
  if (m.options.foot_lock)
    for (int64_t k = 0; k < b; ++k)
      if (m.active[k]) m.lock_feet(static_cast<int>(k), p + k * d);
  m.last_pose.assign(p, p + b * d);
  for (int64_t k = 0; k < b; ++k)
    if (!m.active[k]) std::fill_n(m.last_pose.begin() + k * d, d, 0.0f);
  return m.last_pose;
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
  std::fill_n(m.shaped.begin() + slot * c, c, 0.0);
  std::fill_n(m.shaped_rate.begin() + slot * c, c, 0.0);
  std::fill_n(m.last_control.begin() + slot * c, c, 0.0f);
  std::fill_n(m.last_pose.begin() + slot * d, d, 0.0f);
  if (m.options.foot_lock)
    m.foot_locks[slot] = StreamingFootLock(m.run.dataset.skeleton, m.run.dataset.fps, m.options.foot_lock_options);
  m.active[slot] = 1;
}

void Generator::remove(int slot) {
  auto& m = *impl_;
  if (slot < 0 || slot >= m.options.batch)
    throw Error("Generator::remove: slot " + std::to_string(slot) + " is not in [0, " + std::to_string(m.options.batch) + ")");
  m.active[slot] = 0;
  const int64_t c = m.run.context.control_dim;  // stands still at once: no shaped control left
  std::fill_n(m.shaped.begin() + slot * c, c, 0.0);
  std::fill_n(m.shaped_rate.begin() + slot * c, c, 0.0);
}

bool Generator::active(int slot) const { return impl_->active.at(slot) != 0; }

JointTransforms Generator::joint_transforms(int slot) const {
  const auto& m = *impl_;
  const auto& info = m.run.dataset;
  const int64_t d = m.run.context.pose_dim;
  const RootPose& r = m.roots.at(slot);
  JointTransforms out;
  Motion frame;
  if (m.frames == 0 || !m.active[slot]) {
    frame = Motion::rest(info.skeleton, 1, info.fps);
  } else {
    const std::vector<float> still(static_cast<size_t>(m.run.context.control_dim), 0.0f);
    frame = data::decode(info.skeleton, info.layout, m.last_pose.data() + slot * d, still.data(), 1, info.fps,
                         r.position, r.heading_rad);
  }
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

}  // namespace mosyn::nn
