#include "nn/mojo/mojo.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/nn/modules/activation.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/markers.h"
#include "nn/mojo/dct.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

// ---------------------------------------------------------------------------------------------
// Options

namespace {

const OptionFields<MojoOptions>& mojo_fields() {
  using O = MojoOptions;
  static const auto fields =
      OptionFields<O>("mojo")
          .field("preset", &O::preset, "named defaults: mojo (latent DCT) or mojo-dct (the paper's -DCT)",
                 one_of({"mojo", "mojo-dct"}))
          .field("latent_dct", &O::latent_dct, "latent frequency bands (false = one latent vector)")
          .field("latent", &O::latent, "latent size per band", at_least(1))
          .field("observed", &O::observed, "observed frames", at_least(1))
          .field("future", &O::future, "predicted frames per pass", at_least(1))
          .field("hidden", &O::hidden, "GRU width", at_least(1))
          .field_checked_on_read("mlp", &O::mlp, "hidden widths of the posterior and decoder MLPs", entries_at_least(1))
          .field("velocity_weight", &O::velocity_weight, "weight of the velocity term", at_least(0.0))
          .field("kl", &O::kl, "KL term: robust (Charbonnier) or standard", one_of({"robust", "standard"}))
          .field("kl_weight", &O::kl_weight, "weight of the KL term", at_least(0.0))
          .field("dlow_bands", &O::dlow_bands, "lowest bands mapped by DLow", at_least(1))
          .field("dlow_k", &O::dlow_k, "DLow samples per past", at_least(1))
          .field("dlow_hidden", &O::dlow_hidden, "width of DLow's GRU and MLP", at_least(1))
          .field("dlow_kl_weight", &O::dlow_kl_weight, "DLow KL weight", at_least(0.0))
          .field("dlow_recon_weight", &O::dlow_recon_weight, "DLow best-of-K reconstruction weight", at_least(0.0))
          .field("dlow_div_weight", &O::dlow_div_weight, "DLow diversity weight", at_least(0.0))
          .field("dlow_div_scale", &O::dlow_div_scale, "DLow diversity distance scale", at_least(1e-9))
          .field("dlow_fraction", &O::dlow_fraction, "share of the steps for the DLow stage", in_range(0.0, 0.95))
          .field("dlow_batch", &O::dlow_batch, "DLow stage: pasts per step from the batch (0 = all)", at_least(0))
          .field("sampler", &O::sampler, "latents at sampling: dlow or prior", one_of({"dlow", "prior"}))
          .field("projection", &O::projection, "recursive projection onto the skeleton (marker form)")
          .field("projection_iterations", &O::projection_iterations, "LM iterations per projected frame", at_least(1))
          .field("projection_prior", &O::projection_prior, "pose-change prior of the projection", at_least(0.0))
          .field("projection_threads", &O::projection_threads, "threads of the projection (0 = all)", at_least(0))
          .include(&O::foot, foot_objective_fields())
          .include(&O::draw, draw_objective_fields());
  return fields;
}

}  // namespace

MojoOptions MojoOptions::from_json(const nlohmann::json& config) {
  const auto& fields = mojo_fields();
  MojoOptions o;
  if (!config.is_object()) throw Error("mojo config must be a JSON object");
  if (config.contains("preset")) fields.read_key(config, "preset", &o);  // the preset's defaults first
  if (o.preset == "mojo-dct") {
    o.latent_dct = false;
    o.latent = 128;
    o.kl = "standard";
    o.kl_weight = 0.1;
    o.dlow_bands = 1;
  }
  fields.read(config, &o);
  fields.check(o);
  return o;
}

nlohmann::json MojoOptions::to_json() const { return mojo_fields().write(*this); }

// ---------------------------------------------------------------------------------------------
// Model

