// MoGlow numerics against brute force: log-determinants against autograd Jacobians (double),
// invertibility with carried LSTM state, ActNorm initialisation, learning, sampling determinism.
#include <gtest/gtest.h>
#include <ATen/CPUGeneratorImpl.h>
#include <torch/autograd.h>
#include <torch/optim/adam.h>
#include <torch/utils.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "core/error.h"
#include "nn/label_features.h"
#include "core/trajectory.h"
#include "nn/moglow/moglow.h"
#include "nn/moglow/pose_transport.h"
#include "moglow_test_util.h"
#include "nn_test_util.h"

using namespace mosyn::nn;
using mosyn::nn::testing::noisy_sinusoid_batch;
using mosyn::nn::testing::randomise;
using mosyn::nn::testing::small_context;

namespace {

// Jacobian d y / d x of y = f(x) for x [n], y [m] (double), row i = d y_i / d x.
torch::Tensor jacobian(const std::function<torch::Tensor(const torch::Tensor&)>& f, const torch::Tensor& x0) {
  auto x = x0.detach().clone().requires_grad_(true);
  auto y = f(x).reshape({-1});
  std::vector<torch::Tensor> rows;
  for (int64_t i = 0; i < y.size(0); ++i) {
    auto g = torch::autograd::grad({y[i]}, {x}, {}, /*retain_graph=*/true, false, /*allow_unused=*/true)[0];
    rows.push_back(g.defined() ? g.reshape({-1}) : torch::zeros({x.numel()}, x.options()));
  }
  return torch::stack(rows);
}

double logabsdet(const torch::Tensor& m) { return std::get<1>(torch::slogdet(m)).item<double>(); }



std::shared_ptr<MoGlowImpl> small_model(int d = 6, int k = 3, int tau = 2, int layers = 2) {
  torch::manual_seed(1);
  nlohmann::json cfg = {{"num_steps", k}, {"hidden", 16}, {"lstm_layers", layers}, {"tau", tau}, {"dropout", 0.0}};
  auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, small_context(d)));
  model->to(torch::kFloat64);
  randomise(*model);
  model->eval();
  return model;
}

}  // namespace

TEST(MoGlow, ActNormInitGivesZeroMeanUnitVariance) {
  torch::manual_seed(0);
  ActNorm an(5);
  auto x = torch::randn({7, 9, 5}) * torch::tensor({1.0, 2.0, 0.5, 3.0, 10.0}) + torch::tensor({1.0, -2.0, 3.0, 0.0, 5.0});
  EXPECT_FALSE(an->initialized());
  an->initialize(x);
  EXPECT_TRUE(an->initialized());
  auto y = an->forward(x).reshape({-1, 5});
  EXPECT_LT(y.mean(0).abs().max().item<double>(), 1e-5);
  EXPECT_LT((y.pow(2).mean(0).sqrt() - 1).abs().max().item<double>(), 1e-4);
  EXPECT_LT((an->reverse(an->forward(x)) - x).abs().max().item<double>(), 1e-4);
}

TEST(MoGlow, ModelInitialisesActNormOnFirstTrainingBatch) {
  torch::manual_seed(3);
  auto model = create_model("moglow", {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}}, small_context(4));
  auto& mg = dynamic_cast<MoGlowImpl&>(*model);
  Batch b{torch::randn({4, 8, 4}) * 3 + 1, torch::randn({4, 8, 3}), {}, {}};
  model->train();
  model->loss(b);
  EXPECT_TRUE(mg.steps[0]->actnorm->initialized());
  EXPECT_TRUE(mg.steps[1]->actnorm->initialized());
  // The first ActNorm saw the predicted frames of the batch.
  auto y = mg.steps[0]->actnorm->forward(b.pose.narrow(1, 2, 6)).reshape({-1, 4});
  EXPECT_LT(y.mean(0).abs().max().item<double>(), 1e-5);
  EXPECT_LT((y.pow(2).mean(0).sqrt() - 1).abs().max().item<double>(), 1e-4);
}

TEST(MoGlow, ActNormLogdetMatchesJacobian) {
  torch::manual_seed(0);
  ActNorm an(6);
  an->to(torch::kFloat64);
  {
    torch::NoGradGuard g;
    an->bias.normal_();
    an->logs.normal_();
  }
  auto x = torch::randn({6}, torch::kFloat64);
  auto j = jacobian([&](const torch::Tensor& v) { return an->forward(v); }, x);
  EXPECT_NEAR(an->logdet().item<double>(), logabsdet(j), 1e-9);
}

