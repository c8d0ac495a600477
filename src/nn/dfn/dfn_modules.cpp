// Options and the three networks of Dynamic Future Net (dfn.h): the pose-velocity autoencoder
// with its forward-kinematics layer, the future seq2seq embedding and the stochastic latent RNN.
#include <torch/nn/modules/activation.h>
#include <torch/utils.h>

#include <cmath>

#include "core/error.h"
#include "nn/config_json.h"
#include "nn/dfn/dfn.h"
#include "nn/kinematics.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

// ---------------------------------------------------------------------------------------------
// Options

namespace {

std::string stage_problem(const DfnOptions& o) {
  if (o.stage_fractions.size() != 3) return "stage_fractions must have 3 entries (autoencoder, future, dynamics)";
  for (double f : o.stage_fractions)
    if (!(f > 0)) return "stage_fractions entries must be > 0";
  if (!o.stage_steps.empty() && o.stage_steps.size() != 3) return "stage_steps must be empty or have 3 entries";
  int total = 0;
  for (int s : o.stage_steps) {
    if (s < 0) return "stage_steps entries must be >= 0 (0 skips a stage whose weights are already trained)";
    total += s;
  }
  if (!o.stage_steps.empty() && total < 1) return "stage_steps must train at least one stage";
  return "";
}

const OptionFields<DfnOptions>& dfn_fields() {
  using O = DfnOptions;
  static const auto fields =
      OptionFields<O>("dfn")
          .field("code", &O::code, "pose-velocity code size (paper: 16)", at_least(2))
          .field("pose_code", &O::pose_code, "pose part of the code (the rest is velocity)", at_least(1))
          .rule([](const O& o) { return o.pose_code < o.code ? "" : "pose_code must be < code"; })
          .field("ae_hidden", &O::ae_hidden, "width of the autoencoder's MLPs", at_least(1))
          .field("fk", &O::fk, "decode poses through forward kinematics when the skeleton is known")
          .field("horizon", &O::horizon, "H: future frames the embedding summarises", at_least(1))
          .field("future_hidden", &O::future_hidden, "GRU width of the future seq2seq network", at_least(1))
          .field("future", &O::future, "future embedding size m", at_least(1))
          .field("state", &O::state, "deterministic state h (two stacked GRU layers)", at_least(1))
          .field("future_latent", &O::future_latent, "future latent size f", at_least(1))
          .field("current_latent", &O::current_latent, "current latent size s", at_least(1))
          .field("prior_f_hidden", &O::prior_f_hidden, "width of p(f | h)", at_least(1))
          .field("post_f_hidden", &O::post_f_hidden, "width of q(f | h, m)", at_least(1))
          .field("m_hidden", &O::m_hidden, "width of p(m | f, h)", at_least(1))
          .field("prior_s_hidden", &O::prior_s_hidden, "width of p(s | m, h)", at_least(1))
          .field("post_s_hidden", &O::post_s_hidden, "width of q(s | h, z, m)", at_least(1))
          .field("z_hidden", &O::z_hidden, "width of the code decoder z = MLP(s, h)", at_least(1))
          .field("td_hidden", &O::td_hidden, "width of the temporal-difference networks", at_least(1))
          .field("td_max", &O::td_max, "largest time difference of the TD term", at_least(1))
          .field("leaky_slope", &O::leaky_slope, "negative slope of the LeakyReLUs", in_range(0.0, 1.0))
          .field("pose_weight", &O::pose_weight, "Eq. 2 pose-feature weight", at_least(0.0))
          .field("velocity_weight", &O::velocity_weight, "Eq. 2 root-velocity weight", at_least(0.0))
          .field("fk_weight", &O::fk_weight, "Eq. 2 joint-position weight (rotation features)", at_least(0.0))
          .field("smooth_weight", &O::smooth_weight, "Eq. 3 smoothness weight", at_least(0.0))
          .field("future_starts", &O::future_starts, "future stage: random start frames per window (0 = all)",
                 at_least(0))
          .field("kl_weight", &O::kl_weight, "weight of the KL terms", at_least(0.0))
          .field("kl_free_nats", &O::kl_free_nats, "free nats per frame for each of the s and f KL terms",
                 at_least(0.0))
          .field("observation_logvar_min", &O::observation_logvar_min,
                 "floor on the log-variances of p(z | s, h), p(m | f, h) and the TD prediction (-8: none)", in_range(-8.0, 8.0))
          .field("prior_rollout", &O::prior_rollout,
                 "dynamics stage: probability that the state advances with prior draws (0 = posteriors)",
                 in_range(0.0, 1.0))
          .field("rollout_speed_weight", &O::rollout_speed_weight,
                 "dynamics stage: weight of the open-loop speed term (0 = off)", at_least(0.0))
          .field("rollout_frames", &O::rollout_frames, "dynamics stage: frames generated open loop for that term",
                 at_least(2))
          .field("rollout_speed_tolerance", &O::rollout_speed_tolerance,
                 "dynamics stage: speed ratio within which that term is zero (1 = exact matching)", at_least(1.0))
          .field("rollout_stance_weight", &O::rollout_stance_weight,
                 "dynamics stage: weight of the stance term on the open-loop rollout (0 = off)", at_least(0.0))
          .written_if([](const O& o) { return o.rollout_stance_weight > 0; })
          .field("rollout_speed_distribution_weight", &O::rollout_speed_distribution_weight,
                 "dynamics stage: weight of the heel speed-distribution term on the open-loop rollout (0 = off)",
                 at_least(0.0))
          .written_if([](const O& o) { return o.rollout_speed_distribution_weight > 0; })
          .field("rollout_toe_slide_weight", &O::rollout_toe_slide_weight,
                 "dynamics stage: weight of the toe-slide term on the open-loop rollout (0 = off)", at_least(0.0))
          .written_if([](const O& o) { return o.rollout_toe_slide_weight > 0; })
          .field("labels", &O::labels, "content and style labels as conditions")
          .written_if([](const O& o) { return o.labels; })
          .field("label_dropout", &O::label_dropout, "probability a window's label is dropped in training",
                 in_range(0.0, 1.0))
          .written_if([](const O& o) { return o.labels; })
          .field("m_weight", &O::m_weight, "weight of log p(m | f, h)", at_least(0.0))
          .field("td_weight", &O::td_weight, "weight of the temporal-difference terms", at_least(0.0))
          .field("stage_fractions", &O::stage_fractions, "fractions of the steps per stage")
          .field("stage_steps", &O::stage_steps,
                 "absolute steps per stage (overrides the fractions; 0 skips a stage)")
          .rule(stage_problem)
          .include(&O::foot, foot_objective_fields());
  return fields;
}

}  // namespace