namespace {

torch::nn::Sequential mlp(int in, const std::vector<int>& hidden, int out) {
  torch::nn::Sequential s;
  for (int h : hidden) {
    s->push_back(torch::nn::Linear(in, h));
    s->push_back(torch::nn::Tanh());
    in = h;
  }
  s->push_back(torch::nn::Linear(in, out));
  return s;
}

torch::Tensor kl_unit(const torch::Tensor& mean, const torch::Tensor& logvar) {
  return 0.5 * (mean.pow(2) + logvar.exp() - 1.0 - logvar);
}

}  // namespace

MojoImpl::MojoImpl(const MojoOptions& options, const ModelContext& context)
    : MotionModel("Mojo"), options_(options), context_(context) {
  frame_dim_ = context.pose_dim + context.control_dim;
  if (context.pose_dim < 1) throw Error("mojo: pose_dim must be >= 1");
  foot_ = FootObjectives(context, options.foot, "mojo");
  draw_ = DrawObjectives(context, options.draw, options.foot, "mojo");
  const int h = options.hidden, z = options.latent, dc = frame_dim_;
  past_rnn = register_module("past_rnn", torch::nn::GRU(torch::nn::GRUOptions(dc, h).batch_first(true)));
  future_rnn = register_module("future_rnn", torch::nn::GRU(torch::nn::GRUOptions(dc, h).batch_first(true)));
  posterior = register_module("posterior", mlp(2 * h, options.mlp, 2 * z));
  dec_cell = register_module("dec_cell", torch::nn::GRUCell(torch::nn::GRUCellOptions(h + z + dc, h)));
  dec_mlp = register_module("dec_mlp", mlp(h, options.mlp, dc));
  dlow_rnn = register_module("dlow_rnn", torch::nn::GRU(torch::nn::GRUOptions(dc, options.dlow_hidden).batch_first(true)));
  dlow_heads = register_module("dlow_heads", torch::nn::ModuleList());
  const int bands = options.latent_dct ? options.dlow_bands : 1;
  for (int b = 0; b < bands; ++b)
    dlow_heads->push_back(mlp(options.dlow_hidden, {options.dlow_hidden}, options.dlow_k * 2 * z));
  dlow_trained_ = register_buffer("dlow_trained", torch::zeros({1}));
  {
    // The residual decoder starts near "hold the last frame".
    torch::NoGradGuard no_grad;
    auto last = dec_mlp->ptr<torch::nn::LinearImpl>(dec_mlp->size() - 1);
    last->weight.mul_(0.1);
    last->bias.zero_();
  }
}

ModelTraits MojoImpl::traits() const {
  ModelTraits t;
  t.control = InputUse::kGenerates;
  t.labels = false;
  t.prefix = true;
  t.streaming = false;  // the latent DCT spans the whole predicted window
  return t;
}

std::vector<TrainingStage> MojoImpl::training_stages(const TrainStageDefaults& defaults) const {
  const int n = std::max(2, defaults.steps);
  const int dlow_steps = std::max(1, static_cast<int>(std::lround(n * options_.dlow_fraction)));
  const int steps[2] = {std::max(1, n - dlow_steps), dlow_steps};
  const std::vector<std::string> cvae = {"past_rnn", "future_rnn", "posterior", "dec_cell", "dec_mlp"};
  std::vector<TrainingStage> stages;
  for (int i = 0; i < 2; ++i) {
    TrainingStage s;
    s.name = i == 0 ? "cvae" : "dlow";
    s.steps = steps[i];
    s.trained = i == 0 ? cvae : std::vector<std::string>{"dlow_rnn", "dlow_heads"};
    s.frozen = i == 0 ? std::vector<std::string>{"dlow_rnn", "dlow_heads"} : cvae;
    s.optimizer.lr = defaults.lr;
    s.schedule.kind = ScheduleSpec::Kind::kNoam;
    s.schedule.warmup =
        static_cast<int>(std::lround(static_cast<double>(defaults.warmup) * steps[i] / std::max(1, defaults.steps)));
    stages.push_back(s);
  }
  return stages;
}

