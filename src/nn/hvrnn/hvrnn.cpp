#include "nn/hvrnn/hvrnn.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/nn/functional/loss.h>
#include <torch/utils.h>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "core/error.h"
#include "nn/classifier/classifier.h"
#include "nn/kinematics.h"
#include "nn/label_features.h"
#include "nn/run.h"

namespace mosyn::nn {

namespace {

using Out = HvrnnMlpImpl::Out;

double ramp(double progress, double start, double length) {
  if (length <= 0) return progress >= start ? 1.0 : 0.0;
  return std::clamp((progress - start) / length, 0.0, 1.0);
}

// [..., F] -> [..., F + 1]: a frame with the flag 1 (decoder_previous_frame's input).
torch::Tensor with_flag(const torch::Tensor& frame) {
  auto shape = frame.sizes().vec();
  shape.back() = 1;
  return torch::cat({frame, torch::ones(shape, frame.options())}, -1);
}

// [B, T, F] -> [B, ceil(T / l) l, F] repeating the last frame.
torch::Tensor pad_to_words(const torch::Tensor& x, int64_t l) {
  const int64_t t = x.size(1), padded = (t + l - 1) / l * l;
  if (padded == t) return x;
  return torch::cat({x, x.narrow(1, t - 1, 1).expand({x.size(0), padded - t, x.size(2)})}, 1);
}

}  // namespace

HvrnnImpl::HvrnnImpl(const HvrnnOptions& o, const ModelContext& context)
    : MotionModel("Hvrnn"), options_(o), context_(context) {
  if (context.pose_dim < 1 || context.control_dim < 1) throw Error("hvrnn: the context needs pose and control dims");
  geometry_ = hvrnn::geometry_for(context, o);
  foot_ = FootObjectives(context, o.foot, "hvrnn");
  draw_ = DrawObjectives(context, o.draw, o.foot, "hvrnn");
  label_dim_ = context.num_content + context.num_style;
  const int w = word_dim(), s = o.state * o.state_layers, a = o.label_code, raw = o.word_length * frame_dim();
  if (o.word_coder) {
    word_encoder = register_module("word_encoder", HvrnnMlp(raw, o.word_hidden, 2, w, Out::kElu));
    // With decoder_previous_frame the previous frame and its flag follow the code (a warm start
    // from a run without them grows these input weights with zeros).
    const int previous = o.decoder_previous_frame ? frame_dim() + 1 : 0;
    word_decoder = register_module("word_decoder", HvrnnMlp(w + previous, o.word_hidden, 2, raw, Out::kNone));
  }
  f_w = register_module("f_w", HvrnnMlp(w, o.feature_hidden, 2, o.feature, Out::kElu));
  f_z = register_module("f_z", HvrnnMlp(o.latent, o.feature_hidden, 2, o.feature, Out::kElu));
  // Without a word coder the cell emits frames: no ELU on standardised features.
  f_dec = register_module("f_dec", HvrnnMlp(o.feature + s + a, o.feature_hidden, 2, w, o.word_coder ? Out::kElu : Out::kNone));
  const int post_in = o.feature + s + a, prior_in = s + a, gh = o.gaussian_hidden, gl = o.gaussian_layers;
  post_mu = register_module("post_mu", HvrnnMlp(post_in, gh, gl, o.latent, Out::kNone));
  post_sigma = register_module("post_sigma", HvrnnMlp(post_in, gh, gl, o.latent, Out::kSoftplus));
  prior_mu = register_module("prior_mu", HvrnnMlp(prior_in, gh, gl, o.latent, Out::kNone));
  prior_sigma = register_module("prior_sigma", HvrnnMlp(prior_in, gh, gl, o.latent, Out::kSoftplus));
  if (label_dim_ > 0) f_c = register_module("f_c", torch::nn::Linear(label_dim_, a));
  grus = register_module("grus", torch::nn::ModuleList());
  for (int i = 0; i < o.state_layers; ++i) grus->push_back(torch::nn::GRUCell(i == 0 ? 2 * o.feature : o.state, o.state));
  const int64_t combos = static_cast<int64_t>(context.num_content + 1) * (context.num_style + 1);
  init_mean = register_parameter("init_mean", torch::zeros({combos, s}));
  init_logstd = register_parameter("init_logstd", torch::full({combos, s}, std::log(o.init_std)));
}

int HvrnnImpl::word_dim() const {
  return options_.word_coder ? options_.word_code : options_.word_length * frame_dim();
}

void HvrnnImpl::set_progress(int step, int total_steps) {
  progress_ = total_steps > 0 ? std::clamp(static_cast<double>(step) / total_steps, 0.0, 1.0) : 1.0;
}

double HvrnnImpl::current_kl_weight() const {
  return options_.kl_weight * ramp(progress_, options_.kl_warmup, options_.kl_anneal);
}
double HvrnnImpl::current_classifier_weight() const {
  return options_.classifier_weight * ramp(progress_, 0.0, options_.classifier_ramp);
}
double HvrnnImpl::current_word_drop() const {
  return options_.word_drop * ramp(progress_, 0.0, options_.word_drop_ramp);
}

torch::Tensor HvrnnImpl::draw(at::IntArrayRef sizes, const torch::TensorOptions& opts, at::Generator* gen) const {
  auto cpu = torch::TensorOptions().dtype(opts.dtype());
  return (gen ? torch::randn(sizes, *gen, cpu) : torch::randn(sizes, cpu)).to(opts.device());
}

torch::Tensor HvrnnImpl::encode_words(const torch::Tensor& frames) {
  const int64_t b = frames.size(0), n = frames.size(1) / options_.word_length;
  auto raw = frames.reshape({b, n, options_.word_length * frame_dim()});
  return options_.word_coder ? word_encoder->forward(raw) : raw;
}

torch::Tensor HvrnnImpl::decode_words(const torch::Tensor& words, const torch::Tensor& previous) {
  const int64_t b = words.size(0), n = words.size(1);
  torch::Tensor raw = words;
  if (options_.word_coder) {
    auto in = words;
    if (options_.decoder_previous_frame) {
      if (!previous.defined() || previous.sizes() != at::IntArrayRef({b, n, frame_dim() + 1}))
        throw Error("hvrnn: decode_words needs previous frames [B, N, F + 1]");
      in = torch::cat({words, previous.to(words.options())}, -1);
    }
    raw = word_decoder->forward(in);
  }
  return raw.reshape({b, n * options_.word_length, frame_dim()});
}

torch::Tensor HvrnnImpl::teacher_previous(const torch::Tensor& frames) const {
  const int64_t b = frames.size(0), l = options_.word_length, n = frames.size(1) / l;
  auto none = torch::zeros({b, 1, frame_dim() + 1}, frames.options());
  if (n < 2) return none;
  // The last frame of words 0..n-2, each with the flag 1.
  auto last = frames.narrow(1, 0, (n - 1) * l).reshape({b, n - 1, l, frame_dim()}).select(2, l - 1);
  return torch::cat({none, with_flag(last)}, 1);
}

torch::Tensor HvrnnImpl::decode_generated(const torch::Tensor& words, torch::Tensor* previous, torch::Tensor* before) {
  if (!options_.decoder_previous_frame) return normalise_rotations(decode_words(words));
  const int64_t l = options_.word_length;
  const bool blend = before && options_.boundary_blend > 0 && l >= 2;
  std::vector<torch::Tensor> out;
  for (int64_t i = 0; i < words.size(1); ++i) {
    auto frames = normalise_rotations(decode_words(words.narrow(1, i, 1), previous->unsqueeze(1)));  // [B, l, F]
    if (blend) {
      if (before->defined()) frames = blend_boundary(frames, previous->narrow(-1, 0, frame_dim()), *before);
      *before = frames.select(1, l - 2);
    }
    *previous = with_flag(frames.select(1, l - 1));
    out.push_back(frames);
  }
  return torch::cat(out, 1);
}

torch::Tensor HvrnnImpl::blend_boundary(const torch::Tensor& frames, const torch::Tensor& previous,
                                        const torch::Tensor& before) const {
  const int64_t l = frames.size(1);
  auto first = frames.select(1, 0);
  auto expected = previous + 0.5 * ((previous - before) + (frames.select(1, 1) - first));
  auto decay = torch::pow(torch::full({l}, options_.boundary_blend, frames.options()),
                          torch::arange(l, frames.options())).view({1, l, 1});
  return normalise_rotations(frames + (expected - first).unsqueeze(1) * decay);
}

std::pair<torch::Tensor, torch::Tensor> HvrnnImpl::prefix_tail(const SampleRequest& request, int64_t b) {
  auto frames = prefix_frames(request, b);
  if (!frames.defined()) return {torch::zeros({b, frame_dim() + 1}, init_mean.options()), {}};
  const int64_t p = frames.size(1);
  return {with_flag(frames.select(1, p - 1)), p >= 2 ? frames.select(1, p - 2) : torch::Tensor()};
}

torch::Tensor HvrnnImpl::label_code(const torch::Tensor& content, const torch::Tensor& style, int64_t b,
                                    const torch::TensorOptions& opts) {
  if (label_dim_ == 0) return torch::zeros({b, options_.label_code}, opts);
  auto onehot = label_features(content, style, b, context_.num_content, context_.num_style, opts);
  return torch::elu(f_c->forward(onehot));
}

torch::Tensor HvrnnImpl::initial_state(const torch::Tensor& content, const torch::Tensor& style, int64_t b,
                                       double temperature, at::Generator* gen) {
  auto opts = init_mean.options();
  auto index = torch::zeros({b}, torch::kInt64);
  if (content.defined() && context_.num_content > 0) index = index + (content.to(torch::kCPU) + 1) * (context_.num_style + 1);
  if (style.defined() && context_.num_style > 0) index = index + style.to(torch::kCPU) + 1;
  if (index.min().item<int64_t>() < 0 || index.max().item<int64_t>() >= init_mean.size(0))
    throw Error("hvrnn: a label is outside its vocabulary");
  index = index.to(opts.device());
  auto mean = init_mean.index_select(0, index), std = init_logstd.index_select(0, index).exp();
  return mean + temperature * std * draw(mean.sizes(), opts, gen);
}

torch::Tensor HvrnnImpl::cell_step(std::vector<torch::Tensor>& hs, const torch::Tensor& word,
                                   const torch::Tensor& drop, const torch::Tensor& a, double temperature,
                                   at::Generator* gen, torch::Tensor* kl, torch::Tensor* prior_word) {
  const double floor = options_.spread_floor;
  auto h = torch::cat(hs, -1);
  auto prior_in = torch::cat({h, a}, -1);
  auto mp = prior_mu->forward(prior_in), sp = prior_sigma->forward(prior_in) + floor;
  torch::Tensor z, fw;
  if (word.defined()) {  // Alg. 1: the posterior of the observed word
    fw = f_w->forward(word);
    auto post_in = torch::cat({fw, h, a}, -1);
    auto mq = post_mu->forward(post_in), sq = post_sigma->forward(post_in) + floor;
    z = mq + temperature * sq * draw(mq.sizes(), mq.options(), gen);
    if (kl) *kl = hvrnn::gaussian_kl(mq, sq, mp, sp);
    if (prior_word) {
      auto zp = mp + temperature * sp * draw(mp.sizes(), mp.options(), gen);
      *prior_word = f_dec->forward(torch::cat({f_z->forward(zp), h, a}, -1));
    }
  } else {  // Alg. 2: the prior
    z = mp + temperature * sp * draw(mp.sizes(), mp.options(), gen);
  }
  auto fz = f_z->forward(z);
  auto out = f_dec->forward(torch::cat({fz, h, a}, -1));
  if (!word.defined()) {
    fw = f_w->forward(out);  // Alg. 2: the generated word is fed back
  } else if (drop.defined()) {
    fw = torch::where(drop.unsqueeze(1), f_w->forward(out), fw);  // scheduled word dropping
  }
  auto x = torch::cat({fw, fz}, -1);
  for (int l = 0; l < options_.state_layers; ++l) {
    hs[l] = grus[l]->as<torch::nn::GRUCellImpl>()->forward(x, hs[l]);
    x = hs[l];
  }
  return out;
}

HvrnnImpl::Unroll HvrnnImpl::unroll(const torch::Tensor& words, const torch::Tensor& drop, int64_t n,
                                    const torch::Tensor& h0, const torch::Tensor& a, double temperature,
                                    at::Generator* gen, bool with_prior) {
  const int64_t k = words.defined() ? words.size(1) : 0;
  std::vector<torch::Tensor> hs = h0.chunk(options_.state_layers, -1);
  std::vector<torch::Tensor> outs, kls, priors;
  for (int64_t i = 0; i < n; ++i) {
    torch::Tensor kl, prior;
    const bool teacher = i < k;
    outs.push_back(cell_step(hs, teacher ? words.select(1, i) : torch::Tensor(),
                             teacher && drop.defined() ? drop.select(1, i) : torch::Tensor(), a, temperature, gen,
                             teacher ? &kl : nullptr, teacher && with_prior ? &prior : nullptr));
    if (teacher) kls.push_back(kl);
    if (prior.defined()) priors.push_back(prior);
  }
  Unroll u;
  u.out = torch::stack(outs, 1);
  if (!kls.empty()) u.kl = torch::stack(kls, 1);
  if (!priors.empty()) u.prior = torch::stack(priors, 1);
  return u;
}

torch::Tensor HvrnnImpl::normalise_rotations(const torch::Tensor& frames) const {
  if (!geometry_.valid) return frames;
  const int64_t j = geometry_.num_joints;
  auto mean = geometry_.mean.to(frames.options()), std = geometry_.std.to(frames.options());
  auto slots = frames.narrow(-1, 1, 6 * j);
  auto raw = slots * std.narrow(0, 1, 6 * j) + mean.narrow(0, 1, 6 * j);
  auto shape = raw.sizes().vec();
  shape.back() = j;
  shape.push_back(6);
  auto fixed = rot6d_from_matrix(matrix_from_rot6d(raw.reshape(shape))).reshape(raw.sizes());
  auto standardised = (fixed - mean.narrow(0, 1, 6 * j)) / std.narrow(0, 1, 6 * j);
  return torch::cat({frames.narrow(-1, 0, 1), standardised, frames.narrow(-1, 1 + 6 * j, frames.size(-1) - 1 - 6 * j)},
                    -1);
}

HvrnnImpl::Recon HvrnnImpl::reconstruction(const torch::Tensor& pred, const torch::Tensor& target) {
  Recon r;
  if (!geometry_.valid) {
    r.recon = 0.5 * (pred - target).pow(2).sum(-1);
    r.validity = torch::zeros_like(r.recon);
    r.geodesic = torch::zeros_like(r.recon);
    return r;
  }
  const int64_t j = geometry_.num_joints, d = context_.pose_dim;
  auto mean = geometry_.mean.to(pred.options()).narrow(0, 1, 6 * j);
  auto std = geometry_.std.to(pred.options()).narrow(0, 1, 6 * j);
  auto shape = pred.sizes().vec();
  shape.back() = j;
  shape.push_back(6);
  auto p6 = (pred.narrow(-1, 1, 6 * j) * std + mean).reshape(shape);
  auto t6 = (target.narrow(-1, 1, 6 * j) * std + mean).reshape(shape);
  auto alpha = torch::tensor(geometry_.alpha, pred.options());
  auto geo = hvrnn::weighted_geodesic(p6, t6, alpha);
  std::vector<int64_t> others(geometry_.other_dims.begin(), geometry_.other_dims.end());
  for (int64_t c = 0; c < context_.control_dim; ++c) others.push_back(d + c);
  auto idx = torch::tensor(others, torch::kInt64).to(pred.device());
  auto rest = 0.5 * (pred.index_select(-1, idx) - target.index_select(-1, idx)).pow(2).sum(-1);
  r.recon = geo + options_.root_weight * rest;
  r.validity = hvrnn::rot6d_validity(p6);
  r.geodesic = (geodesic_angle(matrix_from_rot6d(p6), matrix_from_rot6d(t6))).mean(-1).detach();
  return r;
}

torch::Tensor HvrnnImpl::classifier_term(const torch::Tensor& pred, const torch::Tensor& target, const Batch& batch) {
  if (!classifier_) {
    LoadOptions lo;
    lo.threads = -1;
    auto run = load_run(options_.classifier_run, lo);
    classifier_ = std::dynamic_pointer_cast<ClassifierImpl>(run.trainable);
    if (!classifier_) throw Error("hvrnn: classifier_run '" + options_.classifier_run + "' is not a classifier run");
    if (run.context.pose_dim != context_.pose_dim) throw Error("hvrnn: the classifier was trained on other features");
    for (auto& p : classifier_->parameters()) p.set_requires_grad(false);
    classifier_->eval();
  }
  classifier_->to(pred.device());
  const int64_t d = context_.pose_dim, c = context_.control_dim;
  auto out = classifier_->forward(pred.narrow(-1, 0, d), pred.narrow(-1, d, c));
  torch::Tensor ref;
  {
    torch::NoGradGuard no_grad;
    ref = classifier_->forward(target.narrow(-1, 0, d), target.narrow(-1, d, c)).features;
  }
  auto term = options_.classifier_feature_weight * (out.features - ref).pow(2).sum(-1).mean();
  namespace F = torch::nn::functional;
  auto ce = [&](const torch::Tensor& logits, const torch::Tensor& labels) {
    if (!logits.defined() || !labels.defined() || (labels >= 0).sum().item<int64_t>() == 0) return torch::zeros({}, pred.options());
    return F::cross_entropy(logits, labels.to(logits.device()), F::CrossEntropyFuncOptions().ignore_index(-1));
  };
  return term + ce(out.content_logits, batch.content) + ce(out.style_logits, batch.style);
}

void HvrnnImpl::prior_draw_terms(const Unroll& u, const torch::Tensor& frames, const torch::Tensor& previous,
                                  const torch::Tensor& mask, const torch::Tensor& word_mask, const Batch& batch,
                                  torch::Tensor* total, LossTerms* terms) {
  const int64_t b = frames.size(0), l = options_.word_length, n = frames.size(1) / l;
  const bool boundary = options_.boundary_weight > 0 && n > 1;
  const bool drawn = draw_.on() && is_training();
  if (options_.boundary_weight > 0) terms->terms["boundary"] = torch::zeros({}, total->options());
  if (!boundary && !drawn) return;
  torch::Tensor teacher_drawn;  // each drawn word after the real frame before it
  if (boundary || !options_.draw_chained) teacher_drawn = decode_words(u.prior, previous);
  if (boundary) {
    // The first frame of words 1..n-1 decoded from a prior draw, against the real first frame.
    auto first = [&](const torch::Tensor& x) {
      return x.reshape({b, n, l, frame_dim()}).select(2, 0).narrow(1, 1, n - 1);
    };
    auto r_first = reconstruction(first(teacher_drawn), first(frames));
    auto first_mask = word_mask.narrow(1, 1, n - 1);
    auto boundary_error = (r_first.recon * first_mask).sum() / first_mask.sum().clamp_min(1.0);
    *total = *total + options_.boundary_weight * boundary_error;
    terms->terms["boundary"] = boundary_error.detach();
  }
  if (!drawn) return;
  torch::Tensor drawn_frames = teacher_drawn;
  if (options_.draw_chained) {  // as generation: each word after the drawn one before it
    auto chained = torch::zeros({b, frame_dim() + 1}, frames.options());
    drawn_frames = decode_generated(u.prior, &chained);
  }
  const int64_t d = context_.pose_dim, c = context_.control_dim;
  draw_.add({drawn_frames.narrow(-1, 0, d), drawn_frames.narrow(-1, d, c), frames.narrow(-1, 0, d),
             frames.narrow(-1, d, c), mask, batch.content, batch.style},
            true, total, terms);
}

LossTerms HvrnnImpl::loss(const Batch& batch) {
  const auto& pose = batch.pose;
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim || pose.size(1) < 1)
    throw Error("hvrnn: pose must be [B, T >= 1, " + std::to_string(context_.pose_dim) + "]");
  if (!batch.control.defined() || batch.control.sizes() != at::IntArrayRef({pose.size(0), pose.size(1), context_.control_dim}))
    throw Error("hvrnn: control must be [B, T, C] matching pose");
  const int64_t b = pose.size(0), t = pose.size(1), l = options_.word_length;
  auto frames = pad_to_words(torch::cat({pose, batch.control}, -1), l);
  const int64_t n = frames.size(1) / l;
  // Valid frames per window ([B, 1]): padding to whole words and short clips' padding are masked
  // out of recon, validity and geodesic; a word counts in the KL when it starts on a valid frame.
  auto valid_frames = batch.frames.defined() ? batch.frames.to(pose.device()).to(torch::kInt64).clamp(1, t).unsqueeze(1)
                                             : torch::full({b, 1}, t, torch::dtype(torch::kInt64).device(pose.device()));
  const auto index_options = torch::dtype(torch::kInt64).device(pose.device());
  auto mask = (torch::arange(frames.size(1), index_options).unsqueeze(0) < valid_frames).to(pose.dtype());
  auto word_mask = (torch::arange(n, index_options).unsqueeze(0) * l < valid_frames).to(pose.dtype());
  const double pl = is_training() ? options_.label_dropout : 0.0;
  auto content = drop_labels(batch.content, pl), style = drop_labels(batch.style, pl);
  auto a = label_code(content, style, b, pose.options());
  auto h0 = initial_state(content, style, b, 1.0, nullptr);
  torch::Tensor drop;
  const double p_drop = is_training() ? current_word_drop() : 0.0;
  if (p_drop > 0) drop = (torch::rand({b, n}) < p_drop).to(pose.device());
  const bool boundary = options_.boundary_weight > 0 && n > 1;
  const bool drawn = draw_.on() && is_training();
  auto u = unroll(encode_words(frames), drop, n, h0, a, 1.0, nullptr, boundary || drawn);
  auto previous = options_.decoder_previous_frame ? teacher_previous(frames) : torch::Tensor();
  auto pred = decode_words(u.out, previous);
  auto r = reconstruction(pred, frames);
  auto valid = mask.sum();
  auto recon = (r.recon * mask).sum() / valid;
  auto validity = (r.validity * mask).sum() / valid;
  auto kl = (u.kl * word_mask).sum() / valid;
  const double w_kl = is_training() ? current_kl_weight() : options_.kl_weight;
  // Free bits: below the budget the clamp passes no gradient to the posterior or prior.
  auto kl_loss = options_.kl_free_nats > 0 ? torch::clamp_min(kl, options_.kl_free_nats) : kl;
  auto total = recon + w_kl * kl_loss + options_.validity_weight * validity;
  LossTerms terms;
  prior_draw_terms(u, frames, previous, mask, word_mask, batch, &total, &terms);
  torch::Tensor velocity;
  if (options_.velocity_weight > 0) {
    velocity = hvrnn::velocity_error(pred, frames, mask);
    total = total + options_.velocity_weight * velocity;
  } else {
    torch::NoGradGuard reported_only;  // logged, so kept out of the graph when it is not trained
    velocity = hvrnn::velocity_error(pred, frames, mask);
  }
  torch::Tensor cl = torch::zeros({}, total.options());
  const double w_cl = is_training() ? current_classifier_weight() : options_.classifier_weight;
  if (!options_.classifier_run.empty() && w_cl > 0) {
    // The classifier sees each window as the data pads it: its last valid frame repeated.
    auto last_valid = torch::minimum(torch::arange(t, index_options).unsqueeze(0), valid_frames - 1);  // [B, t]
    auto held = [&](const torch::Tensor& x) {
      return x.narrow(1, 0, t).gather(1, last_valid.unsqueeze(-1).expand({b, t, x.size(2)}));
    };
    cl = classifier_term(held(pred), held(frames), batch);
    total = total + w_cl * cl;
  }
  // The reconstruction's feet move with the root steps it reconstructs (the model makes its root).
  const int64_t d = context_.pose_dim, c = context_.control_dim;
  foot_.add({pred.narrow(-1, 0, d), pred.narrow(-1, d, c), frames.narrow(-1, 0, d), frames.narrow(-1, d, c), mask,
             batch.content, batch.style},
            is_training(), &total, &terms);
  terms.terms["loss"] = total;
  terms.terms["recon"] = recon.detach();
  terms.terms["kl"] = kl.detach();
  terms.terms["validity"] = validity.detach();
  terms.terms["velocity"] = velocity.detach();
  terms.terms["classifier"] = cl.detach();
  terms.terms["geodesic"] = ((r.geodesic * mask).sum() / valid).detach();
  terms.terms["kl_weight"] = torch::full({}, w_kl);
  terms.terms["word_drop"] = torch::full({}, p_drop);
  return terms;
}

