// Dynamic Future Net (dfn.h): the model, its three training objectives and stages, and
// generation (posterior over the prefix, then priors), offline and frame by frame.
#include "nn/dfn/dfn.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/utils.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "core/error.h"
#include "nn/label_features.h"

namespace mosyn::nn {

DfnImpl::DfnImpl(const DfnOptions& options, const ModelContext& context)
    : MotionModel("Dfn"), options_(options), context_(context) {
  if (context.pose_dim <= 0 || context.control_dim <= 0) throw Error("dfn: the model context has no dimensions");
  ae = register_module("ae", DfnAutoencoder(options, context));
  future = register_module("future", DfnFuture(options));
  const int label_dim = options.labels ? context.num_content + context.num_style : 0;
  dyn = register_module("dyn", DfnDynamics(options, label_dim));
  foot_ = FootObjectives(context, options.foot, "dfn");
  rollout_foot_ = FootObjectives(context, options.rollout_foot(), "dfn");
}

std::vector<LabelInput> DfnImpl::label_inputs() const {
  const int64_t c = dyn->label_dim();
  if (c == 0) return {};
  // Each labelled input ends with the label block (DfnDynamicsImpl::with_labels).
  const auto params = named_parameters();
  std::vector<LabelInput> out;
  for (const char* name : {"dyn.gru1.weight_ih", "dyn.prior_f.0.weight", "dyn.post_f.0.weight",
                           "dyn.prior_s.0.weight", "dyn.post_s.0.weight"})
    out.push_back({name, 1, params[name].size(1) - c});
  return out;
}

torch::Tensor DfnImpl::labels_of(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                                 const torch::TensorOptions& options) const {
  if (dyn->label_dim() == 0) return {};
  return label_features(content, style, batch, context_.num_content, context_.num_style, options);
}

// ---------------------------------------------------------------------------------------------
// Stages

namespace {
constexpr const char* kStageNames[] = {"autoencoder", "future", "dynamics"};
}  // namespace

std::vector<TrainingStage> DfnImpl::training_stages(const TrainStageDefaults& defaults) const {
  std::vector<int> steps = options_.stage_steps;
  if (steps.empty()) {
    const auto& f = options_.stage_fractions;
    const double sum = f[0] + f[1] + f[2];
    const int n = std::max(3, defaults.steps);
    const int a = std::max(1, static_cast<int>(std::lround(n * f[0] / sum)));
    const int b = std::max(1, static_cast<int>(std::lround(n * f[1] / sum)));
    steps = {a, b, std::max(1, n - a - b)};
  }
  const std::vector<std::vector<std::string>> trained = {{"ae"}, {"future"}, {"dyn"}};
  const std::vector<std::vector<std::string>> frozen = {{}, {"ae"}, {"ae", "future"}};
  std::vector<TrainingStage> stages;
  for (int i = 0; i < 3; ++i) {
    if (steps[i] == 0) continue;  // only absolute stage_steps can be 0: a stage already trained
    TrainingStage s;
    s.name = kStageNames[i];
    s.steps = steps[i];
    s.trained = trained[i];
    s.frozen = frozen[i];
    s.optimizer.lr = defaults.lr;
    // The run's Noam schedule, its warm-up scaled to the stage's share of the run.
    s.schedule.kind = ScheduleSpec::Kind::kNoam;
    s.schedule.warmup = static_cast<int>(std::lround(static_cast<double>(defaults.warmup) * steps[i] /
                                                     std::max(1, defaults.steps)));
    stages.push_back(s);
  }
  return stages;
}

void DfnImpl::begin_stage(int /*index*/, const TrainingStage& stage) {
  for (int i = 0; i < 3; ++i)
    if (stage.name == kStageNames[i]) {
      stage_ = i;
      return;
    }
  throw Error("dfn: unknown training stage '" + stage.name + "'");
}

// ---------------------------------------------------------------------------------------------
// Losses

void DfnImpl::check_batch(const Batch& batch, int64_t min_frames) const {
  const auto& p = batch.pose;
  const auto& c = batch.control;
  if (!p.defined() || p.dim() != 3 || p.size(2) != context_.pose_dim)
    throw Error("dfn: pose must be [B, T, " + std::to_string(context_.pose_dim) + "]");
  if (!c.defined() || c.dim() != 3 || c.size(0) != p.size(0) || c.size(1) != p.size(1) || c.size(2) != context_.control_dim)
    throw Error("dfn: control must be [B, T, " + std::to_string(context_.control_dim) + "] matching pose");
  if (p.size(1) < min_frames)
    throw Error("dfn: windows of " + std::to_string(p.size(1)) + " frames are too short for horizon " +
                std::to_string(options_.horizon) + " (need at least " + std::to_string(min_frames) + ")");
}

torch::Tensor DfnImpl::codes(const torch::Tensor& pose, const torch::Tensor& control) {
  return ae->encode(torch::cat({pose, control}, -1));
}

torch::Tensor DfnImpl::future_windows(const torch::Tensor& x) const {
  const int64_t h = options_.horizon, t = x.size(1);
  // unfold over time: [B, T-H, K, H] -> [B, T-H, H, K]
  return x.narrow(1, 1, t - 1).unfold(1, h, 1).permute({0, 1, 3, 2});
}

LossTerms DfnImpl::autoencoder_loss(const Batch& batch) {
  check_batch(batch, 1);
  auto z = codes(batch.pose, batch.control);
  auto d = ae->decode(z);
  // Eq. 2 in the data's units where the skeleton is known (standardising would let the near-constant
  // 6D components, whose standard deviation is the floor, dominate); control standardised.
  auto pose_mse = (ae->raw_pose(d.pose) - ae->raw_pose(batch.pose)).pow(2).mean();
  auto vel_mse = (d.control - batch.control).pow(2).mean();
  auto total = options_.pose_weight * pose_mse + options_.velocity_weight * vel_mse;
  LossTerms out;
  total = total + foot_term(batch, d.pose, d.control, out);
  if (ae->head() == DfnPoseHead::kRotationsFk) {
    auto target = ae->feature_positions(batch.pose).detach();
    auto fk = (d.positions - target).pow(2).mean();
    total = total + options_.fk_weight * fk;
    out.terms["ae_fk"] = fk.detach();
  }
  out.terms["loss"] = total;
  out.terms["ae_pose"] = pose_mse.detach();
  out.terms["ae_velocity"] = vel_mse.detach();
  return out;
}

namespace {

// [B, n] 1 where window frame start + i lies inside its clip (a short clip's padding left out);
// undefined when the batch holds no padded clip.
torch::Tensor frames_in_clip(const Batch& batch, int64_t start, int64_t n, const torch::Device& device) {
  if (!batch.frames.defined()) return {};
  return torch::arange(start, start + n, torch::dtype(torch::kInt64).device(device)).unsqueeze(0) <
         batch.frames.to(device).to(torch::kInt64).unsqueeze(1);
}

}  // namespace

torch::Tensor DfnImpl::foot_term(const Batch& batch, const torch::Tensor& made, const torch::Tensor& made_control,
                                 LossTerms& out) {
  auto total = torch::zeros({}, made.options());
  if (!foot_.on()) return total;
  const int64_t n = made.size(1);
  const torch::Tensor valid = frames_in_clip(batch, 0, n, made.device());
  foot_.add({made, made_control, batch.pose.narrow(1, 0, n), batch.control.narrow(1, 0, n), valid, batch.content,
             batch.style},
            is_training(), &total, &out);
  return total;
}

LossTerms DfnImpl::future_loss(const Batch& batch) {
  check_batch(batch, options_.horizon + 1);
  const int64_t h = options_.horizon, k = options_.code;
  auto z = codes(batch.pose, batch.control).detach();
  auto x = torch::cat({ae->raw_pose(batch.pose), batch.control}, -1);
  auto z_win = future_windows(z);  // [B, T - H, H, code]
  auto x_win = future_windows(x);
  const int64_t starts = z_win.size(1);
  if (options_.future_starts > 0 && starts > options_.future_starts) {
    // An unbiased subset of the start frames (the same for every window of the batch).
    auto pick = torch::randperm(starts, torch::kLong).narrow(0, 0, options_.future_starts).to(z.device());
    z_win = z_win.index_select(1, pick);
    x_win = x_win.index_select(1, pick);
  }
  auto windows = z_win.reshape({-1, h, k});  // [N, H, code]
  x_win = x_win.reshape({-1, h, x.size(-1)});
  auto rec = future->reconstruct(future->embed(windows), h);
  auto rec_loss = (rec - windows).pow(2).mean();
  // L_smooth: velocities (frame differences) of the decoded reconstruction against the data's.
  auto dec = ae->decode(rec);
  auto x_hat = torch::cat({ae->raw_pose(dec.pose), dec.control}, -1);
  torch::Tensor smooth = torch::zeros({}, rec_loss.options());
  if (h > 1) {
    auto vel = [h](const torch::Tensor& a) { return a.narrow(1, 1, h - 1) - a.narrow(1, 0, h - 1); };
    smooth = (vel(x_hat) - vel(x_win)).pow(2).mean();
  }
  LossTerms out;
  out.terms["loss"] = rec_loss + options_.smooth_weight * smooth;
  out.terms["future_rec"] = rec_loss.detach();
  out.terms["future_smooth"] = smooth.detach();
  return out;
}

namespace {

torch::Tensor reparameterise(const DfnDynamicsImpl::Gaussian& g) {
  auto eps = torch::randn(g.mean.sizes(), torch::TensorOptions().dtype(g.mean.scalar_type())).to(g.mean.device());
  return g.mean + torch::exp(0.5 * g.logvar) * eps;
}

// One frame's latents from the priors, as generation draws them: f ~ p(f | h) (pf given), m decoded
// from it, s ~ p(s | m, h); sample(Gaussian) makes each draw. Returns {s, f}. Shared by
// step_stream, scheduled prior draws and the open-loop speed term, so all three generate alike.
template <class Sample>
std::pair<torch::Tensor, torch::Tensor> prior_latents(DfnDynamicsImpl& dyn, const DfnDynamicsImpl::Gaussian& pf,
                                                      const torch::Tensor& h, const torch::Tensor& labels,
                                                      Sample&& sample) {
  auto f = sample(pf);
  auto s = sample(dyn.prior_s(dyn.decode_m(f, h), h, labels));
  return {s, f};
}

// The latents that advance the state under scheduled prior draws (DfnOptions::prior_rollout): for
// each window, with probability p the priors' draws (f ~ p(f | h), s ~ p(s | m(f, h), h), as
// step_stream generates), else the posteriors' s and f. Reparameterised, so the gradient reaches
// the priors through the states that follow.
std::pair<torch::Tensor, torch::Tensor> scheduled_latents(DfnDynamicsImpl& dyn, double p, const torch::Tensor& s,
                                                          const torch::Tensor& f, const DfnDynamicsImpl::Gaussian& pf,
                                                          const torch::Tensor& h, const torch::Tensor& labels) {
  const auto [s_prior, f_prior] = prior_latents(dyn, pf, h, labels, reparameterise);
  auto use = (torch::rand({s.size(0), 1}, torch::TensorOptions().dtype(s.scalar_type())) < p).to(s.options());
  return {use * s_prior + (1 - use) * s, use * f_prior + (1 - use) * f};
}

}  // namespace

DfnImpl::WindowSpeeds DfnImpl::window_speeds(const torch::Tensor& control, const torch::Tensor& positions) const {
  const auto& st = context_.stats;
  auto ctrl = control.narrow(-1, 0, 2);  // dx, dz
  if (static_cast<int>(st.control_mean.size()) == context_.control_dim &&
      static_cast<int>(st.control_std.size()) == context_.control_dim) {
    auto to = torch::TensorOptions().dtype(control.scalar_type()).device(control.device());
    auto mean = torch::tensor(std::vector<float>(st.control_mean.begin(), st.control_mean.begin() + 2)).to(to);
    auto std_ = torch::tensor(std::vector<float>(st.control_std.begin(), st.control_std.begin() + 2)).to(to);
    ctrl = ctrl * std_ + mean;
  }
  // sqrt(x + 1e-8): a finite gradient at standstill.
  WindowSpeeds w;
  w.root_mps = (ctrl.pow(2).sum(-1) + 1e-8).sqrt().mean(1) * context_.fps;
  const int64_t t = positions.size(1);
  if (t < 2) {
    w.body_mps = torch::zeros_like(w.root_mps);
    return w;
  }
  auto step = positions.narrow(1, 1, t - 1) - positions.narrow(1, 0, t - 1);
  auto rate = positions.dim() == 4 ? (step.pow(2).sum(-1) + 1e-8).sqrt().mean(-1)          // [B, T-1], metres
                                   : (step.pow(2).mean(-1) + 1e-8).sqrt();                 // RMS, standardised
  w.body_mps = rate.mean(1) * context_.fps;
  return w;
}

torch::Tensor DfnImpl::rollout_foot_term(const Batch& batch, const torch::Tensor& made,
                                         const torch::Tensor& made_control, LossTerms& out) {
  auto total = torch::zeros({}, made.options());
  const int64_t r = std::min(made.size(1), batch.pose.size(1)), start = batch.pose.size(1) - r;
  const torch::Tensor valid = frames_in_clip(batch, start, r, made.device());
  LossTerms terms;
  rollout_foot_.add({made.narrow(1, 0, r), made_control.narrow(1, 0, r), batch.pose.narrow(1, start, r),
                     batch.control.narrow(1, start, r), valid, batch.content, batch.style},
                    is_training(), &total, &terms);
  for (const auto& [name, value] : terms.terms) out.terms["rollout_" + name] = value;
  return total;
}

torch::Tensor DfnImpl::rollout_terms(const Batch& batch, std::pair<torch::Tensor, torch::Tensor> state,
                                     const torch::Tensor& labels, LossTerms& out) {
  const bool plain = ae->head() == DfnPoseHead::kPlain;
  std::vector<torch::Tensor> controls, poses, features;
  for (int r = 0; r < options_.rollout_frames; ++r) {  // as step_stream, reparameterised
    const auto h_t = state.second;
    const auto [s, f] = prior_latents(*dyn, dyn->prior_f(h_t, labels), h_t, labels, reparameterise);
    auto x = ae->decode(dyn->decode_z(s, h_t));
    controls.push_back(x.control);
    poses.push_back(plain ? x.pose : x.positions);
    features.push_back(x.pose);
    state = dyn->step(state, s, f, labels);
  }
  auto foot = rollout_foot_.on() ? rollout_foot_term(batch, torch::stack(features, 1), torch::stack(controls, 1), out)
                                 : torch::zeros({}, state.second.options());
  if (options_.rollout_speed_weight <= 0) return foot;
  const WindowSpeeds gen = window_speeds(torch::stack(controls, 1), torch::stack(poses, 1));
  WindowSpeeds real;
  {
    torch::NoGradGuard no_grad;
    real = window_speeds(batch.control, plain ? batch.pose : ae->feature_positions(batch.pose));
  }
  const double tol = options_.rollout_speed_tolerance;
  auto term = (speed_ratio_excess(gen.root_mps, real.root_mps, tol, kRolloutSpeedFloorMps) +
               speed_ratio_excess(gen.body_mps, real.body_mps, tol, kRolloutSpeedFloorMps))
                  .mean();
  out.terms["rollout_speed"] = term.detach();
  out.terms["rollout_root_mps"] = gen.root_mps.mean().detach();
  out.terms["rollout_body_mps"] = gen.body_mps.mean().detach();
  out.terms["real_root_mps"] = real.root_mps.mean();
  out.terms["real_body_mps"] = real.body_mps.mean();
  return options_.rollout_speed_weight * term + foot;
}

LossTerms DfnImpl::dynamics_loss(const Batch& batch) {
  check_batch(batch, options_.horizon + 1);
  const int64_t h = options_.horizon, b = batch.pose.size(0), l = batch.pose.size(1) - h;
  auto z = codes(batch.pose, batch.control).detach();                                         // [B, T, K]
  auto m = future->embed(future_windows(z).reshape({-1, h, options_.code})).reshape({b, l, -1}).detach();
  auto opts = z.options();
  const double drop = is_training() ? options_.label_dropout : 0.0;
  const auto labels = labels_of(drop_labels(batch.content, drop), drop_labels(batch.style, drop), b, opts);
  std::pair<torch::Tensor, torch::Tensor> state{torch::zeros({b, options_.state}, opts),
                                                torch::zeros({b, options_.state}, opts)};
  auto nll_z = torch::zeros({b}, opts), nll_m = nll_z, kl_s = nll_z, kl_f = nll_z, z_se = nll_z;
  std::vector<torch::Tensor> hs, ss, ps_mean, ps_logvar, decoded;  // decoded: codes for the foot terms
  for (int64_t t = 0; t < l; ++t) {
    const auto h_t = state.second;
    auto z_t = z.select(1, t), m_t = m.select(1, t);
    auto pf = dyn->prior_f(h_t, labels), qf = dyn->posterior_f(h_t, m_t, labels);
    auto f = reparameterise(qf);
    auto ps = dyn->prior_s(m_t, h_t, labels), qs = dyn->posterior_s(h_t, z_t, m_t, labels);
    auto s = reparameterise(qs);
    nll_z = nll_z - dyn->log_p_z(z_t, s, h_t);
    {
      torch::NoGradGuard no_grad;  // the code's squared error, for the log only
      z_se = z_se + (dyn->decode_z(s, h_t) - z_t).pow(2).mean(-1);
    }
    if (foot_.on()) decoded.push_back(dyn->decode_z(s, h_t));
    nll_m = nll_m - dyn->log_p_m(m_t, f, h_t);
    kl_s = kl_s + diagonal_gaussian_kl(qs.mean, qs.logvar, ps.mean, ps.logvar);
    kl_f = kl_f + diagonal_gaussian_kl(qf.mean, qf.logvar, pf.mean, pf.logvar);
    hs.push_back(h_t);
    ss.push_back(s);
    ps_mean.push_back(ps.mean);
    ps_logvar.push_back(ps.logvar);
    auto s_next = s, f_next = f;
    if (options_.prior_rollout > 0)
      std::tie(s_next, f_next) = scheduled_latents(*dyn, options_.prior_rollout, s, f, pf, h_t, labels);
    state = dyn->step(state, s_next, f_next, labels);
  }
  LossTerms out;
  auto rollout = options_.rollout_speed_weight > 0 || rollout_foot_.on() ? rollout_terms(batch, state, labels, out)
                                                                         : torch::zeros({}, opts);
  torch::Tensor foot = torch::zeros({}, opts);
  if (foot_.on()) {
    const auto x = ae->decode(torch::stack(decoded, 1));  // the window's first l frames
    foot = foot_term(batch, x.pose, x.control, out);
  }
  auto td_kl = torch::zeros({}, opts), td_nll = torch::zeros({}, opts), td_logvar = torch::zeros({}, opts);
  const int64_t max_delta = std::min<int64_t>(options_.td_max, l - 1);
  if (max_delta >= 1) {
    // One time difference per batch, uniform in 1..td_max (default CPU generator); every pair
    // (t1, t1 + delta) of the window (Sec. 5.5, Eqs. 12-14).
    const int64_t delta = torch::randint(1, max_delta + 1, {1}, torch::kInt64).item<int64_t>();
    const int64_t n = l - delta;
    auto H = torch::stack(hs, 1), S = torch::stack(ss, 1);
    auto PM = torch::stack(ps_mean, 1), PL = torch::stack(ps_logvar, 1);
    // s_t2 is the target, detached: with gradients the posterior could shrink its variance to make
    // itself predictable and drive -log p(s_t2 | ...) to minus infinity (a degenerate optimum the
    // text's Eq. 15 does not rule out; TD-VAE balances it with terms the paper does not keep).
    auto h1 = H.narrow(1, 0, n), h2 = H.narrow(1, delta, n), s2 = S.narrow(1, delta, n).detach();
    auto q = DfnDynamicsImpl::split(dyn->td_q_net->forward(torch::cat({s2, h1, h2}, -1)));
    auto s1 = reparameterise(q);
    td_kl = diagonal_gaussian_kl(q.mean, q.logvar, PM.narrow(1, 0, n), PL.narrow(1, 0, n)).mean();
    auto dt = torch::full({b, n, 1}, static_cast<double>(delta) / options_.td_max, opts);
    auto p = DfnDynamicsImpl::split(dyn->td_p_net->forward(torch::cat({s1, dt}, -1)));
    p.logvar = dyn->floor_observation_logvar(p.logvar);
    td_nll = -diagonal_gaussian_log_density(s2, p.mean, p.logvar).mean();
    td_logvar = p.logvar.mean().detach();
  }
  const double per = 1.0 / static_cast<double>(l);
  auto nz = (nll_z * per).mean(), nm = (nll_m * per).mean(), ks = (kl_s * per).mean(), kf = (kl_f * per).mean();
  // Free bits: below the budget the clamp passes no gradient to the posterior or prior.
  const double free = options_.kl_free_nats;
  auto ks_loss = free > 0 ? torch::clamp_min(ks, free) : ks, kf_loss = free > 0 ? torch::clamp_min(kf, free) : kf;
  out.terms["loss"] =
      nz + options_.m_weight * nm + options_.kl_weight * (ks_loss + kf_loss) + options_.td_weight * (td_kl + td_nll) +
      rollout + foot;
  out.terms["nll_z"] = nz.detach();
  out.terms["z_mse"] = (z_se * per).mean();
  out.terms["nll_m"] = nm.detach();
  out.terms["kl_s"] = ks.detach();
  out.terms["kl_f"] = kf.detach();
  out.terms["td_kl"] = td_kl.detach();
  out.terms["td_nll"] = td_nll.detach();
  out.terms["td_logvar"] = td_logvar;  // mean log-variance of the TD prediction, for the log
  return out;
}

LossTerms DfnImpl::loss(const Batch& batch) {
  switch (stage_) {
    case 0:
      return autoencoder_loss(batch);
    case 1:
      return future_loss(batch);
    case 2:
      return dynamics_loss(batch);
    default:
      break;
  }
  LossTerms all;
  torch::Tensor total;
  for (const LossTerms& part : {autoencoder_loss(batch), future_loss(batch), dynamics_loss(batch)})
    for (const auto& [k, v] : part.terms) {
      if (k == "loss")
        total = total.defined() ? total + v : v;
      else
        all.terms[k] = v;
    }
  all.terms["loss"] = total;
  return all;
}

// ---------------------------------------------------------------------------------------------
// Generation

ModelTraits DfnImpl::traits() const {
  ModelTraits t;
  t.control = InputUse::kGenerates;
  t.labels = dyn->label_dim() > 0;
  t.prefix = true;
  t.streaming = true;  // sample() is begin_stream + step_stream: equal by construction
  return t;
}

namespace {

struct DfnStream : StreamState {
  std::pair<torch::Tensor, torch::Tensor> state;  // the two GRU layers' hidden states [B, state]
  torch::Tensor labels;                            // [B, label features] or undefined (unlabelled)
  at::Generator gen;
  double temperature = 1.0;
};

torch::Tensor draw(const DfnDynamicsImpl::Gaussian& g, DfnStream& st) {
  auto cpu = torch::TensorOptions().dtype(g.mean.scalar_type());
  auto eps = torch::randn(g.mean.sizes(), st.gen, cpu).to(g.mean.device());
  return g.mean + st.temperature * torch::exp(0.5 * g.logvar) * eps;
}

}  // namespace

std::unique_ptr<StreamState> DfnImpl::begin_stream(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t d = context_.pose_dim, c = context_.control_dim, h = options_.horizon;
  auto opts = dyn->gru1->weight_ih.options();
  const bool has_prefix = request.prefix_pose.defined() && request.prefix_pose.size(1) > 0;
  int64_t b = request.batch;
  if (has_prefix) b = request.prefix_pose.size(0);
  else if (request.control.defined() && request.control.dim() == 3) b = request.control.size(0);
  else if (request.content.defined() && request.content.dim() == 1) b = request.content.size(0);
  else if (request.style.defined() && request.style.dim() == 1) b = request.style.size(0);
  if (b <= 0) throw Error("dfn: begin_stream needs a batch size (prefix_pose, control, labels or batch)");
  auto st = std::make_unique<DfnStream>();
  st->gen = at::detail::createCPUGenerator(request.seed);
  st->temperature = request.temperature;
  st->state = {torch::zeros({b, options_.state}, opts), torch::zeros({b, options_.state}, opts)};
  st->labels = labels_of(request.content, request.style, b, opts);
  if (!has_prefix) return st;
  const auto& pre = request.prefix_pose;
  if (pre.dim() != 3 || pre.size(2) != d)
    throw Error("sample request: prefix_pose must be [B, P, " + std::to_string(d) + "]");
  const int64_t p = pre.size(1);
  torch::Tensor pre_ctrl = torch::zeros({b, p, c}, opts);
  if (request.prefix_control.defined()) {
    const auto& pc = request.prefix_control;
    if (pc.dim() != 3 || pc.size(0) != b || pc.size(1) != p || pc.size(2) != c)
      throw Error("sample request: prefix_control must be [B, P, " + std::to_string(c) + "] matching prefix_pose");
    pre_ctrl = pc.to(opts);
  }
  auto z = codes(pre.to(opts), pre_ctrl);  // [B, P, code]
  // Posterior over the prefix: frames whose next H codes are observed take q(f | h, m) with m
  // their embedding; the last H frames draw f from the prior and decode m from it. s always
  // comes from q(s | h, z, m), z being observed.
  for (int64_t t = 0; t < p; ++t) {
    const auto h_t = st->state.second;
    torch::Tensor f, m;
    if (t + h < p) {
      m = future->embed(z.narrow(1, t + 1, h));
      f = draw(dyn->posterior_f(h_t, m, st->labels), *st);
    } else {
      f = draw(dyn->prior_f(h_t, st->labels), *st);
      m = dyn->decode_m(f, h_t);
    }
    auto s = draw(dyn->posterior_s(h_t, z.select(1, t), m, st->labels), *st);
    st->state = dyn->step(st->state, s, f, st->labels);
  }
  return st;
}

StreamFrame DfnImpl::step_stream(StreamState& state, const torch::Tensor& /*control: generated*/) {
  torch::NoGradGuard no_grad;
  auto* st = dynamic_cast<DfnStream*>(&state);
  if (!st) throw Error("dfn: step_stream needs a stream begun by a dfn model");
  const auto h_t = st->state.second;
  const auto [s, f] = prior_latents(*dyn, dyn->prior_f(h_t, st->labels), h_t, st->labels,
                                    [&](const DfnDynamicsImpl::Gaussian& g) { return draw(g, *st); });
  auto z = dyn->decode_z(s, h_t);
  auto x = ae->decode(z);
  st->state = dyn->step(st->state, s, f, st->labels);
  return {x.pose, x.control};
}

SampleOutput DfnImpl::sample(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t c = context_.control_dim;
  if (!request.control.defined() || request.control.dim() != 3 || request.control.size(2) != c)
    throw Error("sample request: control must be [B, T, " + std::to_string(c) + "] (only its shape is read)");
  const int64_t b = request.control.size(0), t = request.control.size(1);
  if (request.prefix_pose.defined() && request.prefix_pose.size(1) > 0 && request.prefix_pose.size(0) != b)
    throw Error("sample request: prefix_pose must have " + std::to_string(b) + " rows");
  auto opts = dyn->gru1->weight_ih.options();
  if (t == 0) return {torch::zeros({b, 0, context_.pose_dim}, opts), torch::zeros({b, 0, c}, opts)};
  auto stream = begin_stream(request);
  std::vector<torch::Tensor> poses, controls;
  poses.reserve(t);
  controls.reserve(t);
  for (int64_t i = 0; i < t; ++i) {
    auto f = step_stream(*stream, {});
    poses.push_back(f.pose);
    controls.push_back(f.control);
  }
  return {torch::stack(poses, 1), torch::stack(controls, 1)};
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(dfn, FamilyInfo{"dfn", FamilyKind::kMotion,
                                      "Dynamic Future Net: future-guided stochastic latent RNN (Chen et al. 2020)",
                                      [](const nlohmann::json& config, const ModelContext& context) {
                                        return std::make_shared<DfnImpl>(DfnOptions::from_json(config), context);
                                      },
                                      {{"code", 6},
                                       {"pose_code", 4},
                                       {"ae_hidden", 8},
                                       {"horizon", 3},
                                       {"future_hidden", 8},
                                       {"future", 4},
                                       {"state", 8},
                                       {"future_latent", 3},
                                       {"current_latent", 3},
                                       {"prior_f_hidden", 8},
                                       {"post_f_hidden", 8},
                                       {"m_hidden", 8},
                                       {"prior_s_hidden", 8},
                                       {"post_s_hidden", 8},
                                       {"z_hidden", 8},
                                       {"td_hidden", 8},
                                       {"td_max", 2}},
                                 {}})