TEST(MoGlow, InvLinearIsPLUAndLogdetMatchesJacobian) {
  torch::manual_seed(0);
  InvLinear lin(6);
  lin->to(torch::kFloat64);
  // Initial W is orthogonal.
  auto w0 = lin->weight();
  EXPECT_LT((w0.matmul(w0.t()) - torch::eye(6, torch::kFloat64)).abs().max().item<double>(), 1e-6);
  {
    torch::NoGradGuard g;
    lin->lower.normal_(0, 0.5);
    lin->upper.normal_(0, 0.5);
    lin->log_s.normal_(0, 0.5);
  }
  auto x = torch::randn({6}, torch::kFloat64);
  auto j = jacobian([&](const torch::Tensor& v) { return lin->forward(v); }, x);
  EXPECT_NEAR(lin->logdet().item<double>(), logabsdet(j), 1e-9);
  EXPECT_NEAR(lin->logdet().item<double>(), logabsdet(lin->weight()), 1e-9);
  auto winv = torch::inverse(lin->weight());
  EXPECT_LT((lin->reverse(lin->forward(x), winv) - x).abs().max().item<double>(), 1e-10);
}

TEST(MoGlow, CouplingLogdetMatchesJacobian) {
  torch::manual_seed(0);
  Coupling cp(7, 5, 12, 2, 0.05);
  cp->to(torch::kFloat64);
  {
    torch::NoGradGuard g;
    cp->out->weight.normal_(0, 0.5);
    cp->out->bias.normal_(0, 0.5);
  }
  auto cond = torch::randn({1, 1, 5}, torch::kFloat64);
  auto h0 = torch::randn({2, 1, 12}, torch::kFloat64), c0 = torch::randn({2, 1, 12}, torch::kFloat64);
  auto x = torch::randn({7}, torch::kFloat64);
  auto f = [&](const torch::Tensor& v) {
    c10::optional<LstmState> st = LstmState{h0, c0};
    return std::get<0>(cp->forward(v.reshape({1, 1, 7}), cond, st));
  };
  c10::optional<LstmState> st = LstmState{h0, c0};
  auto logdet = std::get<1>(cp->forward(x.reshape({1, 1, 7}), cond, st)).item<double>();
  EXPECT_NEAR(logdet, logabsdet(jacobian(f, x)), 1e-9);
  // Inverse with the same state.
  c10::optional<LstmState> s1 = LstmState{h0, c0}, s2 = LstmState{h0, c0};
  auto z = std::get<0>(cp->forward(x.reshape({1, 1, 7}), cond, s1));
  EXPECT_LT((cp->reverse(z, cond, s2).reshape({7}) - x).abs().max().item<double>(), 1e-10);
}

TEST(MoGlow, FlowLogdetMatchesJacobianPerFrame) {
  auto model = small_model(6, 3, 2);
  const int64_t b = 2, t = 6, tau = 2;
  torch::manual_seed(5);
  auto pose = torch::randn({b, t, 6}, torch::kFloat64), control = torch::randn({b, t, 3}, torch::kFloat64);
  auto enc = model->encode(pose, control);
  // Every predicted frame f (and batch element): d z_f / d x_f with all other frames fixed.
  for (int64_t bi = 0; bi < b; ++bi) {
    for (int64_t f = 0; f < t - tau; ++f) {
      auto fn = [&](const torch::Tensor& v) {
        auto p = pose.clone();
        p.select(0, bi).select(0, tau + f).copy_(v);
        return model->encode(p, control).z.select(0, bi).select(0, f);
      };
      double brute = logabsdet(jacobian(fn, pose.select(0, bi).select(0, tau + f)));
      EXPECT_NEAR(enc.logdet[bi][f].item<double>(), brute, 1e-8) << "batch " << bi << " frame " << f;
    }
  }
}

TEST(MoGlow, FlowIsInvertibleFrameByFrameWithCarriedState) {
  auto model = small_model(6, 4, 3, 1);
  model->to(torch::kFloat32);
  const int64_t b = 3, t = 15, tau = 3;
  torch::manual_seed(6);
  auto pose = torch::randn({b, t, 6}), control = torch::randn({b, t, 3});
  auto enc = model->encode(pose, control);
  auto cond = model->conditioning(pose, control);
  std::vector<c10::optional<LstmState>> states(model->steps.size());
  std::vector<torch::Tensor> winv;
  for (auto& s : model->steps) winv.push_back(torch::inverse(s->linear->weight()));
  torch::NoGradGuard g;
  for (int64_t f = 0; f < t - tau; ++f) {
    auto x = enc.z.select(1, f).unsqueeze(0);
    for (int64_t k = static_cast<int64_t>(model->steps.size()) - 1; k >= 0; --k)
      x = model->steps[k]->reverse(x, cond.narrow(0, f, 1), states[k], winv[k]);
    EXPECT_LT((x.squeeze(0) - pose.select(1, tau + f)).abs().max().item<double>(), 1e-4) << "frame " << f;
  }
}