void MojoImpl::begin_stage(int index, const TrainingStage& stage) {
  stage_ = index;
  if (index == 1) {
    torch::NoGradGuard no_grad;
    dlow_trained_.fill_(1.0);
  }
}

torch::Tensor MojoImpl::encode_past(const torch::Tensor& past) {
  return std::get<1>(past_rnn->forward(past)).select(0, 0);  // last layer's final state [B, H]
}

std::pair<torch::Tensor, torch::Tensor> MojoImpl::encode_future(const torch::Tensor& future, const torch::Tensor& h_x) {
  torch::Tensor feats;
  if (options_.latent_dct) {
    feats = mojo::dct_time(std::get<0>(future_rnn->forward(future)));  // [B, F, H] bands
  } else {
    feats = std::get<1>(future_rnn->forward(future)).select(0, 0).unsqueeze(1);  // [B, 1, H]
  }
  auto cond = h_x.unsqueeze(1).expand({feats.size(0), feats.size(1), h_x.size(1)});
  auto parts = posterior->forward(torch::cat({feats, cond}, -1)).chunk(2, -1);
  return {parts[0], parts[1]};
}

torch::Tensor MojoImpl::latent_sequence(const torch::Tensor& z, int64_t frames) const {
  if (options_.latent_dct) {
    if (z.size(1) != frames) throw Error("mojo: latent bands do not match the frames");
    return mojo::idct_time(z);
  }
  return z.expand({z.size(0), frames, z.size(2)});
}

torch::Tensor MojoImpl::decode(const torch::Tensor& h_x, const torch::Tensor& zseq, const torch::Tensor& last,
                               mojo::MarkerProjector* projector) {
  const int64_t frames = zseq.size(1);
  torch::Tensor h = torch::zeros({h_x.size(0), options_.hidden}, h_x.options());
  torch::Tensor prev = last;
  std::vector<torch::Tensor> out;
  out.reserve(frames);
  for (int64_t t = 0; t < frames; ++t) {
    h = dec_cell->forward(torch::cat({h_x, zseq.select(1, t), prev}, -1), h);
    torch::Tensor y = prev + dec_mlp->forward(h);
    if (projector) {
      auto cpu = y.detach().to(torch::kCPU, torch::kFloat32).contiguous().clone();
      projector->project(cpu.data_ptr<float>(), frame_dim_);
      y = cpu.to(y.options());
    }
    out.push_back(y);
    prev = y;
  }
  return torch::stack(out, 1);
}

int MojoImpl::dlow_band_count(int64_t frames) const {
  return options_.latent_dct ? static_cast<int>(std::min<int64_t>(options_.dlow_bands, frames)) : 1;
}

MojoImpl::DlowOut MojoImpl::dlow_latents(const torch::Tensor& past, const torch::Tensor& eps) {
  const int64_t b = past.size(0), nb = eps.size(1), k = options_.dlow_k, z = options_.latent;
  auto hq = std::get<1>(dlow_rnn->forward(past)).select(0, 0);  // [B, Hq]
  std::vector<torch::Tensor> zs, means, logvars;
  for (int64_t band = 0; band < nb; ++band) {
    auto maps = dlow_heads[band]->as<torch::nn::SequentialImpl>()->forward(hq).view({b, k, 2 * z});
    auto parts = maps.chunk(2, -1);
    const auto& mean = parts[0];   // b_k
    const auto& logvar = parts[1]; // log A_k^2
    zs.push_back(mean + torch::exp(0.5 * logvar) * eps.select(1, band).unsqueeze(1));
    means.push_back(mean);
    logvars.push_back(logvar);
  }
  return {torch::stack(zs, 2), torch::stack(means, 2), torch::stack(logvars, 2)};
}