FootObjectiveOptions DfnOptions::rollout_foot() const {
  DrawObjectiveOptions draw;
  draw.draw_stance_weight = rollout_stance_weight;
  draw.draw_speed_distribution_weight = rollout_speed_distribution_weight;
  draw.draw_toe_slide_weight = rollout_toe_slide_weight;
  return draw.foot(foot);
}

DfnOptions DfnOptions::from_json(const nlohmann::json& config) {
  DfnOptions o;
  dfn_fields().read(config, &o);
  dfn_fields().check(o);
  return o;
}

nlohmann::json DfnOptions::to_json() const { return dfn_fields().write(*this); }

// ---------------------------------------------------------------------------------------------
// Helpers

torch::nn::Sequential dfn_mlp(int in, int hidden, int n_hidden, int out, double slope) {
  torch::nn::Sequential s;
  int width = in;
  for (int i = 0; i < n_hidden; ++i) {
    s->push_back(torch::nn::Linear(width, hidden));
    s->push_back(torch::nn::LeakyReLU(torch::nn::LeakyReLUOptions().negative_slope(slope)));
    width = hidden;
  }
  s->push_back(torch::nn::Linear(width, out));
  return s;
}

// ---------------------------------------------------------------------------------------------
// Autoencoder

namespace {

// Whether the context describes a skeleton whose features the FK heads can make.
DfnPoseHead choose_head(const DfnOptions& o, const ModelContext& c) {
  const int j = c.skeleton.num_joints();
  if (!o.fk || j == 0 || static_cast<int>(c.skeleton.parents.size()) != j ||
      static_cast<int>(c.skeleton.offsets.size()) != j || static_cast<int>(c.stats.pose_mean.size()) != c.pose_dim ||
      static_cast<int>(c.stats.pose_std.size()) != c.pose_dim)
    return DfnPoseHead::kPlain;
  switch (c.pose_form) {
    case data::PoseForm::kRotations:
      if (c.pose_dim == data::expected_pose_dim(c.pose_form, j, c.layout.smoothed_root())) return DfnPoseHead::kRotationsFk;
      return DfnPoseHead::kPlain;
    case data::PoseForm::kPositions:
      return c.pose_dim == 3 * j ? DfnPoseHead::kPositionsFk : DfnPoseHead::kPlain;
    case data::PoseForm::kMarkers:
      return DfnPoseHead::kPlain;  // no FK head for markers
  }
  return DfnPoseHead::kPlain;
}

}  // namespace