TEST(MoGlow, LogLikelihoodIncludesGaussianConstant) {
  // With identity-like flow (fresh model, eval, no ActNorm init) z = transformed x; check the
  // reported NLL equals -log N(z) - logdet by direct formula.
  auto model = small_model(4, 2, 1, 1);
  torch::manual_seed(2);
  auto pose = torch::randn({2, 5, 4}, torch::kFloat64), control = torch::randn({2, 5, 3}, torch::kFloat64);
  auto e = model->encode(pose, control);
  auto ll = model->log_likelihood(pose, control);
  auto expect = -0.5 * e.z.pow(2).sum(-1) - 2.0 * std::log(2 * M_PI) + e.logdet;
  EXPECT_LT((ll - expect).abs().max().item<double>(), 1e-10);
  Batch batch{pose, control, {}, {}};
  auto terms = model->loss(batch);
  EXPECT_NEAR(terms.terms.at("nll_frame").item<double>(), -ll.mean().item<double>(), 1e-10);
  EXPECT_NEAR(terms.terms.at("nll_dim").item<double>(), -ll.mean().item<double>() / 4, 1e-10);
}

// A clip shorter than the training window comes padded (its last frame repeated) with its length
// in Batch::frames: the loss is the mean over every row's valid predicted frames, each scored as
// in the unpadded clip (the flow is causal).
TEST(MoGlow, ShortClipsPaddedToTheWindowScoreAsThemselves) {
  auto model = small_model(4, 2, 2, 1);
  EXPECT_EQ(model->short_window_min_frames(), 3);  // tau + 1
  torch::manual_seed(3);
  auto pose = torch::randn({3, 12, 4}, torch::kFloat64), control = torch::randn({3, 12, 3}, torch::kFloat64);
  const std::vector<int64_t> frames = {7, 12, 9};
  std::vector<torch::Tensor> valid_ll;
  Batch padded{pose.clone(), control.clone(), {}, {}};
  for (int r = 0; r < 3; ++r) {
    const int64_t n = frames[r];
    valid_ll.push_back(model->log_likelihood(pose.narrow(0, r, 1).narrow(1, 0, n), control.narrow(0, r, 1).narrow(1, 0, n))
                           .reshape({-1}));
    for (int64_t t = n; t < 12; ++t) {  // padding as the trainer makes it: the last frame repeated
      padded.pose[r][t] = pose[r][n - 1];
      padded.control[r][t] = control[r][n - 1];
    }
  }
  padded.frames = torch::tensor(frames, torch::kInt64);
  const double expected = -torch::cat(valid_ll).mean().item<double>();
  EXPECT_NEAR(model->loss(padded).terms.at("nll_frame").item<double>(), expected, 1e-9);
  // Full-length rows score as without Batch::frames.
  Batch full{pose, control, {}, {}};
  const double unmasked = model->loss(full).terms.at("nll_frame").item<double>();
  full.frames = torch::full({3}, 12, torch::kInt64);
  EXPECT_NEAR(model->loss(full).terms.at("nll_frame").item<double>(), unmasked, 1e-9);
  auto off = MoGlowOptions::from_json({{"short_clips", false}}, small_context(4));
  EXPECT_FALSE(off.short_clips);
}

TEST(MoGlow, NllFallsOnNoisySinusoids) {
  torch::manual_seed(11);
  const int64_t b = 16, t = 24, d = 4;
  nlohmann::json cfg = {{"num_steps", 2}, {"hidden", 32}, {"tau", 3}, {"dropout", 0.0}};
  auto model = create_model("moglow", cfg, small_context(d));
  torch::optim::Adam opt(model->parameters(), torch::optim::AdamOptions(3e-3));
  auto make_batch = [&]() { return noisy_sinusoid_batch(b, t, d); };
  model->train();
  double first = 0, last = 0;
  for (int step = 0; step < 200; ++step) {
    auto terms = model->loss(make_batch());
    opt.zero_grad();
    terms.loss().backward();
    opt.step();
    double v = terms.terms.at("nll_dim").item<double>();
    if (step < 10) first += v / 10;
    if (step >= 190) last += v / 10;
  }
  // Noise std 0.05 allows ~-1.5 nats/dim; a Gaussian fit of the marginal gives ~+0.7.
  EXPECT_LT(last, first - 1.0) << "first " << first << " last " << last;
  EXPECT_LT(last, 0.0);
}

