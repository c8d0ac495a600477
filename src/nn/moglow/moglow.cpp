#include "nn/moglow/moglow.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/nn/init.h>
#include <torch/utils.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <tuple>

#include "core/error.h"
#include "nn/config_json.h"
#include "nn/label_features.h"
#include "nn/moglow/moglow_stream.h"

namespace mosyn::nn {

// ---------------------------------------------------------------------------------------------
// ActNorm

ActNormImpl::ActNormImpl(int dim) {
  bias = register_parameter("bias", torch::zeros({dim}));
  logs = register_parameter("logs", torch::zeros({dim}));
  initialized_flag = register_buffer("initialized", torch::zeros({1}));
}

torch::Tensor ActNormImpl::forward(const torch::Tensor& x) { return (x + bias) * torch::exp(logs); }
torch::Tensor ActNormImpl::reverse(const torch::Tensor& y) { return y * torch::exp(-logs) - bias; }
torch::Tensor ActNormImpl::logdet() const { return logs.sum(); }
bool ActNormImpl::initialized() const { return initialized_flag.item<double>() != 0.0; }

void ActNormImpl::initialize(const torch::Tensor& x) {
  torch::NoGradGuard no_grad;
  auto flat = x.reshape({-1, x.size(-1)});
  auto mean = flat.mean(0);
  auto std = (flat - mean).pow(2).mean(0).sqrt();
  bias.copy_(-mean);
  logs.copy_(-torch::log(std + 1e-6));
  initialized_flag.fill_(1.0);
}

// ---------------------------------------------------------------------------------------------
// InvLinear

InvLinearImpl::InvLinearImpl(int dim) {
  // Random orthogonal W (QR of a Gaussian matrix drawn from torch's generator), then W = P L U.
  auto g = torch::randn({dim, dim}, torch::kFloat64).contiguous();
  Eigen::MatrixXd a(dim, dim);
  for (int r = 0; r < dim; ++r)
    for (int c = 0; c < dim; ++c) a(r, c) = g[r][c].item<double>();
  Eigen::MatrixXd q = Eigen::HouseholderQR<Eigen::MatrixXd>(a).householderQ();
  Eigen::PartialPivLU<Eigen::MatrixXd> lu(q);  // P q = L U  ->  q = P^T L U
  Eigen::MatrixXd packed = lu.matrixLU();
  Eigen::MatrixXd pt = lu.permutationP().transpose().toDenseMatrix().cast<double>();
  auto opts = torch::TensorOptions().dtype(torch::kFloat64);
  auto p_t = torch::zeros({dim, dim}, opts), l_t = torch::zeros({dim, dim}, opts), u_t = torch::zeros({dim, dim}, opts);
  auto s_t = torch::zeros({dim}, opts);
  auto pa = p_t.accessor<double, 2>(), la = l_t.accessor<double, 2>(), ua = u_t.accessor<double, 2>();
  auto sa = s_t.accessor<double, 1>();
  for (int r = 0; r < dim; ++r) {
    for (int c = 0; c < dim; ++c) {
      pa[r][c] = pt(r, c);
      if (c < r) la[r][c] = packed(r, c);
      if (c > r) ua[r][c] = packed(r, c);
    }
    sa[r] = packed(r, r);
  }
  lower = register_parameter("lower", l_t.to(torch::kFloat32));
  upper = register_parameter("upper", u_t.to(torch::kFloat32));
  log_s = register_parameter("log_s", torch::log(torch::abs(s_t)).to(torch::kFloat32));
  perm = register_buffer("perm", p_t.to(torch::kFloat32));
  sign_s = register_buffer("sign_s", torch::sign(s_t).to(torch::kFloat32));
  lower_mask = register_buffer("lower_mask", torch::tril(torch::ones({dim, dim}), -1));
  eye = register_buffer("eye", torch::eye(dim));
}

torch::Tensor InvLinearImpl::weight() const {
  auto l = lower * lower_mask + eye;
  auto u = upper * lower_mask.t() + torch::diag(sign_s * torch::exp(log_s));
  return perm.matmul(l).matmul(u);
}

torch::Tensor InvLinearImpl::forward(const torch::Tensor& a) { return a.matmul(weight().t()); }
torch::Tensor InvLinearImpl::reverse(const torch::Tensor& b, const torch::Tensor& w_inverse) {
  return b.matmul(w_inverse.t());
}
torch::Tensor InvLinearImpl::logdet() const { return log_s.sum(); }

// ---------------------------------------------------------------------------------------------
// Coupling

CouplingImpl::CouplingImpl(int dim, int cond_dim, int hidden, int layers, double scale_eps)
    : dim_(dim), d_lo_(dim / 2), eps_(scale_eps) {
  lstm = register_module("lstm", torch::nn::LSTM(torch::nn::LSTMOptions(d_lo_ + cond_dim, hidden).num_layers(layers)));
  out = register_module("out", torch::nn::Linear(hidden, 2 * (dim - d_lo_)));
  torch::NoGradGuard no_grad;
  out->weight.zero_();
  out->bias.zero_();
}

std::tuple<torch::Tensor, torch::Tensor> CouplingImpl::shift_scale(const torch::Tensor& lo, const torch::Tensor& cond,
                                                                   c10::optional<LstmState>& state) {
  auto input = torch::cat({lo, cond}, -1);
  auto result = lstm->forward(input, state);
  state = std::get<1>(result);
  auto h = out->forward(std::get<0>(result));
  int d_hi = dim_ - d_lo_;
  auto shift = h.narrow(-1, 0, d_hi);
  auto scale = torch::sigmoid(h.narrow(-1, d_hi, d_hi) + 2.0) + eps_;
  return {shift, scale};
}

std::tuple<torch::Tensor, torch::Tensor> CouplingImpl::forward(const torch::Tensor& b, const torch::Tensor& cond,
                                                               c10::optional<LstmState>& state) {
  auto lo = b.narrow(-1, 0, d_lo_);
  auto hi = b.narrow(-1, d_lo_, dim_ - d_lo_);
  auto [shift, scale] = shift_scale(lo, cond, state);
  auto z = torch::cat({lo, (hi + shift) * scale}, -1);
  return {z, torch::log(scale).sum(-1)};
}

torch::Tensor CouplingImpl::reverse(const torch::Tensor& z, const torch::Tensor& cond,
                                    c10::optional<LstmState>& state) {
  auto lo = z.narrow(-1, 0, d_lo_);
  auto hi = z.narrow(-1, d_lo_, dim_ - d_lo_);
  auto [shift, scale] = shift_scale(lo, cond, state);
  return torch::cat({lo, hi / scale - shift}, -1);
}

// ---------------------------------------------------------------------------------------------
// FlowStep

FlowStepImpl::FlowStepImpl(int dim, int cond_dim, int hidden, int layers, double scale_eps) {
  actnorm = register_module("actnorm", ActNorm(dim));
  linear = register_module("linear", InvLinear(dim));
  coupling = register_module("coupling", Coupling(dim, cond_dim, hidden, layers, scale_eps));
}

std::tuple<torch::Tensor, torch::Tensor> FlowStepImpl::forward(const torch::Tensor& x, const torch::Tensor& cond,
                                                               c10::optional<LstmState>& state,
                                                               bool initialize_actnorm) {
  if (initialize_actnorm && !actnorm->initialized()) actnorm->initialize(x.detach());
  auto a = actnorm->forward(x);
  auto b = linear->forward(a);
  auto [z, logdet] = coupling->forward(b, cond, state);
  return {z, logdet + actnorm->logdet() + linear->logdet()};
}

torch::Tensor FlowStepImpl::reverse(const torch::Tensor& z, const torch::Tensor& cond,
                                    c10::optional<LstmState>& state, const torch::Tensor& w_inverse) {
  auto b = coupling->reverse(z, cond, state);
  auto a = linear->reverse(b, w_inverse);
  return actnorm->reverse(a);
}

// ---------------------------------------------------------------------------------------------
// MoGlow

MoGlowImpl::MoGlowImpl(const MoGlowOptions& options, const ModelContext& context)
    : MotionModel("MoGlow"), options_(options), context_(context) {
  const int d = context.pose_dim, c = context.control_dim, tau = options.tau;
  label_dim_ = options.labels ? context.num_content + context.num_style : 0;
  lookahead_dim_ = c * static_cast<int>(options.lookahead.size());
  cond_dim_ = tau * d + (tau + 1) * c + label_dim_ + lookahead_dim_;
  dropout_ = options.dropout;
  if (options.residual) transport_ = PoseTransport(context);
  foot_ = FootObjectives(context, options.foot, "moglow");
  for (int k = 0; k < options.num_steps; ++k)
    steps.push_back(register_module("step" + std::to_string(k),
                                    FlowStep(d, cond_dim_, options.hidden, options.lstm_layers, options.scale_eps)));
}

std::vector<LabelInput> MoGlowImpl::label_inputs() const {
  if (label_dim_ == 0) return {};
  const int64_t d = context_.pose_dim, c = context_.control_dim, tau = options_.tau;
  std::vector<LabelInput> out;
  for (size_t k = 0; k < steps.size(); ++k) {
    const int64_t d_lo = steps[k]->coupling->dim_lo();
    out.push_back({"step" + std::to_string(k) + ".coupling.lstm.weight_ih_l0", 1, d_lo + tau * d + (tau + 1) * c});
  }
  return out;
}

int MoGlowImpl::control_frames_after() const {
  if (options_.lookahead.empty()) return 0;
  const int longest = *std::max_element(options_.lookahead.begin(), options_.lookahead.end());
  return options_.predicted_lookahead > 0 ? std::max(longest, prediction_delay_frames()) : longest;
}

double MoGlowImpl::prediction_omega_per_frame() const {
  const double sigma_s = options_.prediction_smoothing_s > 0 ? options_.prediction_smoothing_s
                                                               : context_.layout.root_smoothing_s;
  if (sigma_s <= 0 || context_.fps <= 0)
    throw Error("moglow config: predicted_lookahead needs prediction_smoothing_s or a dataset with root smoothing");
  return 1.31 / (sigma_s * context_.fps);  // as data::RootController
}

int MoGlowImpl::prediction_delay_frames() const {
  return std::max(1, static_cast<int>(std::lround(2.0 / prediction_omega_per_frame())));
}

torch::Tensor MoGlowImpl::conditioning(const torch::Tensor& pose, const torch::Tensor& control,
                                       const torch::Tensor& labels, const torch::Tensor& control_after) const {
  const int64_t tau = options_.tau, b = pose.size(0), t = pose.size(1);
  const int64_t n = t - tau;
  // unfold(1, w, 1): [B, windows, F, w]; window s covers frames s..s+w-1.
  auto hist = pose.narrow(1, 0, t - 1).unfold(1, tau, 1).permute({0, 1, 3, 2}).reshape({b, n, -1});
  auto ctrl = control.unfold(1, tau + 1, 1).permute({0, 1, 3, 2}).reshape({b, n, -1});
  std::vector<torch::Tensor> parts = {hist, ctrl};
  if (label_dim_ > 0) {
    auto lab = labels.defined() ? labels.to(pose.options()) : torch::zeros({b, label_dim_}, pose.options());
    if (lab.dim() != 2 || lab.size(0) != b || lab.size(1) != label_dim_)
      throw Error("moglow: labels must be [B, " + std::to_string(label_dim_) + "]");
    parts.push_back(lab.unsqueeze(1).expand({b, n, label_dim_}));
  }
  if (lookahead_dim_ > 0) {
    auto ahead = lookahead_features(control, control_after);
    if (options_.predicted_lookahead > 0) {
      auto predicted = predicted_lookahead_features(control, control_after);
      if (is_training() && options_.predicted_lookahead < 1) {  // rows drawn on the CPU generator
        auto rows = torch::bernoulli(torch::full({b, 1, 1}, options_.predicted_lookahead)).to(ahead.device());
        predicted = rows * predicted + (1 - rows) * ahead;
      }
      ahead = predicted;
    }
    parts.push_back(ahead.narrow(1, tau, n));
  }
  return torch::cat(parts, -1).transpose(0, 1);
}

torch::Tensor MoGlowImpl::lookahead_features(const torch::Tensor& control, const torch::Tensor& control_after) const {
  if (lookahead_dim_ == 0) return {};
  const int64_t b = control.size(0), t = control.size(1), c = control.size(2);
  const int64_t longest = control_frames_after();
  std::vector<torch::Tensor> path = {control};
  int64_t known = 0;  // frames of control_after used
  if (control_after.defined()) {
    if (control_after.dim() != 3 || control_after.size(0) != b || control_after.size(2) != c)
      throw Error("moglow: control_after must be [B, K, " + std::to_string(c) + "] matching the control");
    known = std::min(longest, control_after.size(1));
    if (known > 0) path.push_back(control_after.narrow(1, 0, known).to(control.dtype()));
  }
  // Past what is known the last control repeats; cumulative sums give every window mean at once.
  const torch::Tensor& last = path.back();
  path.push_back(last.narrow(1, last.size(1) - 1, 1).expand({b, longest - known, c}));
  auto padded = torch::cat(path, 1);
  auto sums = torch::cat({torch::zeros({b, 1, c}, control.options()), padded.cumsum(1)}, 1);  // sums[i] = sum of frames < i
  std::vector<torch::Tensor> parts;
  for (int k : options_.lookahead)  // mean of frames t+1..t+k = (sums[t+k+1] - sums[t+1]) / k
    parts.push_back((sums.narrow(1, k + 1, t) - sums.narrow(1, 1, t)) / static_cast<double>(k));
  return torch::cat(parts, -1);
}

torch::Tensor MoGlowImpl::predicted_lookahead_features(const torch::Tensor& control,
                                                        const torch::Tensor& control_after) const {
  if (lookahead_dim_ == 0) return {};
  const int64_t b = control.size(0), t = control.size(1), c = control.size(2);
  const int64_t delay = prediction_delay_frames();
  const double w = prediction_omega_per_frame();
  // The path continued as lookahead_features continues it, long enough for every frame's input.
  std::vector<torch::Tensor> path = {control};
  int64_t known = 0;
  if (control_after.defined() && control_after.dim() == 3 && control_after.size(0) == b && control_after.size(2) == c) {
    known = std::min<int64_t>(delay, control_after.size(1));
    if (known > 0) path.push_back(control_after.narrow(1, 0, known).to(control.dtype()));
  }
  const torch::Tensor& last = path.back();
  path.push_back(last.narrow(1, last.size(1) - 1, 1).expand({b, delay - known, c}));
  const auto input = torch::cat(path, 1).narrow(1, delay, t);  // u_t = c_{t + delay}
  // The filter's state: the control and its change from the frame before (none before frame 0).
  const auto before = torch::cat({control.narrow(1, 0, 1), control.narrow(1, 0, t - 1)}, 1);
  const auto j0 = control - input, j1 = (control - before) + w * j0;
  std::vector<torch::Tensor> parts;
  for (int k : options_.lookahead) {  // mean over frames t+1..t+k of u + (j0 + j1 i) e^{-w i}
    double mean_e = 0, mean_ie = 0;
    for (int i = 1; i <= k; ++i) {
      mean_e += std::exp(-w * i) / k;
      mean_ie += i * std::exp(-w * i) / k;
    }
    parts.push_back(input + mean_e * j0 + mean_ie * j1);
  }
  return torch::cat(parts, -1);
}

torch::Tensor MoGlowImpl::labels_of(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                                    const torch::TensorOptions& options) const {
  if (label_dim_ == 0) return {};
  return label_features(content, style, batch, context_.num_content, context_.num_style, options);
}

MoGlowImpl::Encoded MoGlowImpl::encode(const torch::Tensor& pose, const torch::Tensor& control,
                                       const torch::Tensor& history_keep,
                                       const std::vector<c10::optional<LstmState>>* init_states,
                                       bool initialize_actnorm, const torch::Tensor& labels,
                                       const torch::Tensor& history_offset, const torch::Tensor& control_after) {
  const int64_t tau = options_.tau;
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim)
    throw Error("moglow: pose must be [B, T, " + std::to_string(context_.pose_dim) + "]");
  if (control.dim() != 3 || control.size(2) != context_.control_dim || control.size(0) != pose.size(0) ||
      control.size(1) != pose.size(1))
    throw Error("moglow: control must be [B, T, " + std::to_string(context_.control_dim) + "] matching pose");
  if (pose.size(1) <= tau)
    throw Error("moglow: windows need more than tau = " + std::to_string(tau) + " frames, got " +
                std::to_string(pose.size(1)));
  // What the model conditions on (history and the residual's previous frame) may be perturbed;
  // the frames it scores never are.
  const auto seen = history_offset.defined() ? pose + history_offset : pose;
  auto hist_pose = history_keep.defined() ? seen * history_keep.unsqueeze(-1).to(pose.dtype()) : seen;
  auto cond = conditioning(hist_pose, control, labels, control_after);
  const int64_t n = pose.size(1) - tau;
  auto x = pose.narrow(1, tau, n);
  if (options_.residual) x = x - transport_.apply(seen.narrow(1, tau - 1, n), control.narrow(1, tau, n));
  x = x.transpose(0, 1);  // [T', B, D]
  Encoded e;
  e.states.resize(steps.size());
  if (init_states) e.states = *init_states;
  torch::Tensor logdet = torch::zeros({x.size(0), x.size(1)}, x.options());
  for (size_t k = 0; k < steps.size(); ++k) {
    auto [z, ld] = steps[k]->forward(x, cond, e.states[k], initialize_actnorm);
    x = z;
    logdet = logdet + ld;
  }
  e.z = x.transpose(0, 1);
  e.logdet = logdet.transpose(0, 1);
  e.cond = cond;
  return e;
}