ModelTraits HvrnnImpl::traits() const {
  ModelTraits t;
  t.control = InputUse::kGenerates;
  t.labels = label_dim_ > 0;
  t.prefix = true;
  t.streaming = true;  // word by word, equal to sample(); nothing per frame comes in
  return t;
}

torch::Tensor HvrnnImpl::prefix_frames(const SampleRequest& request, int64_t b) {
  const int64_t d = context_.pose_dim, c = context_.control_dim;
  const auto& pre = request.prefix_pose;
  if (!pre.defined() || (pre.dim() == 3 && pre.size(1) == 0)) return {};
  if (pre.dim() != 3 || pre.size(0) != b || pre.size(2) != d)
    throw Error("sample request: prefix_pose must be [" + std::to_string(b) + ", P, " + std::to_string(d) + "]");
  auto opts = init_mean.options();
  const int64_t p = pre.size(1);
  auto pre_ctrl = request.prefix_control.defined() ? request.prefix_control.to(opts) : torch::zeros({b, p, c}, opts);
  if (pre_ctrl.sizes() != at::IntArrayRef({b, p, c}))
    throw Error("sample request: prefix_control must be [B, P, " + std::to_string(c) + "] matching prefix_pose");
  return torch::cat({pre.to(opts), pre_ctrl}, -1);
}