DfnAutoencoderImpl::DfnAutoencoderImpl(const DfnOptions& o, const ModelContext& c)
    : pose_dim_(c.pose_dim), control_dim_(c.control_dim), pose_code_(o.pose_code) {
  head_ = choose_head(o, c);
  const double slope = o.leaky_slope;
  encoder = register_module("encoder", dfn_mlp(c.pose_dim + c.control_dim, o.ae_hidden, 2, o.code, slope));
  int pose_out = c.pose_dim;
  if (head_ != DfnPoseHead::kPlain) {
    joints_ = c.skeleton.num_joints();
    parents_ = c.skeleton.parents;
    root_joint_ = c.pose_form == data::PoseForm::kRotations ? c.layout.root_joint : 0;
    smoothed_ = c.layout.smoothed_root();
    auto off = torch::zeros({joints_, 3}, torch::kFloat64);
    for (int j = 0; j < joints_; ++j)
      for (int k = 0; k < 3; ++k) off[j][k] = c.skeleton.offsets[j][k] * c.skeleton.meters_per_unit;
    offsets = register_buffer("offsets", off.to(torch::kFloat32));
    pose_mean = register_buffer("pose_mean", torch::tensor(c.stats.pose_mean, torch::kFloat32));
    pose_std = register_buffer("pose_std", torch::tensor(c.stats.pose_std, torch::kFloat32).clamp_min(1e-6));
    rot_slot_.assign(joints_, -1);
    if (head_ == DfnPoseHead::kRotationsFk) {
      // Layout (data/representation.h): height, 6D of the trajectory joint r, 6D of every other joint.
      int next = 7;
      for (int j = 0; j < joints_; ++j) rot_slot_[j] = j == root_joint_ ? 1 : (next += 6) - 6;
      for (int p = parents_[root_joint_]; p >= 0; p = parents_[p]) ancestors_of_root_.push_back(p);
    } else {
      pose_out = 3 + 6 * joints_;  // root translation (metres), then 6D of every joint
    }
  }
  pose_decoder = register_module("pose_decoder", dfn_mlp(o.pose_code, o.ae_hidden, 2, pose_out, slope));
  velocity_decoder =
      register_module("velocity_decoder", dfn_mlp(o.velocity_code(), o.ae_hidden, 2, c.control_dim, slope));
}

torch::Tensor DfnAutoencoderImpl::encode(const torch::Tensor& x) { return encoder->forward(x); }

