// The hierarchical deep latent variable model (src/nn/hvrnn): Eq. 23 weights, the geodesic,
// validity and KL terms against hand-computed values, shapes and masking for T not a multiple of
// the word length, training on synthetic data, seeds, labels, prefixes and the ablation presets.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>

#include "core/error.h"
#include "nn/hvrnn/hvrnn.h"
#include "nn/kinematics.h"
#include "foot_test_util.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

const nlohmann::json kTiny = {{"word_hidden", 12}, {"word_code", 8}, {"feature_hidden", 12}, {"feature", 8},
                              {"latent", 4},       {"gaussian_hidden", 12}, {"gaussian_layers", 1},
                              {"state", 12},       {"label_code", 3}};

nlohmann::json tiny(nlohmann::json extra = nlohmann::json::object()) {
  nlohmann::json j = kTiny;
  for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  return j;
}

// A three-joint chain (0 -> 1 -> 2, bones 1 m and 2 m) plus a 0.5 m leaf on joint 1, in the
// rotations form with identity statistics (standardised = raw).
ModelContext rotations_context(int root_joint = 0) {
  ModelContext c;
  c.pose_form = data::PoseForm::kRotations;
  c.skeleton.joint_names = {"a", "b", "c", "d"};
  c.skeleton.parents = {-1, 0, 1, 1};
  c.skeleton.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0, 2, 0),
                        Eigen::Vector3d(0.5, 0, 0)};
  c.pose_dim = 1 + 6 * 4;
  c.control_dim = 3;
  c.num_content = 2;
  c.num_style = 2;
  c.layout.form = data::PoseForm::kRotations;
  c.layout.root_joint = root_joint;
  c.layout.pose_dim = c.pose_dim;
  c.stats.pose_mean.assign(c.pose_dim, 0.0f);
  c.stats.pose_std.assign(c.pose_dim, 1.0f);
  c.stats.control_mean.assign(3, 0.0f);
  c.stats.control_std.assign(3, 1.0f);
  return c;
}

ModelContext labelled_small_context() {
  ModelContext c = nn::testing::small_context(6, 3);
  c.num_content = 3;
  c.num_style = 2;
  c.pose_form = data::PoseForm::kPositions;
  return c;
}

torch::Tensor rot_z(double angle) {
  return torch::tensor({std::cos(angle), -std::sin(angle), 0.0, std::sin(angle), std::cos(angle), 0.0, 0.0, 0.0, 1.0},
                       torch::kFloat64)
      .reshape({3, 3});
}

SampleRequest request(int64_t b, int64_t t, std::uint64_t seed) {
  SampleRequest r;
  r.control = torch::zeros({b, t, 3});
  r.seed = seed;
  return r;
}

// Rotation features of a random smooth motion in the rotations context: valid 6D per joint.
Batch rotation_batch(int64_t b, int64_t t) {
  auto angle = torch::linspace(0, 1, t).reshape({1, t, 1}) * torch::rand({b, 1, 4}) * 2.0;  // [B, T, J]
  auto zero = torch::zeros_like(angle), one = torch::ones_like(angle);
  auto r6 = torch::stack({angle.cos(), angle.sin(), zero, -angle.sin(), angle.cos(), zero}, -1);  // [B, T, J, 6]
  auto pose = torch::cat({torch::ones({b, t, 1}), r6.reshape({b, t, 24})}, -1);
  return Batch{pose, 0.1 * torch::randn({b, t, 3}), torch::tensor({0, 1, -1, 1}).narrow(0, 0, b),
               torch::tensor({1, 0, 1, -1}).narrow(0, 0, b)};
}

TEST(HvrnnAlpha, FollowsEq23WithAFloorAndMeanOne) {
  // alpha_3 = alpha_2 = 0 (leaves), alpha_1 = max(0 + 2, 0 + 0.5) = 2, alpha_0 = 2 + 1 = 3;
  // floor 0.1 x 3 = 0.3 for the leaves; mean of (3, 2, 0.3, 0.3) = 1.4.
  const auto a = hvrnn::hierarchical_alphas({-1, 0, 1, 1}, {0.0, 1.0, 2.0, 0.5}, 0.1);
  ASSERT_EQ(a.size(), 4u);
  const double m = 5.6 / 4;
  EXPECT_NEAR(a[0], 3 / m, 1e-12);
  EXPECT_NEAR(a[1], 2 / m, 1e-12);
  EXPECT_NEAR(a[2], 0.3 / m, 1e-12);
  EXPECT_NEAR(a[3], 0.3 / m, 1e-12);
  EXPECT_EQ(hvrnn::hierarchical_alphas({-1}, {0.0}, 0.1), std::vector<double>{1.0});
}