std::vector<torch::Tensor> MoGlowImpl::linear_inverses() const {
  std::vector<torch::Tensor> out;
  for (const auto& step : steps) out.push_back(step->linear->weight().inverse());
  return out;
}

torch::Tensor MoGlowImpl::reverse_window(const torch::Tensor& z, const torch::Tensor& cond) {
  std::vector<c10::optional<LstmState>> states(steps.size());
  const auto inverses = linear_inverses();
  auto x = z;
  for (size_t k = steps.size(); k-- > 0;) x = steps[k]->reverse(x, cond, states[k], inverses[k]);
  return x;
}

torch::Tensor MoGlowImpl::rollout(const torch::Tensor& seen, const torch::Tensor& control, const Encoded& e,
                                  int64_t k) {
  const int64_t tau = options_.tau, b = seen.size(0), d = context_.pose_dim, hist_dim = tau * d;
  std::vector<torch::Tensor> frames;  // the history: true frames, then the draws
  for (int64_t t = 0; t < tau; ++t) frames.push_back(seen.select(1, t));
  std::vector<c10::optional<LstmState>> states(steps.size());
  const auto inverses = linear_inverses();
  for (int64_t i = 0; i < k; ++i) {
    auto hist = torch::stack(std::vector<torch::Tensor>(frames.end() - tau, frames.end()), 1).reshape({b, hist_dim});
    auto cond = torch::cat({hist, e.cond[i].narrow(-1, hist_dim, e.cond.size(2) - hist_dim)}, -1).unsqueeze(0);
    auto x = (torch::randn({1, b, d}, torch::dtype(seen.scalar_type())) * options_.foot_contact_temperature)
                 .to(seen.device());
    for (size_t s = steps.size(); s-- > 0;) x = steps[s]->reverse(x, cond, states[s], inverses[s]);
    auto made = x.squeeze(0);
    if (options_.residual) made = made + transport_.apply(frames.back(), control.select(1, tau + i));
    frames.push_back(made);
  }
  return torch::stack(std::vector<torch::Tensor>(frames.end() - k, frames.end()), 1);
}