LossTerms MojoImpl::loss(const Batch& batch) {
  const auto& pose = batch.pose;
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim || pose.size(1) < 2)
    throw Error("mojo: pose must be [B, T >= 2, " + std::to_string(context_.pose_dim) + "]");
  if (!batch.control.defined() || batch.control.dim() != 3 || batch.control.size(1) != pose.size(1))
    throw Error("mojo: control must be [B, T, C] matching pose");
  const int64_t t = pose.size(1);
  const int64_t p = std::min<int64_t>(options_.observed, t - 1);
  const int64_t f = std::min<int64_t>(options_.future, t - p);
  auto x = torch::cat({pose, batch.control.to(pose.options())}, -1);
  if (stage_ == 1 && options_.dlow_batch > 0 && x.size(0) > options_.dlow_batch) x = x.narrow(0, 0, options_.dlow_batch);
  return stage_ == 1 ? dlow_loss(x.narrow(1, 0, p), x.narrow(1, p, f))
                     : cvae_loss(x.narrow(1, 0, p), x.narrow(1, p, f), batch);
}

LossTerms MojoImpl::cvae_loss(const torch::Tensor& past, const torch::Tensor& future, const Batch& batch) {
  const int64_t f = future.size(1);
  auto h_x = encode_past(past);
  auto [mean, logvar] = encode_future(future, h_x);
  auto eps = torch::randn(mean.sizes(), torch::TensorOptions().dtype(mean.scalar_type())).to(mean.device());
  auto z = mean + torch::exp(0.5 * logvar) * eps;
  auto last = past.select(1, past.size(1) - 1);
  auto y_hat = decode(h_x, latent_sequence(z, f), last);
  auto recon = (y_hat - future).pow(2).sum({1, 2});  // [B]
  auto with_last = [&](const torch::Tensor& y) { return torch::cat({last.unsqueeze(1), y}, 1); };
  auto vel = with_last(future).diff(1, 1), vel_hat = with_last(y_hat).diff(1, 1);
  auto velocity = (vel_hat - vel).pow(2).sum({1, 2});
  auto kl = kl_unit(mean, logvar).sum({1, 2});  // [B] nats per sequence
  auto kl_term = options_.kl == "robust" ? torch::sqrt(1.0 + kl.pow(2)) - 1.0 : kl;
  auto per_seq = recon + options_.velocity_weight * velocity + options_.kl_weight * kl_term;
  const double scale = static_cast<double>(f * frame_dim_);
  LossTerms out;
  out.terms["loss"] = per_seq.mean() / scale;
  out.terms["recon"] = (recon.mean() / scale).detach();
  out.terms["velocity"] = (velocity.mean() / scale).detach();
  out.terms["kl"] = kl.mean().detach();
  out.terms["kl_term"] = kl_term.mean().detach();
  // The future after the last observed frame, its markers moving with the root steps it predicts.
  const int64_t d = context_.pose_dim, c = frame_dim_ - d;
  const auto made = with_last(y_hat), real = with_last(future);
  foot_.add({made.narrow(-1, 0, d), made.narrow(-1, d, c), real.narrow(-1, 0, d), real.narrow(-1, d, c), {},
             batch.content, batch.style},
            is_training(), &out.terms["loss"], &out);
  if (draw_.on() && is_training()) {  // the same future drawn from the prior, as at sampling
    const auto drawn = with_last(decode(h_x, latent_sequence(torch::randn_like(mean), f), last));
    draw_.add({drawn.narrow(-1, 0, d), drawn.narrow(-1, d, c), real.narrow(-1, 0, d), real.narrow(-1, d, c), {},
               batch.content, batch.style},
              true, &out.terms["loss"], &out);
  }
  return out;
}