torch::Tensor HvrnnImpl::prefix_words(const SampleRequest& request, int64_t b) {
  auto frames = prefix_frames(request, b);
  const int64_t l = options_.word_length, p = frames.defined() ? frames.size(1) : 0;
  if (p < l) return {};  // no whole word to continue
  const int64_t k = p / l;  // whole words ending at the prefix's last frame
  return encode_words(frames.narrow(1, p - k * l, k * l));
}

SampleOutput HvrnnImpl::sample(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  const int64_t d = context_.pose_dim, c = context_.control_dim, l = options_.word_length;
  if (!request.control.defined() || request.control.dim() != 3)
    throw Error("sample request: control must be [B, T, " + std::to_string(c) + "] (its shape gives B and T)");
  const int64_t b = request.control.size(0), t = request.control.size(1);
  auto opts = init_mean.options();
  if (t == 0) return {torch::zeros({b, 0, d}, opts), torch::zeros({b, 0, c}, opts)};
  auto gen = at::detail::createCPUGenerator(request.seed);
  auto a = label_code(request.content, request.style, b, opts);
  auto h0 = initial_state(request.content, request.style, b, request.temperature, &gen);
  auto words = prefix_words(request, b);
  const int64_t k = words.defined() ? words.size(1) : 0, n_gen = (t + l - 1) / l;
  auto u = unroll(words, {}, k + n_gen, h0, a, request.temperature, &gen);
  auto [previous, before] = prefix_tail(request, b);
  auto x = decode_generated(u.out.narrow(1, k, n_gen), &previous, &before).narrow(1, 0, t);
  return {x.narrow(-1, 0, d).contiguous(), x.narrow(-1, d, c).contiguous()};
}