TEST(HvrnnAlpha, GeometryPutsTheRootJointFirstAndNlIsUniform) {
  const auto g = hvrnn::geometry_for(rotations_context(1), HvrnnOptions{});
  ASSERT_TRUE(g.valid);
  EXPECT_EQ(g.slot_joint, (std::vector<int>{1, 0, 2, 3}));
  const double m = 5.6 / 4;
  EXPECT_NEAR(g.alpha[0], 2 / m, 1e-12);
  EXPECT_NEAR(g.alpha[1], 3 / m, 1e-12);
  HvrnnOptions nl = HvrnnOptions::from_json({{"preset", "NL"}});
  EXPECT_EQ(hvrnn::geometry_for(rotations_context(), nl).alpha, std::vector<double>(4, 1.0));
  EXPECT_FALSE(hvrnn::geometry_for(labelled_small_context(), HvrnnOptions{}).valid) << "positions form";
}

TEST(HvrnnLoss, WeightedGeodesicByHand) {
  // Joint 0 rotated 0.5 rad about z, joint 1 by 1.0 rad, against identity: 2 x 0.5 + 0.5 x 1.0.
  auto id = rot6d_from_matrix(torch::eye(3, torch::kFloat64));
  auto a = torch::stack({rot6d_from_matrix(rot_z(0.5)), rot6d_from_matrix(rot_z(1.0))});
  auto b = torch::stack({id, id});
  auto alpha = torch::tensor({2.0, 0.5}, torch::kFloat64);
  EXPECT_NEAR(hvrnn::weighted_geodesic(a, b, alpha).item<double>(), 1.5, 1e-6);
  // Not normalised 6D: the Gram-Schmidt of (2, 0, 0, 1, 1, 0) is identity's.
  auto scaled = torch::tensor({2.0, 0.0, 0.0, 1.0, 1.0, 0.0}, torch::kFloat64).reshape({1, 6});
  EXPECT_NEAR(hvrnn::weighted_geodesic(scaled, id.reshape({1, 6}), alpha.narrow(0, 0, 1)).item<double>(), 0.0, 1e-3);
}

TEST(HvrnnLoss, ValidityIsTheOrthonormalityResidual) {
  // (2,0,0 | 0,1,0): |c0|^2 - 1 = 3 -> 9. (1,0,0 | 1,1,0): |c1|^2 - 1 = 1, c0.c1 = 1 -> 1 + 2.
  auto r = torch::tensor({{2.0, 0.0, 0.0, 0.0, 1.0, 0.0}, {1.0, 0.0, 0.0, 1.0, 1.0, 0.0}}, torch::kFloat64);
  EXPECT_NEAR(hvrnn::rot6d_validity(r).item<double>(), 12.0, 1e-12);
  EXPECT_NEAR(hvrnn::rot6d_validity(rot6d_from_matrix(rot_z(0.3)).unsqueeze(0)).item<double>(), 0.0, 1e-12);
}

TEST(HvrnnLoss, KlMatchesTheClosedFormByHand) {
  // KL(N(1, 0.5^2) || N(0, 2^2)) = log(2 / 0.5) + (0.25 + 1) / 8 - 1/2; a second dim N(0,1)||N(0,1) = 0.
  auto mq = torch::tensor({1.0, 0.0}, torch::kFloat64), sq = torch::tensor({0.5, 1.0}, torch::kFloat64);
  auto mp = torch::tensor({0.0, 0.0}, torch::kFloat64), sp = torch::tensor({2.0, 1.0}, torch::kFloat64);
  EXPECT_NEAR(hvrnn::gaussian_kl(mq, sq, mp, sp).item<double>(), std::log(4.0) + 1.25 / 8 - 0.5, 1e-12);
  // Against Monte Carlo of E_q[log q - log p].
  torch::manual_seed(0);
  auto z = mq + sq * torch::randn({400000, 2}, torch::kFloat64);
  auto logn = [](const torch::Tensor& x, const torch::Tensor& m, const torch::Tensor& s) {
    return (-0.5 * ((x - m) / s).pow(2) - s.log() - 0.5 * std::log(2 * M_PI)).sum(-1);
  };
  EXPECT_NEAR((logn(z, mq, sq) - logn(z, mp, sp)).mean().item<double>(), std::log(4.0) + 1.25 / 8 - 0.5, 0.01);
}

