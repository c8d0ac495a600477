#include "nn/rvae/rvae.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/utils.h>

#include <cmath>

#include "core/error.h"
#include "nn/config_json.h"
#include "nn/gaussian.h"
#include "nn/options_fields.h"
#include "nn/label_features.h"

namespace mosyn::nn {

namespace {

torch::Tensor activation(const torch::Tensor& x) { return torch::elu(x); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options

namespace {

std::string block_count_problem(const RvaeOptions& o) {
  if (o.encoder_channels.empty() || o.encoder_channels.size() > 8)
    return "encoder_channels must have 1 to 8 entries (one per conv/pool block)";
  if (o.control_channels.size() != o.encoder_channels.size())
    return "control_channels must have as many entries as encoder_channels";
  if (o.decoder_channels.size() + 1 != o.encoder_channels.size())
    return "decoder_channels must have one entry fewer than encoder_channels";
  return "";
}

const OptionFields<RvaeOptions>& rvae_fields() {
  using O = RvaeOptions;
  static const auto fields =
      OptionFields<O>("rvae")
          .field_checked_on_read("encoder_channels", &O::encoder_channels, "inference-network conv channels per block",
                                 entries_at_least(1))
          .field_checked_on_read("control_channels", &O::control_channels, "control-encoder conv channels per block",
                                 entries_at_least(1))
          .field_checked_on_read("decoder_channels", &O::decoder_channels, "hidden deconv channels (blocks - 1)",
                                 entries_at_least(1))
          .rule(block_count_problem)
          .field("latent", &O::latent, "latent size = decoder cell-state size", at_least(1))
          .field("kernel", &O::kernel, "temporal kernel width of every conv", odd_at_least(1))
          .field("input_dropout", &O::input_dropout, "dropout on the encoders' inputs in training",
                 in_range(0.0, 1.0, false))
          .field("kl_weight", &O::kl_weight, "weight of the KL term after annealing", at_least(0.0))
          .field("kl_anneal", &O::kl_anneal, "fraction of the steps over which the KL weight ramps up",
                 in_range(0.0, 1.0))
          .field("l1", &O::l1, "L1 penalty on the weights", at_least(0.0))
          .field("labels", &O::labels, "content and style labels as conditions")
          .written_if([](const O& o) { return o.labels; })
          .field("label_dropout", &O::label_dropout, "probability a window's label is dropped in training",
                 in_range(0.0, 1.0))
          .written_if([](const O& o) { return o.labels; })
          .field("free_running", &O::free_running, "probability a reduced step runs from the previous state",
                 in_range(0.0, 1.0))
          .written_if([](const O& o) { return o.free_running > 0; })
          .field("latent_prior", &O::latent_prior, "prior of the per-step latents",
                 one_of({"standard", "conditional"}))
          .written_if([](const O& o) { return o.latent_prior != "standard"; })
          .field("prior_hidden", &O::prior_hidden, "width of the conditional prior's hidden layer", at_least(1))
          .written_if([](const O& o) { return o.latent_prior != "standard"; })
          .include(&O::foot, foot_objective_fields())
          .rule([](const O& o) {
            return o.latent_prior == "conditional" && o.free_running > 0
                       ? "a conditional latent prior draws every step's latent; free_running must be 0"
                       : "";
          })
          .field("test_latents", &O::test_latents, "latents at generation time", one_of({"first", "every_step"}));
  return fields;
}

}  // namespace

RvaeOptions RvaeOptions::from_json(const nlohmann::json& config) {
  RvaeOptions o;
  rvae_fields().read(config, &o);
  rvae_fields().check(o);
  return o;
}

// Labels, free running and the conditional prior are written only when on, so configs of runs
// made before they existed stay byte-identical.
nlohmann::json RvaeOptions::to_json() const { return rvae_fields().write(*this); }

// ---------------------------------------------------------------------------------------------
// ConvEncoder

ConvEncoderImpl::ConvEncoderImpl(int in_dim, const std::vector<int>& channels, int kernel, int head_dim) {
  convs = register_module("convs", torch::nn::ModuleList());
  int in = in_dim;
  for (int ch : channels) {
    convs->push_back(torch::nn::Conv1d(torch::nn::Conv1dOptions(in, ch, kernel).padding(kernel / 2)));
    in = ch;
  }
  if (head_dim > 0) head = register_module("head", torch::nn::Conv1d(torch::nn::Conv1dOptions(in, head_dim, 1)));
}

torch::Tensor ConvEncoderImpl::forward(const torch::Tensor& x) {
  auto h = x.transpose(1, 2);  // [B, F, T']
  for (const auto& m : *convs) {
    h = activation(m->as<torch::nn::Conv1dImpl>()->forward(h));
    h = torch::max_pool1d(h, 2);
  }
  if (head) h = head->forward(h);
  return h.transpose(1, 2);
}

// ---------------------------------------------------------------------------------------------
// RvaeCell

RvaeCellImpl::RvaeCellImpl(int state_dim, int control_dim) {
  gates_state = register_module("gates_state", torch::nn::Linear(state_dim, 2 * state_dim));
  gates_control = register_module("gates_control", torch::nn::Linear(control_dim, 2 * state_dim));
  state_in = register_module("state_in", torch::nn::Linear(torch::nn::LinearOptions(state_dim, state_dim).bias(false)));
  control_in =
      register_module("control_in", torch::nn::Linear(torch::nn::LinearOptions(control_dim, state_dim).bias(false)));
}

torch::Tensor RvaeCellImpl::forward(const torch::Tensor& prev, const torch::Tensor& control,
                                    const torch::Tensor& latent, bool teacher_latent) {
  const auto& s = teacher_latent ? latent : prev;
  if (!s.defined()) throw Error(teacher_latent ? "rvae cell: teacher_latent needs a latent" : "rvae cell: no state");
  auto gates = (gates_state->forward(s) + gates_control->forward(control)).sigmoid();
  auto parts = gates.chunk(2, -1);
  const auto& i = parts[0];
  const auto& f = parts[1];
  return activation(f * state_in->forward(s) + i * control_in->forward(control));
}

// ---------------------------------------------------------------------------------------------
// Rvae

RvaeImpl::RvaeImpl(const RvaeOptions& options, const ModelContext& context)
    : MotionModel("Rvae"), options_(options), context_(context) {
  const int d = context.pose_dim, c = context.control_dim, z = options.latent, k = options.kernel;
  label_dim_ = options.labels ? context.num_content + context.num_style : 0;
  inference = register_module("inference", ConvEncoder(d, options.encoder_channels, k, 2 * z));
  control_encoder = register_module("control_encoder", ConvEncoder(c + label_dim_, options.control_channels, k, 0));
  cell = register_module("cell", RvaeCell(z, options.control_channels.back()));
  deconvs = register_module("deconvs", torch::nn::ModuleList());
  int in = z;
  for (size_t b = 0; b < options.encoder_channels.size(); ++b) {
    const int out = b < options.decoder_channels.size() ? options.decoder_channels[b] : d;
    deconvs->push_back(torch::nn::Conv1d(torch::nn::Conv1dOptions(in, out, k).padding(k / 2)));
    in = out;
  }
  kl_now_ = options.kl_weight;
  foot_ = FootObjectives(context, options.foot, "rvae");
  if (options.latent_prior == "conditional") {
    prior_hidden = register_module("prior_hidden", torch::nn::Linear(z + options.control_channels.back(), options.prior_hidden));
    prior_out = register_module("prior_out", torch::nn::Linear(options.prior_hidden, 2 * z));
    // Zero output: the prior starts as N(0, I), the paper's, and a warm start from a standard-prior
    // run begins from exactly that model.
    torch::NoGradGuard no_grad;
    prior_out->weight.zero_();
    prior_out->bias.zero_();
  }
}

std::pair<torch::Tensor, torch::Tensor> RvaeImpl::conditional_prior(const torch::Tensor& prev,
                                                                    const torch::Tensor& control_code) {
  auto h = activation(prior_hidden->forward(torch::cat({prev, control_code}, -1)));
  auto parts = prior_out->forward(h).chunk(2, -1);
  // The log-variance clamped to [-10, 2] (a spread of at most 2.7 N(0, I) units): generation feeds
  // each drawn latent back as the next state, and an unbounded spread lets one wide draw grow into
  // ever wider ones (samples exploding to 1e4 and NaN within seconds, seen in 2% of drawn-path
  // samples of a foot-contact run).
  return {parts[0], parts[1].clamp(-10.0, 2.0)};
}

torch::Tensor RvaeImpl::run_decoder_conditional(const torch::Tensor& control_code, const torch::Tensor& latents,
                                                double temperature, at::Generator* gen,
                                                std::pair<torch::Tensor, torch::Tensor>* prior) {
  const int64_t l = control_code.size(1), k = latents.size(1);
  if (k < 1 || k > l) throw Error("rvae: run_decoder needs 1 to L latents");
  if (k < l && gen == nullptr) throw Error("rvae: drawing latents needs a generator");
  std::vector<torch::Tensor> states, means, logvars;
  torch::Tensor prev;
  for (int64_t t = 0; t < l; ++t) {
    torch::Tensor z;
    if (t > 0 && (prior || t >= k)) {
      auto [mean, logvar] = conditional_prior(prev, control_code.select(1, t));
      if (prior) {
        means.push_back(mean);
        logvars.push_back(logvar);
      }
      if (t >= k) {
        auto eps = torch::randn(mean.sizes(), *gen, torch::TensorOptions().dtype(mean.scalar_type())).to(mean.device());
        z = mean + temperature * torch::exp(0.5 * logvar) * eps;
      }
    }
    if (t < k) z = latents.select(1, t);
    prev = cell->forward(prev, control_code.select(1, t), z, true);
    states.push_back(prev);
  }
  if (prior && !means.empty()) *prior = {torch::stack(means, 1), torch::stack(logvars, 1)};
  return torch::stack(states, 1);
}

void RvaeImpl::set_progress(int step, int total_steps) {
  if (options_.kl_anneal <= 0 || total_steps <= 0) {
    kl_now_ = options_.kl_weight;
    return;
  }
  const double ramp = options_.kl_anneal * total_steps;
  kl_now_ = options_.kl_weight * std::min(1.0, std::max(0.0, step / ramp));
}

torch::Tensor RvaeImpl::pad_time(const torch::Tensor& x) const {
  const int64_t r = options_.reduction(), t = x.size(1);
  const int64_t padded = (t + r - 1) / r * r;
  if (padded == t) return x;
  auto last = x.narrow(1, t - 1, 1).expand({x.size(0), padded - t, x.size(2)});
  return torch::cat({x, last}, 1);
}

RvaeImpl::Posterior RvaeImpl::encode(const torch::Tensor& pose) {
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim || pose.size(1) < 1)
    throw Error("rvae: pose must be [B, T >= 1, " + std::to_string(context_.pose_dim) + "]");
  auto h = inference->forward(pad_time(pose));
  auto parts = h.chunk(2, -1);
  return {parts[0], parts[1]};
}

std::vector<LabelInput> RvaeImpl::label_inputs() const {
  if (label_dim_ == 0) return {};
  return {{"control_encoder.convs.0.weight", 1, context_.control_dim}};
}

torch::Tensor RvaeImpl::encode_control(const torch::Tensor& control, const torch::Tensor& labels) {
  if (control.dim() != 3 || control.size(2) != context_.control_dim || control.size(1) < 1)
    throw Error("rvae: control must be [B, T >= 1, " + std::to_string(context_.control_dim) + "]");
  auto padded = pad_time(control);
  if (label_dim_ > 0) {
    const int64_t b = padded.size(0), t = padded.size(1);
    auto lab = labels.defined() ? labels.to(padded.options()) : torch::zeros({b, label_dim_}, padded.options());
    if (lab.dim() != 2 || lab.size(0) != b || lab.size(1) != label_dim_)
      throw Error("rvae: labels must be [B, " + std::to_string(label_dim_) + "]");
    padded = torch::cat({padded, lab.unsqueeze(1).expand({b, t, label_dim_})}, -1);
  }
  return control_encoder->forward(padded);
}

torch::Tensor RvaeImpl::run_decoder(const torch::Tensor& control_code, const torch::Tensor& latents,
                                    const torch::Tensor& use_latent) {
  const int64_t l = control_code.size(1), k = latents.size(1);
  if (k < 1 || k > l) throw Error("rvae: run_decoder needs 1 to L latents");
  if (use_latent.defined() && (use_latent.dim() != 2 || use_latent.size(0) != latents.size(0) || use_latent.size(1) != k))
    throw Error("rvae: use_latent must be [B, K]");
  std::vector<torch::Tensor> states;
  states.reserve(l);
  torch::Tensor prev;
  for (int64_t t = 0; t < l; ++t) {
    const bool teacher = t < k;
    torch::Tensor state = teacher ? latents.select(1, t) : torch::Tensor();
    if (teacher && t > 0 && use_latent.defined())
      state = torch::where(use_latent.select(1, t).unsqueeze(1).to(torch::kBool), state, prev);
    prev = cell->forward(prev, control_code.select(1, t), state, teacher);
    states.push_back(prev);
  }
  return torch::stack(states, 1);
}

torch::Tensor RvaeImpl::decode_canvas(const torch::Tensor& canvas) {
  auto h = canvas.transpose(1, 2);  // [B, Z, L]
  const size_t n = deconvs->size();
  for (size_t b = 0; b < n; ++b) {
    h = h.repeat_interleave(2, 2);  // nearest-neighbour upsampling x2
    h = (*deconvs)[b]->as<torch::nn::Conv1dImpl>()->forward(h);
    if (b + 1 < n) h = activation(h);
  }
  return h.transpose(1, 2);
}

torch::Tensor RvaeImpl::kl_to_unit_gaussian(const torch::Tensor& mean, const torch::Tensor& logvar) {
  return 0.5 * (mean.pow(2) + logvar.exp() - 1.0 - logvar).sum(-1);
}

std::pair<torch::Tensor, torch::Tensor> RvaeImpl::dropped_inputs(const torch::Tensor& pose,
                                                                 const torch::Tensor& control) const {
  const double p = options_.input_dropout;
  if (!is_training() || p <= 0) return {pose, control};
  // Element-wise dropout on the encoders' inputs; masks from the default CPU generator.
  auto mask = [&](const torch::Tensor& x) {
    return (torch::bernoulli(torch::full(x.sizes(), 1.0 - p)) / (1.0 - p)).to(x.options());
  };
  return {pose * mask(pose), control * mask(control)};
}

torch::Tensor RvaeImpl::latent_use_mask(const torch::Tensor& latents) const {
  torch::Tensor use_latent;
  if (options_.free_running >= 1.0) {
    // Algorithm 1's model, in training and validation alike: only the first step takes a latent.
    use_latent = torch::zeros({latents.size(0), latents.size(1)});
    use_latent.select(1, 0).fill_(1.0);
  } else if (is_training() && options_.free_running > 0) {
    use_latent = torch::bernoulli(torch::full({latents.size(0), latents.size(1)}, 1.0 - options_.free_running));
    use_latent.select(1, 0).fill_(1.0);
  }
  return use_latent.defined() ? use_latent.to(latents.device()) : use_latent;
}

torch::Tensor RvaeImpl::kl_per_frame(const Posterior& post, const std::pair<torch::Tensor, torch::Tensor>& prior,
                                     const torch::Tensor& use_latent, int64_t frames) const {
  auto kl_steps = kl_to_unit_gaussian(post.mean, post.logvar);  // [B, L]
  if (conditional() && prior.first.defined()) {
    // Steps after the first against the learned prior: KL of two diagonal Gaussians.
    const int64_t l = post.mean.size(1);
    auto qm = post.mean.narrow(1, 1, l - 1), qv = post.logvar.narrow(1, 1, l - 1);
    auto kl_rest = diagonal_gaussian_kl(qm, qv, prior.first, prior.second);
    kl_steps = torch::cat({kl_steps.narrow(1, 0, 1), kl_rest}, 1);
  }
  if (use_latent.defined()) kl_steps = kl_steps * use_latent.to(kl_steps.dtype());  // unused latents cost nothing
  return kl_steps.sum(1).mean() / static_cast<double>(frames);
}

torch::Tensor RvaeImpl::l1_penalty(const torch::TensorOptions& options) {
  auto pen = torch::zeros({}, options);
  for (const auto& kv : named_parameters())
    if (kv.key().size() >= 6 && kv.key().compare(kv.key().size() - 6, 6, "weight") == 0)
      pen = pen + kv.value().abs().sum();
  return options_.l1 * pen;
}

LossTerms RvaeImpl::loss(const Batch& batch) {
  const auto& pose = batch.pose;
  const auto& control = batch.control;
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim || pose.size(1) < 1)
    throw Error("rvae: pose must be [B, T >= 1, " + std::to_string(context_.pose_dim) + "]");
  if (control.dim() != 3 || control.size(0) != pose.size(0) || control.size(1) != pose.size(1))
    throw Error("rvae: control must be [B, T, C] matching pose");
  const int64_t t = pose.size(1), d = context_.pose_dim;
  const auto [pose_in, control_in] = dropped_inputs(pose, control);
  torch::Tensor labels;
  if (label_dim_ > 0) {
    const double pl = is_training() ? options_.label_dropout : 0.0;
    labels = label_features(drop_labels(batch.content, pl), drop_labels(batch.style, pl), pose.size(0),
                            context_.num_content, context_.num_style, pose.options());
  }
  const Posterior post = encode(pose_in);
  auto hc = encode_control(control_in, labels);
  auto eps = torch::randn(post.mean.sizes(), torch::TensorOptions().dtype(post.mean.scalar_type()))
                 .to(post.mean.device());
  auto z = post.mean + torch::exp(0.5 * post.logvar) * eps;
  const torch::Tensor use_latent = latent_use_mask(z);
  std::pair<torch::Tensor, torch::Tensor> prior;
  auto canvas = conditional() ? run_decoder_conditional(hc, z, 1.0, nullptr, &prior) : run_decoder(hc, z, use_latent);
  auto x_hat = decode_canvas(canvas).narrow(1, 0, t);
  auto recon = (0.5 * (x_hat - pose).pow(2).sum(-1) + 0.5 * d * kLog2Pi).mean();  // per frame
  auto kl = kl_per_frame(post, prior, use_latent, t);
  const double w = is_training() ? kl_now_ : options_.kl_weight;
  auto total = (recon + w * kl) / static_cast<double>(d);
  if (options_.l1 > 0 && is_training()) total = total + l1_penalty(total.options());
  LossTerms out;
  // The reconstruction takes the window's root steps as given, so both sides move with the data's.
  foot_.add({x_hat, batch.control, pose, batch.control, {}, batch.content, batch.style}, is_training(), &total, &out);
  out.terms["loss"] = total;
  out.terms["recon"] = recon.detach();
  out.terms["kl"] = kl.detach();
  out.terms["nll_frame"] = (recon + kl).detach();
  out.terms["nll_dim"] = ((recon + kl) / static_cast<double>(d)).detach();
  out.terms["kl_weight"] = torch::full({}, w, total.options()).detach();
  return out;
}

ModelTraits RvaeImpl::traits() const {
  ModelTraits t;
  t.control = InputUse::kTakes;
  t.labels = label_dim_ > 0;
  t.prefix = true;
  return t;
}

SampleOutput RvaeImpl::sample(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t d = context_.pose_dim, c = context_.control_dim, z = options_.latent;
  if (!request.control.defined() || request.control.dim() != 3 || request.control.size(2) != c)
    throw Error("sample request: control must be [B, T, " + std::to_string(c) + "]");
  const int64_t b = request.control.size(0), t = request.control.size(1);
  auto opts = cell->state_in->weight.options();
  if (t == 0) return {torch::zeros({b, 0, d}, opts), request.control};
  auto gen = at::detail::createCPUGenerator(request.seed);
  auto cpu = torch::TensorOptions().dtype(opts.dtype());
  auto control = request.control.to(opts);
  int64_t p = 0;
  torch::Tensor latents;
  if (request.prefix_pose.defined() && request.prefix_pose.size(1) > 0) {
    const auto& pre = request.prefix_pose;
    if (pre.dim() != 3 || pre.size(0) != b || pre.size(2) != d)
      throw Error("sample request: prefix_pose must be [" + std::to_string(b) + ", P, " + std::to_string(d) + "]");
    p = pre.size(1);
    torch::Tensor pre_ctrl;
    if (request.prefix_control.defined()) {
      if (request.prefix_control.dim() != 3 || request.prefix_control.size(0) != b ||
          request.prefix_control.size(1) != p || request.prefix_control.size(2) != c)
        throw Error("sample request: prefix_control must be [B, P, " + std::to_string(c) + "] matching prefix_pose");
      pre_ctrl = request.prefix_control.to(opts);
    } else {
      pre_ctrl = torch::zeros({b, p, c}, opts);
    }
    control = torch::cat({pre_ctrl, control}, 1);
    auto post = encode(pre.to(opts));  // [B, K, Z], K = ceil(P / R)
    auto eps = torch::randn(post.mean.sizes(), gen, cpu).to(opts.device());
    latents = post.mean + request.temperature * torch::exp(0.5 * post.logvar) * eps;
  } else {
    latents = (request.temperature * torch::randn({b, 1, z}, gen, cpu)).to(opts.device());
  }
  torch::Tensor labels;
  if (label_dim_ > 0)
    labels = label_features(request.content, request.style, b, context_.num_content, context_.num_style, opts);
  auto hc = encode_control(control, labels);
  if (conditional()) {
    auto x = decode_canvas(run_decoder_conditional(hc, latents, request.temperature, &gen));
    return {x.narrow(1, p, t).contiguous(), request.control};
  }
  if (options_.test_latents == "every_step" && hc.size(1) > latents.size(1)) {
    auto rest = request.temperature * torch::randn({b, hc.size(1) - latents.size(1), z}, gen, cpu);
    latents = torch::cat({latents, rest.to(opts.device())}, 1);
  }
  auto x = decode_canvas(run_decoder(hc, latents));
  return {x.narrow(1, p, t).contiguous(), request.control};
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(rvae, FamilyInfo{"rvae", FamilyKind::kMotion,
                                       "recurrent VAE: convolutional autoencoder with a recurrent latent (Habibie et al. 2017)",
                                       [](const nlohmann::json& config, const ModelContext& context) {
                                         return std::make_shared<RvaeImpl>(RvaeOptions::from_json(config), context);
                                       },
                                       {{"encoder_channels", {8, 12}}, {"control_channels", {6, 10}},
                                        {"decoder_channels", {8}}, {"latent", 5}, {"kernel", 5}},
                                       // Habibie et al. 2017, section 4.2: Adam at a constant 5e-4.
                                       {{"paper", {{"lr", 5e-4}, {"warmup", 0}}}}})