MoGlowImpl::HeelDraws MoGlowImpl::heel_draws(const Batch& batch, const torch::Tensor& seen, const Encoded& e) {
  const int64_t tau = options_.tau, b = seen.size(0);
  int64_t n = e.z.size(1);
  HeelDraws out;
  // 1 for the rows whose draws start from the data's frames, 0 for cold starts (the mean pose).
  out.warm_rows = (torch::arange(b, torch::dtype(torch::kInt64).device(seen.device())) >=
                   std::lround(options_.cold_start_fraction * b))
                      .to(seen.dtype());
  if (options_.foot_contact_rollout > 0) {
    n = std::min<int64_t>(n, options_.foot_contact_rollout);
    const auto start = seen * out.warm_rows.view({b, 1, 1});  // standardised: 0 is the mean pose
    out.made = rollout(start, batch.control, e, n);
    out.prev = torch::cat({start.narrow(1, tau - 1, 1), out.made.narrow(1, 0, n - 1)}, 1);
  } else {
    // Latents on the CPU generator, as the dropout mask, for reproducible training on any device.
    auto z = torch::randn(e.z.sizes(), torch::dtype(e.z.scalar_type())).to(e.z.device()) *
             options_.foot_contact_temperature;
    out.made = reverse_window(z.transpose(0, 1), e.cond).transpose(0, 1);  // [B, T', D]
    out.prev = seen.narrow(1, tau - 1, n);
    if (options_.residual) out.made = out.made + transport_.apply(out.prev, batch.control.narrow(1, tau, n));
  }
  return out;
}