LossTerms MojoImpl::dlow_loss(const torch::Tensor& past, const torch::Tensor& future) {
  const int64_t b = past.size(0), f = future.size(1), k = options_.dlow_k, z = options_.latent;
  const int nb = dlow_band_count(f);
  torch::Tensor h_x;
  {
    torch::NoGradGuard no_grad;  // the CVAE is frozen
    h_x = encode_past(past);
  }
  auto opts = torch::TensorOptions().dtype(past.scalar_type());
  auto eps = torch::randn({b, nb, z}, opts).to(past.device());
  auto d = dlow_latents(past, eps);  // z [B, K, nb, Z]
  torch::Tensor latents = d.z;
  if (options_.latent_dct && f > nb)
    latents = torch::cat({latents, torch::randn({b, k, f - nb, z}, opts).to(past.device())}, 2);
  latents = latents.reshape({b * k, latents.size(2), z});
  auto last = past.select(1, past.size(1) - 1).repeat_interleave(k, 0);
  auto y_hat = decode(h_x.repeat_interleave(k, 0), latent_sequence(latents, f), last).view({b, k, f, frame_dim_});
  auto err = (y_hat - future.unsqueeze(1)).pow(2).mean({2, 3});  // [B, K]
  auto recon = std::get<0>(err.min(1)).mean();
  auto kl = kl_unit(d.mean, d.logvar).mean();
  auto flat = y_hat.reshape({b, k, f * frame_dim_});
  auto sq = flat.pow(2).sum(-1);  // [B, K]
  auto d2 = (sq.unsqueeze(2) + sq.unsqueeze(1) - 2.0 * torch::matmul(flat, flat.transpose(1, 2))).clamp_min(1e-8);
  auto rms = torch::sqrt(d2 / static_cast<double>(f * frame_dim_));
  auto off_diag = 1.0 - torch::eye(k, opts).to(past.device());
  auto div = k > 1 ? ((-rms / options_.dlow_div_scale).exp() * off_diag).sum({1, 2}).mean() / static_cast<double>(k * (k - 1))
                   : torch::zeros({}, opts);
  auto total = options_.dlow_recon_weight * recon + options_.dlow_kl_weight * kl + options_.dlow_div_weight * div;
  LossTerms out;
  out.terms["loss"] = total;
  out.terms["dlow_recon"] = recon.detach();
  out.terms["dlow_kl"] = kl.detach();
  out.terms["dlow_div"] = div.detach();
  return out;
}

bool MojoImpl::can_project() const {
  return options_.projection && context_.pose_form == data::PoseForm::kMarkers && context_.skeleton.num_joints() > 0 &&
         static_cast<int>(context_.stats.pose_mean.size()) == context_.pose_dim &&
         static_cast<int>(context_.stats.pose_std.size()) == context_.pose_dim &&
         context_.pose_dim == data::expected_pose_dim(data::PoseForm::kMarkers, 0, false);
}

std::vector<SampleStageTiming> MojoImpl::last_sample_timings() const {
  if (last_timing_.calls == 0) return {};
  return {{"projection", last_timing_.seconds, last_timing_.calls, last_timing_.frames}};
}