TEST(MoGlow, SamplingIsDeterministicPerSeedAndStreamsMatch) {
  auto model = small_model(6, 3, 2, 1);
  model->to(torch::kFloat32);
  torch::manual_seed(8);
  SampleRequest req;
  req.control = torch::randn({3, 12, 3});
  req.prefix_pose = torch::randn({3, 5, 6});
  req.prefix_control = torch::randn({3, 5, 3});
  req.seed = 42;
  auto a = model->sample(req).pose;
  auto b = model->sample(req).pose;
  ASSERT_EQ(a.sizes(), (std::vector<int64_t>{3, 12, 6}));
  EXPECT_TRUE(torch::equal(a, b));
  EXPECT_TRUE(torch::isfinite(a).all().item<bool>());
  req.seed = 43;
  auto c = model->sample(req).pose;
  EXPECT_GT((a - c).abs().max().item<double>(), 1e-3);
  // Frame-by-frame streaming gives the same frames as sample().
  req.seed = 42;
  auto stream = model->begin_stream(req);
  for (int64_t t = 0; t < 12; ++t) {
    auto x = model->step_stream(*stream, req.control.select(1, t)).pose;
    EXPECT_TRUE(torch::allclose(x, a.select(1, t), 1e-5, 1e-6)) << "frame " << t;
  }
  // Temperature 0 is deterministic regardless of seed.
  req.temperature = 0.0;
  req.seed = 1;
  auto d0 = model->sample(req).pose;
  req.seed = 2;
  EXPECT_TRUE(torch::allclose(d0, model->sample(req).pose));
}

// Look-ahead: the mean control over the next k frames (the last frame repeating past the end),
// by hand; it joins the conditioning; offline it reads the real path ahead, and a stream given the
// same path ahead (step_stream_ahead) makes the same frames.
TEST(MoGlow, LookaheadFeaturesByHandAndStreamedWithThePathAhead) {
  torch::manual_seed(1);
  nlohmann::json cfg = {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"dropout", 0.0}, {"lookahead", {1, 3}}};
  auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, small_context(6)));
  model->to(torch::kFloat64);
  randomise(*model);
  model->eval();
  EXPECT_EQ(model->cond_dim(), 2 * 6 + 3 * 3 + 2 * 3);
  auto control = torch::randn({2, 7, 3}, torch::kFloat64);
  auto f = model->lookahead_features(control);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{2, 7, 6}));
  auto at = [&](int64_t b, int64_t t) { return control[b][std::min<int64_t>(t, 6)]; };
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t t = 0; t < 7; ++t) {
      EXPECT_TRUE(torch::allclose(f[b][t].narrow(0, 0, 3), at(b, t + 1)));
      EXPECT_TRUE(torch::allclose(f[b][t].narrow(0, 3, 3), (at(b, t + 1) + at(b, t + 2) + at(b, t + 3)) / 3.0));
    }
  auto pose = torch::randn({2, 7, 6}, torch::kFloat64);
  auto cond = model->conditioning(pose, control);
  EXPECT_TRUE(torch::allclose(cond.narrow(2, 2 * 6 + 3 * 3, 6), f.narrow(1, 2, 5).transpose(0, 1)));
  // A window cut from the longer control, with the frames after it (Batch::control_after), looks
  // ahead as the whole control does; with fewer after it than the longest offset, the last repeats.
  EXPECT_EQ(model->control_frames_after(), 3);
  EXPECT_TRUE(torch::allclose(model->lookahead_features(control.narrow(1, 0, 4), control.narrow(1, 4, 3)),
                              f.narrow(1, 0, 4)));
  EXPECT_TRUE(torch::allclose(model->lookahead_features(control.narrow(1, 0, 4), control.narrow(1, 4, 1)),
                              model->lookahead_features(control.narrow(1, 0, 5)).narrow(1, 0, 4)));
  EXPECT_TRUE(torch::allclose(model->conditioning(pose.narrow(1, 0, 4), control.narrow(1, 0, 4), {}, control.narrow(1, 4, 3)),
                              cond.narrow(0, 0, 2)));
  EXPECT_THROW(model->lookahead_features(control, torch::zeros({2, 3, 2}, torch::kFloat64)), mosyn::Error);
  EXPECT_TRUE(model->traits().streaming);
  EXPECT_EQ(model->traits().control_ahead_frames, 3);
  SampleRequest req;
  req.control = control;
  req.seed = 3;
  auto a = model->sample(req).pose;
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{2, 7, 6}));
  EXPECT_TRUE(torch::equal(a, model->sample(req).pose));
  // The path ahead matters: another future gives another present.
  auto other = control.clone();
  other.narrow(1, 3, 4).add_(1.0);
  req.control = other;
  EXPECT_FALSE(torch::allclose(a.select(1, 0), model->sample(req).pose.select(1, 0)));
  req.control = control;
  auto stream = model->begin_stream(req);
  std::vector<torch::Tensor> frames;
  for (int64_t t = 0; t < 7; ++t) {
    const auto ahead = control.narrow(1, t + 1, std::min<int64_t>(3, 6 - t));  // none after the last frame
    frames.push_back(model->step_stream_ahead(*stream, control.select(1, t), ahead).pose);
  }
  EXPECT_TRUE(torch::allclose(torch::stack(frames, 1), a));
}