MoGlowImpl::HeelTerms MoGlowImpl::heel_terms(const Batch& batch, const torch::Tensor& seen, const Encoded& e,
                                             const torch::Tensor& frame_valid) {
  const int64_t tau = options_.tau, d = context_.pose_dim, c = context_.control_dim, b = seen.size(0);
  const FootObjectiveOptions& foot = options_.foot;
  const FootTerms& terms = foot_.terms();
  // heel_label_weights: each window's weight in the terms' means, on top of its valid frames [B, T'].
  torch::Tensor valid = frame_valid;
  if (!foot.heel_label_weights.empty())
    valid = (frame_valid.defined() ? frame_valid : torch::ones({b, e.z.size(1)}, seen.options())) *
            foot_.heel_weight_rows(batch.content, batch.style, b, seen.options()).view({b, 1});
  const HeelDraws draws = heel_draws(batch, seen, e);
  const auto &made = draws.made, &prev = draws.prev, &warm_rows = draws.warm_rows;
  const int64_t n = made.size(1);
  // Each predicted frame with the frame before it: [B n, 2, .] pairs, one ground step each.
  auto pairs = [](const torch::Tensor& before, const torch::Tensor& after, int64_t f) {
    return torch::stack({before, after}, 2).reshape({-1, 2, f});
  };
  const auto real_drawn = batch.pose.narrow(1, tau, n);                // the data's frames of the draws
  const auto drawn_valid = valid.defined() ? valid.narrow(1, 0, n) : valid;  // [B, n], undefined = all
  const auto made_pairs = pairs(prev, made, d);
  const auto real_pairs = pairs(batch.pose.narrow(1, tau - 1, n), real_drawn, d);
  const auto control_pairs = pairs(batch.control.narrow(1, tau - 1, n), batch.control.narrow(1, tau, n), c);
  const auto speeds = terms.speeds(made_pairs, real_pairs, control_pairs);  // once for every term
  // [B n, 1, .] pairs -> [B, n, .] sequences; the phase-locked terms read the first `locked` steps.
  // A scalar (the fixed planted threshold) stays as it is.
  const auto sequence = [&](const torch::Tensor& x, int64_t k) {
    return x.defined() && x.dim() > 0 ? x.reshape({b, n, -1}).narrow(1, 0, k) : x;
  };
  const int64_t locked = options_.phase_locked_frames > 0 ? std::min<int64_t>(n, options_.phase_locked_frames) : n;
  const FootTerms::HeelSpeeds first{sequence(speeds.made_mps, locked), sequence(speeds.real_mps, locked),
                                          sequence(speeds.planted_below_mps, locked), {}};
  const auto first_valid = (valid.defined() ? valid.narrow(1, 0, locked) : torch::ones({b, locked}, seen.options())) *
                           warm_rows.view({b, 1});
  HeelTerms out;
  out.planted_mps = terms.mean_planted_speed(first, first_valid);
  if (foot.heel_speed_weight > 0) out.speed_error_mps = terms.mean_speed_error(first, first_valid);
  if (foot.lift_off_weight > 0) {
    const auto lift_off_valid =  // lift_off_labels
        first_valid * foot_.lift_off_rows(batch.content, batch.style, b, seen.options()).view({b, 1});
    out.lingering_mps = terms.mean_lingering_speed(first, lift_off_valid);
  }
  if (foot.stance_weight > 0 || foot.slow_share_weight > 0) {
    const FootTerms::HeelSpeeds all{sequence(speeds.made_mps, n), sequence(speeds.real_mps, n),
                                    sequence(speeds.planted_below_mps, n), {}};
    const auto window = std::max<int64_t>(1, std::lround(foot.stance_window_s * context_.fps));
    if (foot.stance_weight > 0)
      out.missed_stance_mps = terms.mean_missed_stance(all, window, drawn_valid, foot.stance_relative);
    if (foot.slow_share_weight > 0) out.excess_slow_share = terms.mean_excess_slow_share(all, window, drawn_valid);
  }
  if (foot.speed_distribution_weight > 0 && n > 1) {
    // Every draw but the first: a cold start's first step leaves the mean pose, no frame of the motion.
    auto later = torch::ones({b, n}, seen.options()).index_put_({torch::indexing::Slice(), 0}, 0.0);
    if (drawn_valid.defined()) later = later * drawn_valid;
    out.speed_distribution_mps = terms.mean_sorted_speed_error(
        {sequence(speeds.made_mps, n), sequence(speeds.real_mps, n), {}, sequence(speeds.root_mps, n)}, later,
        foot.speed_distribution_cap_mps, foot.speed_distribution_cap_fraction);
  }
  if (foot.toe_slide_weight > 0 && n > 1) {
    // Along each row's own draws; the first step (from the history) is left out, as a cold start's
    // mean pose is no frame of the motion. Step s (draw s -> s + 1) is the root's step into draw s + 1.
    auto steps = valid.defined() ? drawn_valid.narrow(1, 1, n - 1) : valid;
    if (foot.toe_slide_below_root_mps > 0) {
      const auto step_root_mps = sequence(speeds.root_mps, n).squeeze(-1).narrow(1, 1, n - 1);  // [B, n - 1]
      const auto slow = (step_root_mps < foot.toe_slide_below_root_mps).to(seen.dtype());
      steps = steps.defined() ? steps * slow : slow;
    }
    out.toe_slide_mps = terms.mean_excess_toe_slide(made, real_drawn, batch.control.narrow(1, tau, n), steps);
  }
  if (foot.pelvis_follow_weight > 0) out.pelvis_offset_m = terms.mean_pelvis_offset_m(made, real_drawn, drawn_valid);
  if (foot.bone_length_weight > 0) out.bone_length_error_m = terms.mean_bone_length_error_m(made, drawn_valid);
  return out;
}