namespace {

// A word-wise stream: the cell makes a word of l frames whenever the last one is used up.
struct HvrnnStream : StreamState {
  at::Generator gen;
  std::vector<torch::Tensor> hs;
  torch::Tensor a;
  torch::Tensor frames;  // [B, l, F] the current word's frames (undefined before the first)
  torch::Tensor previous;  // [B, F + 1] the frame before the next word and a 1, or zeros
  torch::Tensor before;    // [B, F] the frame before that (boundary_blend), undefined before two
  int64_t next = 0;      // index of the next frame in `frames`
  double temperature = 1.0;
};

}  // namespace

std::unique_ptr<StreamState> HvrnnImpl::begin_stream(const SampleRequest& request) {
  torch::NoGradGuard no_grad;
  int64_t b = request.batch;
  if (request.prefix_pose.defined()) b = request.prefix_pose.size(0);
  else if (request.content.defined()) b = request.content.size(0);
  else if (request.style.defined()) b = request.style.size(0);
  if (b < 1) throw Error("hvrnn stream: no batch size (prefix, labels or request.batch)");
  auto s = std::make_unique<HvrnnStream>();
  s->gen = at::detail::createCPUGenerator(request.seed);
  s->temperature = request.temperature;
  auto opts = init_mean.options();
  s->a = label_code(request.content, request.style, b, opts);
  s->hs = initial_state(request.content, request.style, b, request.temperature, &s->gen).chunk(options_.state_layers, -1);
  auto words = prefix_words(request, b);  // the same draws, in the same order, as sample()
  for (int64_t i = 0; words.defined() && i < words.size(1); ++i)
    cell_step(s->hs, words.select(1, i), {}, s->a, s->temperature, &s->gen, nullptr);
  std::tie(s->previous, s->before) = prefix_tail(request, b);
  s->next = options_.word_length;
  return s;
}