// predicted_lookahead: the features are the means of a critically damped spring's path, stepped
// here frame by frame (exact discretisation) from the control and its change, its input the control
// one filter delay later.
TEST(MoGlow, PredictedLookaheadIsTheSpringsPathByBruteForce) {
  torch::manual_seed(2);
  nlohmann::json cfg = {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"dropout", 0.0}, {"lookahead", {2, 5}},
                        {"predicted_lookahead", 1.0}, {"prediction_smoothing_s", 0.2}};
  const auto ctx = small_context(6);
  auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, ctx));
  model->to(torch::kFloat64);
  const double w = 1.31 / (0.2 * ctx.fps);
  const int64_t delay = std::max<int64_t>(1, std::lround(2.0 / w));
  EXPECT_EQ(model->prediction_delay_frames(), delay);
  EXPECT_EQ(model->control_frames_after(), std::max<int64_t>(5, delay));
  const int64_t t_len = 9;
  auto control = torch::randn({2, t_len, 3}, torch::kFloat64);
  const auto f = model->predicted_lookahead_features(control);
  ASSERT_EQ(f.sizes(), (std::vector<int64_t>{2, t_len, 6}));
  for (int64_t b = 0; b < 2; ++b)
    for (int64_t t = 0; t < t_len; ++t)
      for (int64_t ch = 0; ch < 3; ++ch) {
        const double u = control[b][std::min(t + delay, t_len - 1)][ch].item<double>();
        double x = control[b][t][ch].item<double>();
        double v = t > 0 ? x - control[b][t - 1][ch].item<double>() : 0.0;
        double sum = 0, mean2 = 0;
        for (int k = 1; k <= 5; ++k) {
          const double x0 = x - u, e = std::exp(-w);
          x = u + (x0 + (v + w * x0)) * e;
          v = (v - w * (v + w * x0)) * e;
          sum += x;
          if (k == 2) mean2 = sum / 2;
        }
        EXPECT_NEAR(f[b][t][ch].item<double>(), mean2, 1e-9);
        EXPECT_NEAR(f[b][t][3 + ch].item<double>(), sum / 5, 1e-9);
      }
  // Training reads them; without look-ahead the option is refused.
  auto pose = torch::randn({2, t_len, 6}, torch::kFloat64);
  EXPECT_TRUE(torch::allclose(model->conditioning(pose, control).narrow(2, 2 * 6 + 3 * 3, 6),
                              f.narrow(1, 2, t_len - 2).transpose(0, 1)));
  EXPECT_THROW(create_model("moglow", {{"predicted_lookahead", 0.5}}, ctx), mosyn::Error);
}