torch::Tensor MoGlowImpl::log_likelihood(const torch::Tensor& pose, const torch::Tensor& control) {
  auto e = encode(pose, control);
  const double d = context_.pose_dim;
  return -0.5 * e.z.pow(2).sum(-1) - 0.5 * d * kLog2Pi + e.logdet;
}

LossTerms MoGlowImpl::loss(const Batch& batch) {
  torch::Tensor keep;
  if (is_training() && dropout_ > 0) {
    // Whole frames dropped (zeroed = mean pose); drawn on the CPU generator so training is
    // reproducible on any device.
    keep = torch::bernoulli(torch::full({batch.pose.size(0), batch.pose.size(1)}, 1.0 - dropout_))
               .to(batch.pose.device());
  }
  torch::Tensor labels;
  if (label_dim_ > 0) {
    const double p = is_training() ? options_.label_dropout : 0.0;
    labels = labels_of(drop_labels(batch.content, p), drop_labels(batch.style, p), batch.pose.size(0),
                       batch.pose.options());
  }
  torch::Tensor offset;
  if (is_training() && options_.history_noise > 0) {
    // Drawn on the CPU generator, as the dropout mask, for reproducible training on any device.
    offset = (torch::randn(batch.pose.sizes(), torch::dtype(batch.pose.scalar_type())) * options_.history_noise)
                 .to(batch.pose.device());
  }
  auto e = encode(batch.pose, batch.control, keep, nullptr, is_training(), labels, offset, batch.control_after);
  const double d = context_.pose_dim;
  auto ll = -0.5 * e.z.pow(2).sum(-1) - 0.5 * d * kLog2Pi + e.logdet;  // [B, T']
  auto logdet = e.logdet;
  torch::Tensor valid;
  if (batch.frames.defined()) {
    // Predicted frame i is window frame tau + i; a short clip's padding starts at its frames.
    const int64_t predicted = ll.size(1);
    auto first_padded = batch.frames.to(ll.device()).to(torch::kInt64).unsqueeze(1) - options_.tau;
    valid = (torch::arange(predicted, torch::dtype(torch::kInt64).device(ll.device())).unsqueeze(0) < first_padded)
                .to(ll.dtype());
    const auto count = valid.sum().clamp_min(1.0);
    ll = ll * valid * (valid.numel() / count);  // the mean below then runs over valid frames only
    logdet = logdet * valid * (valid.numel() / count);
  }
  auto nll_frame = -ll.mean();
  LossTerms out;
  out.terms["loss"] = nll_frame / d;
  if (options_.heel_terms_on()) {
    // Training only, so that the validation loss stays the likelihood, comparable across runs.
    const auto seen = offset.defined() ? batch.pose + offset : batch.pose;
    const HeelTerms heels = heel_terms(batch, seen, e, valid);
    const FootObjectiveOptions& foot = options_.foot;
    auto added = foot.foot_contact_weight * heels.planted_mps;
    // Each optional term (undefined when its weight is 0): weighted into the loss, logged by name.
    const std::tuple<const torch::Tensor&, double, const char*> optional_terms[] = {
        {heels.speed_error_mps, foot.heel_speed_weight, "heel_speed_error_mps"},
        {heels.lingering_mps, foot.lift_off_weight, "lingering_heel_mps"},
        {heels.missed_stance_mps, foot.stance_weight, "missed_stance_mps"},
        {heels.toe_slide_mps, foot.toe_slide_weight, "toe_slide_mps"},
        {heels.excess_slow_share, foot.slow_share_weight, "excess_slow_share"},
        {heels.speed_distribution_mps, foot.speed_distribution_weight, "speed_distribution_mps"},
        {heels.pelvis_offset_m, foot.pelvis_follow_weight, "pelvis_offset_m"},
        {heels.bone_length_error_m, foot.bone_length_weight, "bone_length_error_m"}};
    for (const auto& [term, weight, name] : optional_terms) {
      if (!term.defined()) continue;
      added = added + weight * term;
      out.terms[name] = term.detach();
    }
    if (is_training()) out.terms["loss"] = out.terms["loss"] + added;
    out.terms["planted_heel_mps"] = heels.planted_mps.detach();
  }
  out.terms["nll_frame"] = nll_frame.detach();
  out.terms["nll_dim"] = (nll_frame / d).detach();
  out.terms["logdet_frame"] = logdet.mean().detach();
  return out;
}