TEST(HvrnnModel, ShapesAndMaskingForAnOddLength) {
  torch::manual_seed(1);
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), rotations_context());
  m.eval();
  Batch x = rotation_batch(3, 7);  // 7 frames: 3 words, the last with 2 padded frames
  torch::manual_seed(2);
  const LossTerms a = m.loss(x);
  for (const auto& kv : a.terms) EXPECT_TRUE(std::isfinite(kv.second.item<double>())) << kv.first;
  // The same windows padded by hand to 9 frames: same words and noise, so the same KL, but now
  // the two padded frames count (recon x frames grows) — masking left them out.
  Batch padded = x;
  padded.pose = torch::cat({x.pose, x.pose.narrow(1, 6, 1).expand({3, 2, -1})}, 1);
  padded.control = torch::cat({x.control, x.control.narrow(1, 6, 1).expand({3, 2, -1})}, 1);
  torch::manual_seed(2);
  const LossTerms b = m.loss(padded);
  EXPECT_NEAR(a.terms.at("kl").item<double>() * 7, b.terms.at("kl").item<double>() * 9, 1e-4);
  EXPECT_LT(a.terms.at("recon").item<double>() * 7, b.terms.at("recon").item<double>() * 9);
  const SampleOutput s = m.sample(request(2, 7, 3));
  EXPECT_EQ(s.pose.sizes(), (std::vector<int64_t>{2, 7, 25}));
  EXPECT_EQ(s.control.sizes(), (std::vector<int64_t>{2, 7, 3}));
  // Generated rotations are valid: Gram-Schmidt re-normalised (identity statistics: raw = standardised).
  auto r6 = s.pose.narrow(-1, 1, 24).reshape({2, 7, 4, 6});
  EXPECT_LT(hvrnn::rot6d_validity(r6).abs().max().item<double>(), 1e-4);
}

// Free bits: the loss takes max(KL, kl_free_nats); the reported KL stays the plain one.
TEST(HvrnnLoss, FreeNatsFloorTheKlInTheLoss) {
  Batch x = rotation_batch(3, 9);
  for (double free : {0.0, 0.01, 1e3}) {
    torch::manual_seed(1);
    HvrnnImpl m(HvrnnOptions::from_json(tiny({{"kl_free_nats", free}, {"kl_weight", 0.7}})), rotations_context());
    m.eval();  // the schedules' final weights
    torch::manual_seed(2);
    const LossTerms out = m.loss(x);
    auto term = [&](const char* k) { return out.terms.at(k).item<double>(); };
    const double expected =
        term("recon") + 0.7 * std::max(term("kl"), free) + m.options().validity_weight * term("validity");
    EXPECT_NEAR(out.loss().item<double>(), expected, 1e-5 * std::max(1.0, std::abs(expected))) << "free " << free;
    if (free == 1e3) {
      EXPECT_LT(term("kl"), free);  // the floor, not the KL, entered the loss
    }
  }
  EXPECT_THROW(HvrnnOptions::from_json({{"kl_free_nats", -1.0}}), Error);
}

// The velocity term: by hand for two frames, and it enters the loss with its weight.
TEST(HvrnnLoss, VelocityTermMatchesHandComputedFrameSteps) {
  Batch x = rotation_batch(2, 9);
  for (double w : {0.0, 2.5}) {
    torch::manual_seed(1);
    HvrnnImpl m(HvrnnOptions::from_json(tiny({{"velocity_weight", w}})), rotations_context());
    m.eval();
    torch::manual_seed(2);
    const LossTerms out = m.loss(x);
    auto term = [&](const char* k) { return out.terms.at(k).item<double>(); };
    EXPECT_GT(term("velocity"), 0.0);
    const double expected = term("recon") + m.options().kl_weight * term("kl") +
                            m.options().validity_weight * term("validity") + w * term("velocity") +
                            m.options().classifier_weight * term("classifier");
    EXPECT_NEAR(out.loss().item<double>(), expected, 1e-5 * std::max(1.0, std::abs(expected))) << "weight " << w;
  }
  // Known answer: pred moves by 1 in one feature, target by 3, over 3 frames; the last frame
  // is padding (mask 0): two valid pairs of 0.5 * (1 - 3)^2 = 2 each, the padded pair left out.
  auto pred = torch::zeros({1, 4, 5});
  auto target = torch::zeros({1, 4, 5});
  for (int f = 0; f < 4; ++f) {
    pred[0][f][2] = 1.0 * f;
    target[0][f][2] = 3.0 * f;
  }
  target[0][3][2] = 100.0;  // padding: must not count
  auto mask = torch::tensor({{1.0f, 1.0f, 1.0f, 0.0f}});
  EXPECT_NEAR(hvrnn::velocity_error(pred, target, mask).item<double>(), 2.0, 1e-6);
  EXPECT_THROW(HvrnnOptions::from_json({{"velocity_weight", -1.0}}), Error);
}