TEST(MoGlow, ConfigPresetsAndErrors) {
  auto ctx = small_context(6);
  ctx.pose_form = mosyn::data::PoseForm::kPositions;
  auto o = MoGlowOptions::from_json({{"preset", "paper"}}, ctx);
  EXPECT_EQ(o.num_steps, 16);
  EXPECT_EQ(o.hidden, 512);
  EXPECT_EQ(o.lstm_layers, 2);
  EXPECT_EQ(o.tau, 10);
  EXPECT_DOUBLE_EQ(o.dropout, 0.95);
  ctx.pose_form = mosyn::data::PoseForm::kRotations;
  EXPECT_DOUBLE_EQ(MoGlowOptions::from_json(nlohmann::json::object(), ctx).dropout, 0.6);
  EXPECT_THROW(MoGlowOptions::from_json({{"nonsense", 1}}, ctx), mosyn::Error);
  EXPECT_THROW(MoGlowOptions::from_json({{"preset", "huge"}}, ctx), mosyn::Error);
  EXPECT_THROW(create_model("nosuchfamily", {}, ctx), mosyn::Error);
  auto m = create_model("moglow", {{"num_steps", 2}, {"hidden", 8}}, ctx);
  EXPECT_EQ(m->family(), "moglow");
  EXPECT_EQ(m->config().at("num_steps"), 2);
  auto m2 = create_model("moglow", m->config(), ctx);
  EXPECT_EQ(m2->config(), m->config());
  // The lead-in: the paper's 1 s unless the run records its own, which becomes the family's
  // default warm-up for sample and eval; written only when set, so older configs stay as they were.
  EXPECT_EQ(m->traits().default_warmup_s, 1.0);
  EXPECT_FALSE(m->config().contains("lead_in_s"));
  auto longer = create_model("moglow", {{"num_steps", 2}, {"hidden", 8}, {"lead_in_s", 3.0}}, ctx);
  EXPECT_EQ(longer->traits().default_warmup_s, 3.0);
  EXPECT_EQ(longer->config().at("lead_in_s"), 3.0);
  EXPECT_EQ(create_model("moglow", longer->config(), ctx)->traits().default_warmup_s, 3.0);
  EXPECT_EQ(create_model("moglow", {{"num_steps", 2}, {"hidden", 8}, {"lead_in_s", 0.0}}, ctx)->traits().default_warmup_s, 0.0);
  EXPECT_THROW(MoGlowOptions::from_json({{"lead_in_s", -1.0}}, ctx), mosyn::Error);
  EXPECT_THROW(MoGlowOptions::from_json({{"lead_in_s", 61.0}}, ctx), mosyn::Error);
}

// The inference stream (moglow_stream.h: fused weights, per-character generators) against the
// reference flow: running the generated frames, after a prefix that warms the LSTMs up, through
// the normalising direction (encode) recovers exactly the noise each character drew from its own
// generator, times the temperature (two LSTM layers, labels, double precision).
// Also for the residual parameterisation: the stream adds the transported previous frame that
// encode() subtracts, with features standardised by non-trivial statistics.
TEST(MoGlow, StreamInvertsTheReferenceFlowWithPerCharacterNoise) {
  for (bool residual : {false, true}) {
    SCOPED_TRACE(residual ? "residual" : "plain");
    torch::manual_seed(1);
    nlohmann::json cfg = {{"num_steps", 3}, {"hidden", 16}, {"lstm_layers", 2}, {"tau", 2}, {"dropout", 0.0},
                          {"labels", true}, {"residual", residual}};
    auto ctx = small_context(6);
    ctx.num_content = 2;
    ctx.num_style = 3;
    ctx.pose_form = mosyn::data::PoseForm::kPositions;
    ctx.stats.pose_mean = {0.1f, 0.9f, -0.2f, 0.05f, 0.4f, 0.3f};
    ctx.stats.pose_std = {0.3f, 0.1f, 0.25f, 0.2f, 0.3f, 0.15f};
    ctx.stats.control_mean = {0.01f, 0.06f, 0.0f};
    ctx.stats.control_std = {0.02f, 0.03f, 0.05f};
    auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, ctx));
    EXPECT_EQ(model->transport() != nullptr, residual);
    model->to(torch::kFloat64);
    randomise(*model);
    model->eval();
    const int64_t b = 3, p = 5, t = 7, d = 6;
    SampleRequest req;
    req.prefix_pose = torch::randn({b, p, d}, torch::kFloat64);
    req.prefix_control = torch::randn({b, p, 3}, torch::kFloat64);
    req.content = torch::tensor({0, -1, 1}, torch::kInt64);
    req.style = torch::tensor({2, 0, -1}, torch::kInt64);
    req.seed = 11;
    req.seeds = {11, 5, 900};
    req.temperature = 0.8;
    auto control = torch::randn({b, t, 3}, torch::kFloat64);
    auto stream = model->begin_stream(req);
    std::vector<torch::Tensor> frames;
    for (int64_t f = 0; f < t; ++f) frames.push_back(model->step_stream(*stream, control.select(1, f)).pose);
    auto pose = torch::cat({req.prefix_pose, torch::stack(frames, 1)}, 1);
    auto ctrl = torch::cat({req.prefix_control, control}, 1);
    auto labels = label_features(req.content, req.style, b, 2, 3, pose.options());
    auto z = model->encode(pose, ctrl, {}, nullptr, false, labels).z.narrow(1, p - 2, t);  // frames p..p+t-1
    for (int64_t k = 0; k < b; ++k) {
      auto g = at::detail::createCPUGenerator(req.seeds[k]);
      for (int64_t f = 0; f < t; ++f) {
        auto noise = torch::randn({d}, g, torch::kFloat64) * req.temperature;
        EXPECT_TRUE(torch::allclose(z[k][f], noise, 1e-9, 1e-9)) << "row " << k << " frame " << f << "\n"
                                                                  << z[k][f] << "\n" << noise;
      }
    }
  }
}