SampleOutput MojoImpl::sample(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t d = context_.pose_dim, c = context_.control_dim, zdim = options_.latent;
  if (!request.control.defined() || request.control.dim() != 3 || request.control.size(2) != c)
    throw Error("sample request: control must be [B, T, " + std::to_string(c) + "] (only its shape is read)");
  const int64_t b = request.control.size(0), t = request.control.size(1);
  auto opts = dec_cell->weight_ih.options();
  if (t == 0) return {torch::zeros({b, 0, d}, opts), torch::zeros({b, 0, c}, opts)};
  torch::Tensor history;
  if (request.prefix_pose.defined() && request.prefix_pose.size(1) > 0) {
    const auto& pre = request.prefix_pose;
    if (pre.dim() != 3 || pre.size(0) != b || pre.size(2) != d)
      throw Error("sample request: prefix_pose must be [" + std::to_string(b) + ", P, " + std::to_string(d) + "]");
    auto pre_ctrl = request.prefix_control.defined() ? request.prefix_control.to(opts) : torch::zeros({b, pre.size(1), c}, opts);
    if (pre_ctrl.dim() != 3 || pre_ctrl.size(0) != b || pre_ctrl.size(1) != pre.size(1) || pre_ctrl.size(2) != c)
      throw Error("sample request: prefix_control must be [B, P, " + std::to_string(c) + "] matching prefix_pose");
    history = torch::cat({pre.to(opts), pre_ctrl}, -1);
  } else {
    history = torch::zeros({b, 1, frame_dim_}, opts);  // the mean pose, standing
  }
  auto gen = at::detail::createCPUGenerator(request.seed);
  auto cpu = torch::TensorOptions().dtype(opts.dtype());
  std::unique_ptr<mojo::MarkerProjector> projector;
  if (can_project()) {
    mojo::ProjectionOptions po;
    po.iterations = options_.projection_iterations;
    po.pose_prior = options_.projection_prior;
    po.threads = options_.projection_threads;
    const auto& st = context_.stats;
    projector = std::make_unique<mojo::MarkerProjector>(context_.skeleton, std::vector<double>(st.pose_mean.begin(), st.pose_mean.end()),
                                                        std::vector<double>(st.pose_std.begin(), st.pose_std.end()),
                                                        static_cast<int>(b), po);
    // Start every row's body at the last observed frame (its fitted markers are not fed back).
    auto last = history.select(1, history.size(1) - 1).to(torch::kCPU, torch::kFloat32).contiguous().clone();
    projector->project(last.data_ptr<float>(), frame_dim_);
    projector->reset_timing();  // timings count predicted frames only
  }
  const bool dlow = options_.sampler == "dlow" && dlow_trained();
  const int64_t k = options_.dlow_k, f = options_.future;
  std::vector<torch::Tensor> chunks;
  int64_t made = 0;
  while (made < t) {
    const int64_t p = std::min<int64_t>(options_.observed, history.size(1));
    auto past = history.narrow(1, history.size(1) - p, p);
    auto h_x = encode_past(past);
    const int64_t bands = options_.latent_dct ? f : 1;
    torch::Tensor z;
    if (dlow) {
      const int nb = dlow_band_count(f);
      const int64_t groups = (b + k - 1) / k;
      auto eps_groups = request.temperature * torch::randn({groups, nb, zdim}, gen, cpu);
      auto row_group = torch::arange(b, torch::kLong).div(k, "floor");
      auto d_out = dlow_latents(past, eps_groups.index_select(0, row_group).to(opts.device()));
      auto row_k = torch::arange(b, torch::kLong).remainder(k).to(opts.device());
      z = d_out.z.index({torch::arange(b, torch::kLong).to(opts.device()), row_k});  // [B, nb, Z]
      if (bands > nb) z = torch::cat({z, (request.temperature * torch::randn({b, bands - nb, zdim}, gen, cpu)).to(opts.device())}, 1);
    } else {
      z = (request.temperature * torch::randn({b, bands, zdim}, gen, cpu)).to(opts.device());
    }
    auto y = decode(h_x, latent_sequence(z, f), past.select(1, p - 1), projector.get());
    chunks.push_back(y);
    history = torch::cat({history, y}, 1);
    made += f;
  }
  last_timing_ = projector ? projector->timing() : mojo::ProjectionTiming{};
  auto all = torch::cat(chunks, 1).narrow(1, 0, t);
  return {all.narrow(2, 0, d).contiguous(), all.narrow(2, d, c).contiguous()};
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(mojo, FamilyInfo{"mojo", FamilyKind::kMotion,
                                       "MOJO: CVAE with latent DCT, DLow sampling, recursive projection (Zhang et al. 2021)",
                                       [](const nlohmann::json& config, const ModelContext& context) {
                                         return std::make_shared<MojoImpl>(MojoOptions::from_json(config), context);
                                       },
                                       {{"latent", 3},
                                        {"observed", 3},
                                        {"future", 4},
                                        {"hidden", 8},
                                        {"mlp", {8}},
                                        {"dlow_bands", 2},
                                        {"dlow_k", 3},
                                        {"dlow_hidden", 8},
                                        {"projection_threads", 1}},
                                 {}})