// A clip shorter than the training window comes padded (its last frame repeated) with its length
// in Batch::frames: every term equals the loss of the unpadded clip (same words, same noise).
TEST(HvrnnModel, ShortClipsPaddedToTheWindowScoreAsThemselves) {
  torch::manual_seed(1);
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), rotations_context());
  EXPECT_EQ(m.short_window_min_frames(), 3);  // one word
  m.eval();
  Batch x = rotation_batch(3, 7);
  torch::manual_seed(2);
  const LossTerms a = m.loss(x);
  Batch padded = x;
  padded.pose = torch::cat({x.pose, x.pose.narrow(1, 6, 1).expand({3, 5, -1})}, 1);  // 12 frames
  padded.control = torch::cat({x.control, x.control.narrow(1, 6, 1).expand({3, 5, -1})}, 1);
  padded.frames = torch::full({3}, 7, torch::kInt64);
  torch::manual_seed(2);
  const LossTerms b = m.loss(padded);
  for (const char* key : {"loss", "recon", "kl", "validity", "geodesic"})
    EXPECT_NEAR(a.terms.at(key).item<double>(), b.terms.at(key).item<double>(), 1e-5) << key;
  // Full-length rows (frames = T) score as without Batch::frames.
  padded.frames = torch::full({3}, 12, torch::kInt64);
  torch::manual_seed(2);
  const LossTerms full = m.loss(padded);
  padded.frames = torch::Tensor();
  torch::manual_seed(2);
  EXPECT_NEAR(full.terms.at("loss").item<double>(), m.loss(padded).terms.at("loss").item<double>(), 1e-6);
}

TEST(HvrnnModel, ATinyModelLearnsSyntheticMotion) {
  torch::manual_seed(4);
  auto ctx = labelled_small_context();
  HvrnnImpl m(HvrnnOptions::from_json(tiny({{"kl_warmup", 0.0}, {"kl_anneal", 0.0}, {"word_drop", 0.0}})), ctx);
  torch::optim::Adam opt(m.parameters(), torch::optim::AdamOptions(3e-3));
  auto eval_loss = [&] {
    m.eval();
    torch::manual_seed(9);
    Batch x = nn::testing::noisy_sinusoid_batch(8, 24, 6);
    double v = m.loss(x).loss().item<double>();
    m.train();
    return v;
  };
  const double before = eval_loss();
  for (int step = 1; step <= 100; ++step) {
    m.set_progress(step, 100);
    Batch x = nn::testing::noisy_sinusoid_batch(8, 24, 6);
    opt.zero_grad();
    m.loss(x).loss().backward();
    opt.step();
  }
  const double after = eval_loss();
  EXPECT_LT(after, 0.7 * before) << before << " -> " << after;
}

TEST(HvrnnModel, ARotationsModelsLossFallsToo) {
  torch::manual_seed(5);
  HvrnnImpl m(HvrnnOptions::from_json(tiny({{"kl_warmup", 0.0}, {"kl_anneal", 0.0}})), rotations_context());
  torch::optim::Adam opt(m.parameters(), torch::optim::AdamOptions(3e-3));
  double first = 0, last = 0;
  for (int step = 1; step <= 100; ++step) {
    m.set_progress(step, 100);
    Batch x = rotation_batch(4, 12);
    opt.zero_grad();
    auto terms = m.loss(x);
    terms.loss().backward();
    opt.step();
    if (step <= 10) first += terms.terms.at("geodesic").item<double>();
    if (step > 90) last += terms.terms.at("geodesic").item<double>();
  }
  EXPECT_LT(last, 0.7 * first) << "mean joint angle error " << first / 10 << " -> " << last / 10;
}

TEST(HvrnnModel, SchedulesFollowProgress) {
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), labelled_small_context());  // warm-up 0.1, anneal 0.4
  m.set_progress(5, 100);
  EXPECT_EQ(m.current_kl_weight(), 0.0);
  m.set_progress(30, 100);
  EXPECT_NEAR(m.current_kl_weight(), 0.5, 1e-12);
  m.set_progress(80, 100);
  EXPECT_NEAR(m.current_kl_weight(), 1.0, 1e-12);
  EXPECT_NEAR(m.current_word_drop(), 0.3, 1e-12);
  m.set_progress(40, 100);
  EXPECT_NEAR(m.current_word_drop(), 0.15, 1e-12);
  EXPECT_NEAR(m.current_classifier_weight(), 0.1 * 0.8, 1e-12);
}