torch::Tensor DfnAutoencoderImpl::fk(const torch::Tensor& rot6d, const torch::Tensor& root) const {
  auto lead = rot6d.sizes().vec();
  lead.resize(lead.size() - 2);  // [...]
  const int64_t n = rot6d.numel() / (joints_ * 6);
  auto r = matrix_from_rot6d(rot6d.reshape({n, 1, joints_, 6}));
  if (!ancestors_of_root_.empty()) {
    auto keep = torch::ones({joints_, 1, 1}, r.options());
    for (int a : ancestors_of_root_) keep[a] = 0;
    r = r * keep + torch::eye(3, r.options()) * (1 - keep);  // joints above r stay at rest
  }
  auto pos = forward_kinematics(r, root.reshape({n, 1, 3}), offsets.to(r.dtype()), parents_);
  lead.push_back(joints_);
  lead.push_back(3);
  return pos.reshape(lead);
}

torch::Tensor DfnAutoencoderImpl::raw_pose(const torch::Tensor& pose) const {
  return head_ == DfnPoseHead::kPlain ? pose : pose * pose_std + pose_mean;
}

torch::Tensor DfnAutoencoderImpl::rotations_from_features(const torch::Tensor& pose) {
  std::vector<int64_t> idx;
  for (int j = 0; j < joints_; ++j)
    for (int k = 0; k < 6; ++k) idx.push_back(rot_slot_[j] + k);
  auto index = torch::tensor(idx, torch::kInt64).to(pose.device());
  auto raw = pose.index_select(-1, index) * pose_std.index_select(0, index) + pose_mean.index_select(0, index);
  auto sizes = raw.sizes().vec();
  sizes.back() = joints_;
  sizes.push_back(6);
  return raw.reshape(sizes);
}

torch::Tensor DfnAutoencoderImpl::feature_positions(const torch::Tensor& pose) {
  if (head_ == DfnPoseHead::kPlain) throw Error("dfn: joint positions need a skeleton in the model context");
  if (head_ == DfnPoseHead::kPositionsFk) {
    auto raw = pose * pose_std + pose_mean;
    auto sizes = raw.sizes().vec();
    sizes.back() = joints_;
    sizes.push_back(3);
    return raw.reshape(sizes);
  }
  auto r6 = rotations_from_features(pose);
  auto lead = r6.sizes().vec();
  lead.resize(lead.size() - 2);
  lead.push_back(3);
  auto pos = fk(r6, torch::zeros(lead, pose.options()));
  return pos - pos.select(-2, root_joint_).unsqueeze(-2);
}