namespace {

int64_t batch_of(const SampleRequest& r) {
  for (const auto* t : {&r.control, &r.prefix_pose, &r.prefix_control, &r.content, &r.style})
    if (t->defined()) return t->size(0);
  if (r.batch > 0) return r.batch;
  throw Error("sample request: no batch size (give prefix_pose, labels or batch)");
}

// Last n frames of x [B, P, F], zero-padded in front when P < n.
torch::Tensor last_frames(const torch::Tensor& x, int64_t n, int64_t b, int64_t f, const torch::TensorOptions& o) {
  auto out = torch::zeros({b, n, f}, o);
  if (!x.defined() || x.size(1) == 0) return out;
  int64_t p = std::min<int64_t>(n, x.size(1));
  out.narrow(1, n - p, p).copy_(x.narrow(1, x.size(1) - p, p));
  return out;
}

}  // namespace

std::unique_ptr<StreamState> MoGlowImpl::begin_stream(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t b = batch_of(request), tau = options_.tau, d = context_.pose_dim, c = context_.control_dim;
  const auto options = steps.front()->actnorm->bias.options();
  if (request.prefix_pose.defined() && (request.prefix_pose.dim() != 3 || request.prefix_pose.size(2) != d))
    throw Error("sample request: prefix_pose must be [B, P, " + std::to_string(d) + "]");
  if (request.prefix_control.defined() && (request.prefix_control.dim() != 3 || request.prefix_control.size(2) != c))
    throw Error("sample request: prefix_control must be [B, P, " + std::to_string(c) + "]");
  if (!request.seeds.empty() && static_cast<int64_t>(request.seeds.size()) != b)
    throw Error("sample request: seeds must have one entry per character (" + std::to_string(b) + ")");
  std::vector<std::uint64_t> seeds = request.seeds;
  for (int64_t k = static_cast<int64_t>(seeds.size()); k < b; ++k) seeds.push_back(row_seed(request.seed, k));
  auto st = std::make_unique<MoGlowStream>(*this, b, seeds);
  st->temperature = request.temperature;
  torch::Tensor pre_pose = request.prefix_pose.defined() ? request.prefix_pose.to(options) : torch::Tensor();
  torch::Tensor pre_ctrl;
  if (pre_pose.defined()) {
    pre_ctrl = request.prefix_control.defined() ? request.prefix_control.to(options)
                                                : torch::zeros({b, pre_pose.size(1), c}, options);
  }
  const auto labels = labels_of(request.content, request.style, b, options);
  // A prefix longer than tau warms the coupling LSTMs up, as the window context does in training.
  if (pre_pose.defined() && pre_pose.size(1) > tau)
    st->set_lstm_states(encode(pre_pose, pre_ctrl, {}, nullptr, false, labels).states);
  st->set_history(last_frames(pre_pose, tau, b, d, options), last_frames(pre_ctrl, tau, b, c, options), labels);
  return st;
}