TEST(HvrnnModel, SeedsAndLabelsDecideTheMotion) {
  torch::manual_seed(6);
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), labelled_small_context());
  m.eval();
  EXPECT_TRUE(m.traits().labels);
  EXPECT_EQ(m.traits().control, InputUse::kGenerates);
  SampleRequest r = request(2, 10, 7);
  r.content = torch::tensor({0, 0});
  r.style = torch::tensor({1, 1});
  const SampleOutput a = m.sample(r);
  EXPECT_TRUE(torch::equal(a.pose, m.sample(r).pose));
  EXPECT_TRUE(torch::equal(a.control, m.sample(r).control));
  SampleRequest other_seed = r;
  other_seed.seed = 8;
  EXPECT_FALSE(torch::equal(a.pose, m.sample(other_seed).pose));
  SampleRequest other_label = r;
  other_label.content = torch::tensor({2, 2});
  EXPECT_FALSE(torch::equal(a.pose, m.sample(other_label).pose));
  other_label = r;
  other_label.style = torch::tensor({-1, -1});
  EXPECT_FALSE(torch::equal(a.pose, m.sample(other_label).pose));
  SampleRequest bad = r;
  bad.content = torch::tensor({3, 0});
  EXPECT_THROW(m.sample(bad), Error);
}

TEST(HvrnnModel, ContinuesAPrefixWordByWord) {
  torch::manual_seed(7);
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), labelled_small_context());
  m.eval();
  SampleRequest r = request(2, 8, 3);
  const SampleOutput plain = m.sample(r);
  r.prefix_pose = torch::randn({2, 7, 6});  // 2 whole words (the first frame is left out)
  r.prefix_control = torch::randn({2, 7, 3});
  const SampleOutput cont = m.sample(r);
  EXPECT_EQ(cont.pose.sizes(), (std::vector<int64_t>{2, 8, 6}));
  EXPECT_FALSE(torch::equal(cont.pose, plain.pose));
  SampleRequest shifted = r;  // the frame before the last two words does not matter
  shifted.prefix_pose = r.prefix_pose.clone();
  shifted.prefix_pose.select(1, 0).fill_(5.0);
  EXPECT_TRUE(torch::equal(m.sample(shifted).pose, cont.pose));
  SampleRequest other = r;
  other.prefix_pose = r.prefix_pose.clone();
  other.prefix_pose.select(1, 6).fill_(5.0);
  EXPECT_FALSE(torch::equal(m.sample(other).pose, cont.pose));
  SampleRequest short_prefix = request(2, 8, 3);  // shorter than a word: nothing to continue
  short_prefix.prefix_pose = torch::randn({2, 2, 6});
  EXPECT_TRUE(torch::equal(m.sample(short_prefix).pose, plain.pose));
}

TEST(HvrnnModel, StreamsWordByWordAsSampleDoes) {
  torch::manual_seed(10);
  HvrnnImpl m(HvrnnOptions::from_json(tiny()), rotations_context());
  m.eval();
  EXPECT_TRUE(m.traits().streaming);
  SampleRequest r = request(2, 8, 11);
  r.content = torch::tensor({1, -1});
  r.style = torch::tensor({0, 1});
  r.prefix_pose = rotation_batch(2, 7).pose;
  const SampleOutput offline = m.sample(r);
  auto stream = m.begin_stream(r);
  for (int64_t t = 0; t < 8; ++t) {
    const StreamFrame f = m.step_stream(*stream, {});
    EXPECT_TRUE(torch::allclose(f.pose, offline.pose.select(1, t), 1e-5, 1e-5)) << t;
    EXPECT_TRUE(torch::allclose(f.control, offline.control.select(1, t), 1e-5, 1e-5)) << t;
  }
}