DfnAutoencoderImpl::Decoded DfnAutoencoderImpl::decode(const torch::Tensor& z) {
  Decoded d;
  d.control = velocity_decoder->forward(z.narrow(-1, pose_code_, z.size(-1) - pose_code_));
  auto out = pose_decoder->forward(z.narrow(-1, 0, pose_code_));
  auto lead = out.sizes().vec();
  lead.pop_back();
  auto with = [&](std::vector<int64_t> tail) {
    auto s = lead;
    s.insert(s.end(), tail.begin(), tail.end());
    return s;
  };
  switch (head_) {
    case DfnPoseHead::kPlain:
      d.pose = out;
      break;
    case DfnPoseHead::kPositionsFk: {
      auto root = out.narrow(-1, 0, 3);
      auto r6 = out.narrow(-1, 3, 6 * joints_).reshape(with({joints_, 6}));
      d.positions = fk(r6, root);
      d.pose = (d.positions.reshape(with({3 * joints_})) - pose_mean) / pose_std;
      break;
    }
    case DfnPoseHead::kRotationsFk: {
      // 6D outputs are raw (unstandardised) rotations, re-orthogonalised so that every decoded
      // rotation is a rotation; height and root offsets are decoded standardised directly.
      std::vector<int64_t> idx;
      for (int j = 0; j < joints_; ++j)
        for (int k = 0; k < 6; ++k) idx.push_back(rot_slot_[j] + k);
      auto index = torch::tensor(idx, torch::kInt64).to(out.device());
      auto r6 = out.index_select(-1, index).reshape(with({joints_, 6}));
      auto ortho = rot6d_from_matrix(matrix_from_rot6d(r6)).reshape(with({6 * joints_}));
      auto stdz = (ortho - pose_mean.index_select(0, index)) / pose_std.index_select(0, index);
      d.pose = out.index_copy(-1, index, stdz);
      auto pos = fk(ortho.reshape(with({joints_, 6})), torch::zeros(with({3}), out.options()));
      d.positions = pos - pos.select(-2, root_joint_).unsqueeze(-2);
      break;
    }
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// Future embedding

DfnFutureImpl::DfnFutureImpl(const DfnOptions& o) {
  encoder = register_module("encoder", torch::nn::GRU(torch::nn::GRUOptions(o.code, o.future_hidden).batch_first(true)));
  to_m = register_module("to_m", torch::nn::Linear(o.future_hidden, o.future));
  from_m = register_module("from_m", torch::nn::Linear(o.future, o.future_hidden));
  decoder = register_module("decoder", torch::nn::GRU(torch::nn::GRUOptions(o.future, o.future_hidden).batch_first(true)));
  out = register_module("out", torch::nn::Linear(o.future_hidden, o.code));
}

torch::Tensor DfnFutureImpl::embed(const torch::Tensor& codes) {
  auto h = std::get<1>(encoder->forward(codes));  // [1, N, hidden]
  return to_m->forward(h.squeeze(0));
}

torch::Tensor DfnFutureImpl::reconstruct(const torch::Tensor& m, int64_t h) {
  auto h0 = torch::tanh(from_m->forward(m)).unsqueeze(0);
  auto in = m.unsqueeze(1).expand({m.size(0), h, m.size(1)});
  return out->forward(std::get<0>(decoder->forward(in, h0)));
}

// ---------------------------------------------------------------------------------------------
// Dynamics

DfnDynamicsImpl::DfnDynamicsImpl(const DfnOptions& o, int label_dim) : label_dim_(label_dim) {
  const double a = o.leaky_slope;
  const int h = o.state, f = o.future_latent, s = o.current_latent, m = o.future, z = o.code, c = label_dim;
  gru1 = register_module("gru1", torch::nn::GRUCell(s + f + c, h));
  gru2 = register_module("gru2", torch::nn::GRUCell(h, h));
  prior_f_net = register_module("prior_f", dfn_mlp(h + c, o.prior_f_hidden, 2, 2 * f, a));       // 3 layers
  post_f_net = register_module("post_f", dfn_mlp(h + m + c, o.post_f_hidden, 2, 2 * f, a));      // 2 hidden
  m_net = register_module("m", dfn_mlp(f + h, o.m_hidden, 3, m, a));                            // 4 layers
  prior_s_net = register_module("prior_s", dfn_mlp(m + h + c, o.prior_s_hidden, 1, 2 * s, a));   // 2 layers
  post_s_net = register_module("post_s", dfn_mlp(h + z + m + c, o.post_s_hidden, 2, 2 * s, a));  // 2 hidden
  z_net = register_module("z", dfn_mlp(s + h, o.z_hidden, 3, z, a));                         // 3 hidden
  td_q_net = register_module("td_q", dfn_mlp(s + 2 * h, o.td_hidden, 2, 2 * s, a));          // Eq. 13
  td_p_net = register_module("td_p", dfn_mlp(s + 1, o.td_hidden, 3, 2 * s, a));              // Eq. 14
  z_logvar = register_parameter("z_logvar", torch::zeros({z}));
  m_logvar = register_parameter("m_logvar", torch::zeros({m}));
  observation_logvar_min_ = o.observation_logvar_min;
}

torch::Tensor DfnDynamicsImpl::observation_logvar(const torch::Tensor& raw) const {
  return floor_observation_logvar(8.0 * torch::tanh(raw / 8.0));
}

torch::Tensor DfnDynamicsImpl::floor_observation_logvar(const torch::Tensor& logvar) const {
  // Below the floor the clamp passes no gradient: the variance stops shrinking there.
  return observation_logvar_min_ > -8.0 ? torch::clamp_min(logvar, observation_logvar_min_) : logvar;
}

torch::Tensor DfnDynamicsImpl::log_p_z(const torch::Tensor& z, const torch::Tensor& s, const torch::Tensor& h) {
  auto mean = decode_z(s, h);
  return diagonal_gaussian_log_density(z, mean, observation_logvar(z_logvar).expand_as(mean));
}

torch::Tensor DfnDynamicsImpl::log_p_m(const torch::Tensor& m, const torch::Tensor& f, const torch::Tensor& h) {
  auto mean = decode_m(f, h);
  return diagonal_gaussian_log_density(m, mean, observation_logvar(m_logvar).expand_as(mean));
}

DfnDynamicsImpl::Gaussian DfnDynamicsImpl::split(const torch::Tensor& x) {
  auto parts = x.chunk(2, -1);
  // Log-variances bounded softly to [-8, 8]: long open-loop generation never draws from a
  // degenerate or exploding Gaussian.
  return {parts[0], 8.0 * torch::tanh(parts[1] / 8.0)};
}

torch::Tensor DfnDynamicsImpl::with_labels(std::vector<torch::Tensor> parts, const torch::Tensor& labels) const {
  if (label_dim_ > 0) {
    const auto& first = parts.front();
    if (!labels.defined()) {
      auto shape = first.sizes().vec();
      shape.back() = label_dim_;
      parts.push_back(torch::zeros(shape, first.options()));
    } else {
      if (labels.dim() != 2 || labels.size(0) != first.size(0) || labels.size(1) != label_dim_)
        throw Error("dfn: labels must be [B, " + std::to_string(label_dim_) + "]");
      parts.push_back(labels.to(first.options()));
    }
  }
  return torch::cat(parts, -1);
}

DfnDynamicsImpl::Gaussian DfnDynamicsImpl::prior_f(const torch::Tensor& h, const torch::Tensor& labels) {
  return split(prior_f_net->forward(with_labels({h}, labels)));
}
DfnDynamicsImpl::Gaussian DfnDynamicsImpl::posterior_f(const torch::Tensor& h, const torch::Tensor& m,
                                                       const torch::Tensor& labels) {
  return split(post_f_net->forward(with_labels({h, m}, labels)));
}
torch::Tensor DfnDynamicsImpl::decode_m(const torch::Tensor& f, const torch::Tensor& h) {
  return m_net->forward(torch::cat({f, h}, -1));
}
DfnDynamicsImpl::Gaussian DfnDynamicsImpl::prior_s(const torch::Tensor& m, const torch::Tensor& h,
                                                   const torch::Tensor& labels) {
  return split(prior_s_net->forward(with_labels({m, h}, labels)));
}
DfnDynamicsImpl::Gaussian DfnDynamicsImpl::posterior_s(const torch::Tensor& h, const torch::Tensor& z,
                                                       const torch::Tensor& m, const torch::Tensor& labels) {
  return split(post_s_net->forward(with_labels({h, z, m}, labels)));
}
torch::Tensor DfnDynamicsImpl::decode_z(const torch::Tensor& s, const torch::Tensor& h) {
  return z_net->forward(torch::cat({s, h}, -1));
}

std::pair<torch::Tensor, torch::Tensor> DfnDynamicsImpl::step(const std::pair<torch::Tensor, torch::Tensor>& state,
                                                              const torch::Tensor& s, const torch::Tensor& f,
                                                              const torch::Tensor& labels) {
  auto h1 = gru1->forward(with_labels({s, f}, labels), state.first);
  auto h2 = gru2->forward(h1, state.second);
  return {h1, h2};
}

}  // namespace mosyn::nn