std::shared_ptr<const MoGlowInference> MoGlowImpl::inference() {
  std::lock_guard<std::mutex> lock(*inference_mutex_);
  std::vector<std::pair<const void*, int64_t>> key;  // storage and in-place version of every parameter
  for (const auto& p : parameters()) key.emplace_back(p.data_ptr(), p._version());
  if (!inference_ || key != inference_key_) {
    inference_ = std::make_shared<const MoGlowInference>(MoGlowInference::of(*this));
    inference_key_ = std::move(key);
  }
  return inference_;
}

void MoGlowImpl::reseed_stream_row(StreamState& state, int64_t row, std::uint64_t seed) {
  auto& st = dynamic_cast<MoGlowStream&>(state);
  if (row < 0 || row >= st.batch) throw Error("moglow stream: row " + std::to_string(row) + " out of range");
  st.generators[row] = at::detail::createCPUGenerator(seed);
}

void MoGlowImpl::copy_stream_row(StreamState& dst, int64_t dst_row, const StreamState& src, int64_t src_row) {
  dynamic_cast<MoGlowStream&>(dst).copy_row(dst_row, dynamic_cast<const MoGlowStream&>(src), src_row);
}

ModelTraits MoGlowImpl::traits() const {
  ModelTraits t;
  t.control = InputUse::kTakes;
  t.labels = label_dim_ > 0;
  t.prefix = true;
  t.streaming = true;  // with look-ahead: the path ahead predicted from the input so far (step_stream_ahead)
  t.control_ahead_frames = lookahead_dim_ > 0 ? *std::max_element(options_.lookahead.begin(), options_.lookahead.end()) : 0;
  t.independent_rows = true;
  t.default_warmup_s = options_.lead_in_s;
  return t;
}