// decoder_previous_frame: the teacher-forced previous frames by hand, a warm start with zero
// weights on the new inputs reproducing the model without them, and streaming equal to sample().
TEST(HvrnnModel, DecoderSeesThePreviousFrame) {
  EXPECT_THROW(HvrnnOptions::from_json(tiny({{"preset", "SL"}, {"decoder_previous_frame", true}})), Error);
  torch::manual_seed(12);
  HvrnnImpl plain(HvrnnOptions::from_json(tiny()), rotations_context());
  HvrnnImpl with(HvrnnOptions::from_json(tiny({{"decoder_previous_frame", true}})), rotations_context());
  plain.eval();
  with.eval();
  const int64_t f = 25 + 3;
  auto frames = torch::randn({2, 9, f});
  auto prev = with.teacher_previous(frames);
  ASSERT_EQ(prev.sizes(), (std::vector<int64_t>{2, 3, f + 1}));
  EXPECT_EQ(prev.select(1, 0).abs().sum().item<double>(), 0.0);
  for (int64_t n = 1; n < 3; ++n) {
    EXPECT_TRUE(torch::equal(prev.select(1, n).narrow(-1, 0, f), frames.select(1, 3 * n - 1))) << n;
    EXPECT_EQ(prev.select(1, n)[0][f].item<double>(), 1.0);
  }
  // Copy the plain model into the wider one, the new input weights zero (what --init-from does).
  {
    torch::NoGradGuard no_grad;
    auto src = plain.named_parameters(), dst = with.named_parameters();
    for (auto& kv : src) {
      auto& t = dst[kv.key()];
      t.zero_();
      t.narrow(-1, 0, kv.value().size(-1)).copy_(kv.value());
    }
  }
  Batch x = rotation_batch(2, 8);
  torch::manual_seed(3);
  const double a = plain.loss(x).terms.at("loss").item<double>();
  torch::manual_seed(3);
  EXPECT_NEAR(with.loss(x).terms.at("loss").item<double>(), a, 1e-5);
  SampleRequest r = request(2, 8, 5);
  r.prefix_pose = rotation_batch(2, 2).pose;  // shorter than a word: only its last frame is used
  EXPECT_TRUE(torch::allclose(with.sample(r).pose, plain.sample(r).pose, 1e-5, 1e-5));
  // Non-zero weights on the previous frame: the prefix's last frame now shapes the first word, and
  // the stream decodes word by word exactly as sample() does.
  {
    torch::NoGradGuard no_grad;
    with.word_decoder->layers[0]->as<torch::nn::LinearImpl>()->weight.narrow(1, 8, f + 1).normal_(0, 0.5);
  }
  const SampleOutput offline = with.sample(r);
  EXPECT_FALSE(torch::allclose(offline.pose, plain.sample(r).pose, 1e-3, 1e-3));
  auto stream = with.begin_stream(r);
  for (int64_t t = 0; t < 8; ++t) {
    const StreamFrame fr = with.step_stream(*stream, {});
    EXPECT_TRUE(torch::allclose(fr.pose, offline.pose.select(1, t), 1e-5, 1e-5)) << t;
  }
}

// boundary_weight: the term enters the loss with its weight, and it is what trains the prior when
// the KL is off (without it the prior networks get no gradient at all).
TEST(HvrnnLoss, BoundaryTermTrainsThePriorPath) {
  for (double w : {0.0, 2.0}) {
    torch::manual_seed(14);
    HvrnnImpl m(HvrnnOptions::from_json(
                    tiny({{"kl_weight", 0.0}, {"validity_weight", 0.0}, {"boundary_weight", w},
                          {"decoder_previous_frame", true}})),
                rotations_context());
    m.eval();
    const LossTerms t = m.loss(rotation_batch(2, 9));
    m.zero_grad();
    t.terms.at("loss").backward();
    const double prior_grad = m.prior_mu->layers[0]->as<torch::nn::LinearImpl>()->weight.grad().defined()
                                  ? m.prior_mu->layers[0]->as<torch::nn::LinearImpl>()->weight.grad().abs().sum().item<double>()
                                  : 0.0;
    if (w == 0) {
      EXPECT_EQ(t.terms.count("boundary"), 0u);
      EXPECT_EQ(prior_grad, 0.0);
      continue;
    }
    const double boundary = t.terms.at("boundary").item<double>();
    EXPECT_GT(boundary, 0.0);
    EXPECT_NEAR(t.terms.at("loss").item<double>(), t.terms.at("recon").item<double>() + w * boundary, 1e-4);
    EXPECT_GT(prior_grad, 0.0);
  }
}