// history_noise perturbs what the model conditions on, never the frames it scores: an offset on
// the last frame alone (scored, never conditioned on) changes nothing, one on earlier frames does.
TEST(MoGlow, HistoryOffsetReachesOnlyTheConditioning) {
  for (bool residual : {false, true}) {
    SCOPED_TRACE(residual ? "residual" : "plain");
    torch::manual_seed(1);
    auto ctx = small_context(6);
    ctx.pose_form = mosyn::data::PoseForm::kPositions;
    nlohmann::json cfg = {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"dropout", 0.0}, {"residual", residual},
                          {"history_noise", 0.1}};
    auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, ctx));
    model->to(torch::kFloat64);
    randomise(*model);
    model->eval();
    auto pose = torch::randn({2, 6, 6}, torch::kFloat64), control = torch::randn({2, 6, 3}, torch::kFloat64);
    const auto z = model->encode(pose, control).z;
    auto last = torch::zeros_like(pose);
    last.narrow(1, 5, 1).normal_();
    EXPECT_TRUE(torch::allclose(model->encode(pose, control, {}, nullptr, false, {}, last).z, z, 0, 0));
    auto earlier = torch::zeros_like(pose);
    earlier.narrow(1, 3, 1).normal_();
    const auto moved = model->encode(pose, control, {}, nullptr, false, {}, earlier).z;
    EXPECT_TRUE(torch::allclose(moved.narrow(1, 0, 2), z.narrow(1, 0, 2), 0, 0));  // frames 2, 3: before it
    EXPECT_FALSE(torch::allclose(moved.narrow(1, 2, 2), z.narrow(1, 2, 2)));       // frames 4, 5 saw it
    // Evaluation mode draws no noise: the loss is deterministic.
    Batch batch{pose, control, {}, {}};
    EXPECT_EQ(model->loss(batch).loss().item<double>(), model->loss(batch).loss().item<double>());
  }
}

// A point fixed in the world, seen from a root path that steps and turns, is where the transport
// carries it (by hand through core/trajectory's integration), in standardised features; and the
// residual needs joint positions.
TEST(MoGlow, PoseTransportKeepsWorldFixedPointsInPlace) {
  mosyn::Skeleton skeleton;  // no joints: Y up
  ModelContext ctx = small_context(6);
  ctx.pose_form = mosyn::data::PoseForm::kPositions;
  ctx.stats.pose_mean = {0.1f, 0.9f, -0.2f, 0.05f, 0.4f, 0.3f};
  ctx.stats.pose_std = {0.3f, 0.1f, 0.25f, 0.2f, 0.3f, 0.15f};
  ctx.stats.control_mean = {0.01f, 0.06f, 0.0f};
  ctx.stats.control_std = {0.02f, 0.03f, 0.05f};
  const PoseTransport transport(ctx);
  const std::vector<Eigen::Vector3d> world = {{1.0, 0.05, 2.0}, {-0.4, 1.2, 0.7}};  // metres
  const double heading0 = 0.6;
  mosyn::RootDelta step;
  step.sideways = 0.03;
  step.forward = 0.11;
  step.turn_rad = -0.2;
  skeleton.meters_per_unit = 1.0;
  const auto ground = mosyn::integrate_root_deltas(skeleton, {mosyn::RootDelta{}, step}, {0.5, 0.0, -0.3}, heading0);
  auto features = [&](int t) {  // the world points in frame t's root frame, standardised
    std::vector<double> f;
    const Eigen::Quaterniond h = mosyn::heading_rotation(skeleton, ground.headings_rad[t]);
    for (const auto& w : world) {
      const Eigen::Vector3d local = h.conjugate() * (w - ground.positions[t]);
      for (int k = 0; k < 3; ++k) f.push_back((local[k] - ctx.stats.pose_mean[f.size()]) / ctx.stats.pose_std[f.size()]);
    }
    return torch::tensor(f, torch::kFloat64);
  };
  const auto& cs = ctx.stats;
  const auto control = torch::tensor({(step.sideways - cs.control_mean[0]) / cs.control_std[0],
                                      (step.forward - cs.control_mean[1]) / cs.control_std[1],
                                      (step.turn_rad - cs.control_mean[2]) / cs.control_std[2]},
                                     torch::kFloat64);
  const auto moved = transport.apply(features(0).unsqueeze(0), control.unsqueeze(0)).squeeze(0);
  EXPECT_TRUE(torch::allclose(moved, features(1), 1e-9, 1e-9)) << moved << "\n" << features(1);
  EXPECT_THROW(PoseTransport(small_context(6)), mosyn::Error);  // rotations form
}