StreamFrame MoGlowImpl::step_stream(StreamState& state, const torch::Tensor& control) {
  return step_stream_ahead(state, control, {});
}

StreamFrame MoGlowImpl::step_stream_ahead(StreamState& state, const torch::Tensor& control,
                                          const torch::Tensor& control_ahead) {
  torch::Tensor ahead;
  if (lookahead_dim_ > 0) {
    if (control.dim() != 2 || control.size(1) != context_.control_dim)
      throw Error("moglow step: control must be [B, " + std::to_string(context_.control_dim) + "]");
    ahead = lookahead_features(control.unsqueeze(1), control_ahead).select(1, 0);
  }
  return {next_frame(state, control, ahead), control};
}

torch::Tensor MoGlowImpl::next_frame(StreamState& state, const torch::Tensor& control, const torch::Tensor& lookahead) {
  auto& st = dynamic_cast<MoGlowStream&>(state);
  if (control.dim() != 2 || control.size(0) != st.batch || control.size(1) != context_.control_dim)
    throw Error("moglow step: control must be [" + std::to_string(st.batch) + ", " +
                std::to_string(context_.control_dim) + "]");
  return st.step(control.to(st.options), lookahead.defined() ? lookahead.to(st.options) : lookahead);
}

SampleOutput MoGlowImpl::sample(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  if (!request.control.defined() || request.control.dim() != 3 || request.control.size(2) != context_.control_dim)
    throw Error("sample request: control must be [B, T, " + std::to_string(context_.control_dim) + "]");
  auto stream = begin_stream(request);
  std::vector<torch::Tensor> frames;
  frames.reserve(request.control.size(1));
  torch::Tensor ahead;
  if (lookahead_dim_ > 0 && request.control.size(1) > 0) ahead = lookahead_features(request.control);
  for (int64_t t = 0; t < request.control.size(1); ++t)
    frames.push_back(next_frame(*stream, request.control.select(1, t), ahead.defined() ? ahead.select(1, t) : ahead));
  if (frames.empty())
    return {torch::zeros({request.control.size(0), 0, context_.pose_dim}, steps.front()->actnorm->bias.options()),
            request.control};
  return {torch::stack(frames, 1), request.control};
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(moglow, FamilyInfo{"moglow", FamilyKind::kMotion,
                                         "MoGlow: normalising flow with LSTM conditioning (Henter et al. 2020)",
                                         [](const nlohmann::json& config, const ModelContext& context) {
                                           return std::make_shared<MoGlowImpl>(
                                               MoGlowOptions::from_json(config, context), context);
                                         },
                                         {{"num_steps", 2}, {"hidden", 16}, {"tau", 3}, {"dropout", 0.5}},
                                        // Henter et al. 2020, section 4.2: Adam, batch 100, 160k steps at
                                        // 1e-4 (human); 80k with 1k Noam warm-up steps to 1e-3 (quadruped).
                                        {{"paper", {{"batch", 100}, {"steps", 160000}, {"lr", 1e-4}, {"warmup", 0}}},
                                         {"paper-quadruped",
                                          {{"batch", 100}, {"steps", 80000}, {"lr", 1e-3}, {"warmup", 1000}}}}})