TEST(HvrnnPresets, AblationsBuildAndTrain) {
  const auto sl = HvrnnOptions::from_json({{"preset", "SL"}});
  EXPECT_FALSE(sl.word_coder);
  EXPECT_EQ(sl.word_length, 1);
  EXPECT_EQ(HvrnnOptions::from_json({{"preset", "NL"}}).alpha, "uniform");
  EXPECT_EQ(HvrnnOptions::from_json({{"preset", "NC"}}).classifier_weight, 0.0);
  EXPECT_EQ(HvrnnOptions::from_json({{"preset", "full"}}).to_json(), HvrnnOptions{}.to_json());
  EXPECT_THROW(HvrnnOptions::from_json({{"preset", "XL"}}), Error);
  EXPECT_THROW(HvrnnOptions::from_json({{"kl_warmup", 0.7}, {"kl_anneal", 0.5}}), Error);
  for (const std::string p : {"full", "SL", "NL", "NC"}) {
    torch::manual_seed(8);
    HvrnnImpl m(HvrnnOptions::from_json(tiny({{"preset", p}})), rotations_context());
    m.train();
    auto terms = m.loss(rotation_batch(2, 5));
    EXPECT_TRUE(std::isfinite(terms.loss().item<double>())) << p;
    terms.loss().backward();
    m.eval();
    EXPECT_EQ(m.sample(request(1, 5, 1)).pose.sizes(), (std::vector<int64_t>{1, 5, 25})) << p;
    EXPECT_EQ(m.word_encoder.is_empty(), p == "SL") << p;
  }
  // The paper's sizes: two GRU cells of 512, latent 96, words of 3 frames.
  HvrnnImpl full(HvrnnOptions{}, rotations_context());
  EXPECT_EQ(full.init_mean.size(1), 1024);
  EXPECT_EQ(full.init_mean.size(0), 9) << "(content + none) x (style + none) initial states";
}

TEST(HvrnnClassifierLoss, AMissingClassifierRunIsAnErrorWhenTheTermIsUsed) {
  HvrnnImpl m(HvrnnOptions::from_json(tiny({{"classifier_run", "/nonexistent/run"}})), labelled_small_context());
  m.train();
  m.set_progress(100, 100);
  Batch x = nn::testing::noisy_sinusoid_batch(2, 6, 6);
  EXPECT_THROW(m.loss(x), Error);
  HvrnnImpl nc(HvrnnOptions::from_json(tiny({{"classifier_run", "/nonexistent/run"}, {"preset", "NC"}})),
               labelled_small_context());
  EXPECT_NO_THROW(nc.loss(x)) << "NC never loads it";
}

}  // namespace

// The shared foot objectives (HvrnnOptions::foot) on the reconstruction of a walk in the
// rotations form, its feet after forward kinematics moving with the root steps it reconstructs:
// logged by name, added in training on top of the loss the same draws make with the terms off.
TEST(Hvrnn, FootObjectivesOnTheReconstruction) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::form_context(s, data::PoseForm::kRotations);
  const Batch batch = nn::testing::walk_batch(s, ctx, 24);
  auto loss_of = [&](const nlohmann::json& cfg, bool training) {
    torch::manual_seed(3);
    HvrnnImpl m(HvrnnOptions::from_json(cfg), ctx);
    m.train(training);
    torch::manual_seed(4);
    return m.loss(batch);
  };
  const auto on = tiny({{"foot_contact_weight", 3.0}, {"heel_speed_weight", 1.0}, {"toe_slide_weight", 1.0},
                        {"pelvis_follow_weight", 0.5}});
  EXPECT_EQ(HvrnnOptions::from_json(on).to_json().at("foot_contact_weight"), 3.0);
  const LossTerms off = loss_of(tiny(), true), with = loss_of(on, true), eval = loss_of(on, false);
  EXPECT_EQ(off.terms.count("planted_heel_mps"), 0u);
  const double planted = with.terms.at("planted_heel_mps").item<double>();
  const double toe = with.terms.at("toe_slide_mps").item<double>();
  const double pelvis = with.terms.at("pelvis_offset_m").item<double>();
  const double heel = with.terms.at("heel_speed_error_mps").item<double>();
  EXPECT_GT(heel, 0.0);  // an untrained model's feet do not move as the data's
  EXPECT_NEAR(with.loss().item<double>(), off.loss().item<double>() + 3.0 * planted + heel + toe + 0.5 * pelvis,
              1e-4);
  EXPECT_EQ(eval.terms.count("planted_heel_mps"), 1u);  // logged outside training too
  // Without the skeleton the terms cannot find the feet, and say so.
  EXPECT_THROW(HvrnnImpl(HvrnnOptions::from_json(on), labelled_small_context()), Error);
}