// The teacher-forced generating direction over a window inverts encode() (residual form, double);
// the planted-heel term (foot_contact_weight) is, by hand, the mean horizontal length of the heels'
// residuals (metres here) times the frame rate, for frames drawn from the flow; it is reported in
// every loss and added only in training, so the validation loss stays the likelihood.
TEST(MoGlow, FootContactTermIsTheDrawnHeelResidualSpeed) {
  const mosyn::Skeleton s = mosyn::make_synthetic_biped();
  const ModelContext ctx = mosyn::nn::testing::positions_context(s);
  const Batch batch = mosyn::nn::testing::standing_batch(s, ctx, 12);
  Batch batch64{batch.pose.to(torch::kFloat64), batch.control.to(torch::kFloat64), {}, {}};
  torch::manual_seed(1);
  nlohmann::json cfg = {{"num_steps", 3}, {"hidden", 16}, {"tau", 2}, {"dropout", 0.0}, {"residual", true},
                        {"foot_contact_weight", 2.0}};
  auto model = std::dynamic_pointer_cast<MoGlowImpl>(create_model("moglow", cfg, ctx));
  model->to(torch::kFloat64);
  randomise(*model);
  const int64_t tau = 2, n = 10;
  const auto prev = batch64.pose.narrow(1, tau - 1, n), control = batch64.control.narrow(1, tau, n);
  const auto residual = batch64.pose.narrow(1, tau, n) - model->transport()->apply(prev, control);
  const auto e = model->encode(batch64.pose, batch64.control);
  const auto back = model->reverse_window(e.z.transpose(0, 1), e.cond).transpose(0, 1);
  EXPECT_TRUE(torch::allclose(back, residual, 1e-9, 1e-9));

  auto loss_in = [&](bool training) {
    model->train(training);
    torch::manual_seed(4);  // the same latent draw in both modes
    return model->loss(batch64);
  };
  const LossTerms eval_terms = loss_in(false), train_terms = loss_in(true);
  const double planted = eval_terms.terms.at("planted_heel_mps").item<double>();
  EXPECT_NEAR(train_terms.terms.at("planted_heel_mps").item<double>(), planted, 1e-9);
  EXPECT_NEAR(train_terms.loss().item<double>(), eval_terms.loss().item<double>() + 2.0 * planted, 1e-9);
  // By hand: the same draw through the flow, the heels' sideways (x) and forward (z) residuals.
  model->eval();
  torch::manual_seed(4);
  const auto z = torch::randn(e.z.sizes(), torch::kFloat64);
  const auto drawn = model->reverse_window(z.transpose(0, 1), e.cond).transpose(0, 1);
  double sum = 0;
  for (int heel : {s.find("Foot_L"), s.find("Foot_R")})
    for (int64_t t = 0; t < n; ++t)
      sum += std::hypot(drawn[0][t][3 * heel].item<double>(), drawn[0][t][3 * heel + 2].item<double>()) * ctx.fps;
  EXPECT_NEAR(planted, sum / (2 * n), 1e-6);
  EXPECT_GT(planted, 0.0);
  // The term needs joint positions with the skeleton.
  auto bare = small_context(6);
  bare.pose_form = mosyn::data::PoseForm::kPositions;
  EXPECT_THROW(create_model("moglow", cfg, bare), mosyn::Error);
}