StreamFrame HvrnnImpl::step_stream(StreamState& state, const torch::Tensor&) {
  torch::NoGradGuard no_grad;
  auto* s = dynamic_cast<HvrnnStream*>(&state);
  if (!s) throw Error("hvrnn: step_stream needs a stream from this family's begin_stream");
  if (s->next >= options_.word_length) {
    auto word = cell_step(s->hs, {}, {}, s->a, s->temperature, &s->gen, nullptr);
    s->frames = decode_generated(word.unsqueeze(1), &s->previous, &s->before);
    s->next = 0;
  }
  auto f = s->frames.select(1, s->next++);
  const int64_t d = context_.pose_dim;
  return {f.narrow(-1, 0, d).contiguous(), f.narrow(-1, d, context_.control_dim).contiguous()};
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(hvrnn, FamilyInfo{"hvrnn", FamilyKind::kMotion,
                                        "hierarchical deep latent variable model: motion words in a conditional VRNN "
                                        "(Ghorbani et al. 2020)",
                                        [](const nlohmann::json& config, const ModelContext& context) {
                                          return std::make_shared<HvrnnImpl>(HvrnnOptions::from_json(config), context);
                                        },
                                        {{"word_hidden", 12}, {"word_code", 8}, {"feature_hidden", 12},
                                         {"feature", 8}, {"latent", 4}, {"gaussian_hidden", 12},
                                         {"gaussian_layers", 1}, {"state", 12}, {"label_code", 3}},
                                        // Ghorbani et al. 2020, section 4.2: Adam at 1e-3, batch 64,
                                        // gradient norm clipped at 0.1.
                                        {{"paper", {{"batch", 64}, {"lr", 1e-3}, {"warmup", 0}, {"grad_clip", 0.1}}}}})