// The shared terms on free draws: every word also decoded from a prior draw; added in training
// only, their gradient reaching the prior; chained, the drawn words are those generation decodes
// one after another (each after the drawn word before it), so the terms differ from the
// teacher-forced draws' and the option needs the previous-frame decoder.
TEST(Hvrnn, DrawTermsOnPriorWords) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::form_context(s, data::PoseForm::kRotations);
  const Batch batch = nn::testing::walk_batch(s, ctx, 24);
  auto loss_of = [&](const nlohmann::json& cfg, bool training, HvrnnImpl** keep = nullptr) {
    torch::manual_seed(3);
    auto* m = new HvrnnImpl(HvrnnOptions::from_json(cfg), ctx);
    m->train(training);
    torch::manual_seed(4);
    LossTerms t = m->loss(batch);
    if (keep) *keep = m; else delete m;
    return t;
  };
  const nlohmann::json draw = {{"draw_speed_distribution_weight", 1.0}, {"draw_toe_slide_weight", 2.0},
                               {"draw_speed_weight", 0.5}, {"decoder_previous_frame", true},
                               {"boundary_weight", 1.0}};  // both runs draw the prior words alike
  auto with = [&](nlohmann::json extra) {
    auto cfg = tiny(draw);
    for (auto& [k, v] : extra.items()) cfg[k] = v;
    return cfg;
  };
  const LossTerms off = loss_of(tiny({{"decoder_previous_frame", true}, {"boundary_weight", 1.0}}), true);
  HvrnnImpl* model = nullptr;
  const LossTerms on = loss_of(with({}), true, &model);
  ASSERT_EQ(off.terms.count("draw_speed"), 0u);
  const double dist = on.terms.at("draw_speed_distribution_mps").item<double>();
  const double toe = on.terms.at("draw_toe_slide_mps").item<double>();
  const double speed = on.terms.at("draw_speed").item<double>();
  EXPECT_GT(dist, 0.0);  // an untrained prior's words do not walk as the data does
  EXPECT_NEAR(on.loss().item<double>(), off.loss().item<double>() + dist + 2.0 * toe + 0.5 * speed, 1e-4);
  model->zero_grad();
  on.loss().backward();
  const auto& prior = model->prior_mu->layers[0]->as<torch::nn::LinearImpl>()->weight;
  ASSERT_TRUE(prior.grad().defined());
  EXPECT_GT(prior.grad().abs().sum().item<double>(), 0.0);
  delete model;
  EXPECT_EQ(loss_of(with({}), false).terms.count("draw_speed"), 0u);  // not drawn outside training
  const LossTerms chained = loss_of(with({{"draw_chained", true}}), true);
  EXPECT_NE(chained.terms.at("draw_root_mps").item<double>(), on.terms.at("draw_root_mps").item<double>());
  EXPECT_EQ(HvrnnOptions::from_json(with({{"draw_chained", true}})).to_json().at("draw_chained"), true);
  auto bad = tiny({{"draw_chained", true}});
  EXPECT_THROW(HvrnnOptions::from_json(bad), Error);
}

// boundary_blend: a generated word is joined to the two frames before it (the offset from the
// continuation of their velocity, averaged with the word's own first step, decays by the factor a
// frame), by hand on a channel the rotation normalisation leaves alone; and streaming still
// equals sample() with it.
TEST(HvrnnModel, BoundaryBlendJoinsWordsToTheFramesBeforeThem) {
  torch::manual_seed(12);
  HvrnnImpl m(HvrnnOptions::from_json(tiny({{"decoder_previous_frame", true}, {"boundary_blend", 0.5}})),
              rotations_context());
  m.eval();
  const ModelContext context = rotations_context();
  const int64_t f = m.options().word_length, dim = context.pose_dim + context.control_dim;
  auto frames = torch::randn({1, f, dim});
  auto previous = torch::randn({1, dim}), before = torch::randn({1, dim});
  const auto out = m.blend_boundary(frames, previous, before);
  const int64_t c = dim - 1;  // the last control channel
  const double p1 = previous[0][c].item<double>(), p0 = before[0][c].item<double>();
  const double f0 = frames[0][0][c].item<double>(), f1 = frames[0][1][c].item<double>();
  const double offset = p1 + 0.5 * ((p1 - p0) + (f1 - f0)) - f0;
  for (int64_t j = 0; j < f; ++j)
    EXPECT_NEAR(out[0][j][c].item<double>(), frames[0][j][c].item<double>() + offset * std::pow(0.5, j), 1e-5) << j;

  SampleRequest r = request(2, 10, 13);
  r.prefix_pose = rotation_batch(2, 7).pose;
  const SampleOutput offline = m.sample(r);
  auto stream = m.begin_stream(r);
  for (int64_t t = 0; t < 10; ++t) {
    const StreamFrame s = m.step_stream(*stream, {});
    EXPECT_TRUE(torch::allclose(s.pose, offline.pose.select(1, t), 1e-5, 1e-5)) << t;
  }
  EXPECT_THROW(HvrnnOptions::from_json(tiny({{"boundary_blend", 1.0}})), Error);
}
