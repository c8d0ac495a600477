// MOJO (nn/mojo): the DCT against its closed form, the latent DCT and -DCT shapes, the robust KL,
// DLow's latents, losses and sampling groups, seeds, and the recursive projection giving valid
// bodies (a body's own markers come back unchanged; noisy markers come back as a body's).
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/markers.h"
#include "core/rotation.h"
#include "core/synthetic.h"
#include "data/representation.h"
#include "nn/mojo/dct.h"
#include "nn/mojo/mojo.h"
#include "nn/mojo/projection.h"
#include "nn/registry.h"
#include "foot_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

ModelContext plain_context(int pose_dim = 6) {
  ModelContext c;
  c.pose_dim = pose_dim;
  c.control_dim = 3;
  c.pose_form = data::PoseForm::kPositions;
  return c;
}

std::shared_ptr<MojoImpl> make(nlohmann::json config = family_info("mojo").tiny_config,
                               const ModelContext& c = plain_context()) {
  torch::manual_seed(5);
  return std::make_shared<MojoImpl>(MojoOptions::from_json(config), c);
}

Batch random_batch(int b, int t, int d, unsigned seed) {
  torch::manual_seed(seed);
  return Batch{torch::randn({b, t, d}), torch::randn({b, t, 3}), {}, {}};
}

}  // namespace

TEST(MojoDct, MatrixMatchesClosedFormAndIsOrthonormal) {
  for (int64_t n : {1, 2, 4, 7, 45}) {
    const auto c = mojo::dct_matrix(n);
    auto a = c.accessor<double, 2>();
    for (int64_t k = 0; k < n; ++k)
      for (int64_t i = 0; i < n; ++i) {
        const double s = k == 0 ? std::sqrt(1.0 / n) : std::sqrt(2.0 / n);
        EXPECT_NEAR(a[k][i], s * std::cos(M_PI * (2 * i + 1) * k / (2.0 * n)), 1e-14);
      }
    EXPECT_LT((torch::matmul(c, c.t()) - torch::eye(n, torch::kFloat64)).abs().max().item<double>(), 1e-12) << n;
    EXPECT_LT((torch::matmul(c.t(), c) - torch::eye(n, torch::kFloat64)).abs().max().item<double>(), 1e-12) << n;
  }
  // N = 4 by hand: band 0 is 1/2 everywhere; band 2 is (1, -1, -1, 1) / 2.
  const auto c4 = mojo::dct_matrix(4);
  EXPECT_NEAR(c4[0][3].item<double>(), 0.5, 1e-15);
  EXPECT_NEAR(c4[2][0].item<double>(), 0.5, 1e-15);
  EXPECT_NEAR(c4[2][1].item<double>(), -0.5, 1e-15);
  EXPECT_NEAR(c4[1][0].item<double>(), std::sqrt(0.5) * std::cos(M_PI / 8), 1e-15);
}

TEST(MojoDct, TimeTransformIsInvertibleAndCompactsAConstant) {
  torch::manual_seed(1);
  auto x = torch::randn({3, 9, 5}, torch::kFloat64);
  EXPECT_LT((mojo::idct_time(mojo::dct_time(x)) - x).abs().max().item<double>(), 1e-12);
  // A constant sequence lives in band 0 only: sqrt(N) x value.
  auto constant = torch::full({1, 9, 2}, 2.0, torch::kFloat64);
  auto bands = mojo::dct_time(constant);
  EXPECT_NEAR(bands[0][0][0].item<double>(), 2.0 * 3.0, 1e-12);
  EXPECT_LT(bands.narrow(1, 1, 8).abs().max().item<double>(), 1e-12);
  EXPECT_THROW(mojo::dct_matrix(0), Error);
}

TEST(Mojo, PresetsAndOptions) {
  const MojoOptions dct = MojoOptions::from_json(nlohmann::json::object());
  EXPECT_TRUE(dct.latent_dct);
  EXPECT_EQ(dct.latent, 16);
  EXPECT_EQ(dct.kl, "robust");
  EXPECT_EQ(dct.dlow_bands, 9);
  EXPECT_EQ(dct.dlow_k, 50);
  const MojoOptions plain = MojoOptions::from_json({{"preset", "mojo-dct"}});
  EXPECT_FALSE(plain.latent_dct);
  EXPECT_EQ(plain.latent, 128);
  EXPECT_EQ(plain.kl, "standard");
  EXPECT_DOUBLE_EQ(plain.kl_weight, 0.1);
  EXPECT_THROW(MojoOptions::from_json({{"kl", "sideways"}}), Error);
  EXPECT_THROW(MojoOptions::from_json({{"preset", "mojo-dct"}, {"nope", 1}}), Error);
}

TEST(Mojo, LatentShapesWithAndWithoutDct) {
  auto m = make();
  auto past = torch::randn({2, 3, 9}), future = torch::randn({2, 4, 9});
  auto h = m->encode_past(past);
  EXPECT_EQ(h.sizes(), (std::vector<int64_t>{2, 8}));
  auto [mean, logvar] = m->encode_future(future, h);
  EXPECT_EQ(mean.sizes(), (std::vector<int64_t>{2, 4, 3}));  // one latent per band
  EXPECT_EQ(logvar.sizes(), mean.sizes());
  // The decoder's latent sequence is the inverse DCT of the bands.
  EXPECT_LT((m->latent_sequence(mean, 4) - mojo::idct_time(mean)).abs().max().item<double>(), 1e-6);
  auto cfg = family_info("mojo").tiny_config;
  cfg["preset"] = "mojo-dct";
  cfg["latent"] = 5;
  auto plain = make(cfg);
  auto [m2, l2] = plain->encode_future(future, plain->encode_past(past));
  EXPECT_EQ(m2.sizes(), (std::vector<int64_t>{2, 1, 5}));  // one vector for the whole future
  auto seq = plain->latent_sequence(m2, 4);
  EXPECT_EQ(seq.sizes(), (std::vector<int64_t>{2, 4, 5}));
  EXPECT_LT((seq.select(1, 3) - m2.select(1, 0)).abs().max().item<double>(), 1e-9);
}

TEST(Mojo, RobustKlIsTheCharbonnierOfTheKl) {
  auto m = make();
  auto terms = m->loss(random_batch(1, 7, 6, 2)).terms;  // one sequence: no batch mean in between
  const double kl = terms.at("kl").item<double>();
  EXPECT_GT(kl, 0.0);
  EXPECT_NEAR(terms.at("kl_term").item<double>(), std::sqrt(1.0 + kl * kl) - 1.0, 1e-4 * (1 + kl));
  auto cfg = family_info("mojo").tiny_config;
  cfg["kl"] = "standard";
  auto s = make(cfg)->loss(random_batch(1, 7, 6, 2)).terms;
  EXPECT_NEAR(s.at("kl_term").item<double>(), s.at("kl").item<double>(), 1e-6);
}

// On a fixed batch of smooth trajectories, Adam on the CVAE loss lowers the reconstruction error by
// a third and the total; the robust KL first falls and then grows again as the latent starts to
// carry the future, so only the total and the reconstruction are asserted.
TEST(Mojo, CvaeLossTrainsTheCvaeAndFalls) {
  torch::manual_seed(5);
  auto m = make();
  torch::optim::Adam opt(m->parameters(), torch::optim::AdamOptions(3e-3));
  auto batch = random_batch(8, 7, 6, 3);
  batch.pose = torch::cumsum(batch.pose * 0.1, 1);  // smooth trajectories
  double first = 0, last = 0, first_recon = 0, last_recon = 0;
  for (int i = 0; i < 150; ++i) {
    opt.zero_grad();
    auto terms = m->loss(batch);
    terms.loss().backward();
    opt.step();
    if (i == 0) first = terms.loss().item<double>(), first_recon = terms.terms.at("recon").item<double>();
    last = terms.loss().item<double>();
    last_recon = terms.terms.at("recon").item<double>();
  }
  EXPECT_LT(last, first);
  EXPECT_LT(last_recon, 0.7 * first_recon);
}

TEST(Mojo, DlowLatentsShareOneNoisePerBandAcrossTheKMaps) {
  auto m = make();
  auto past = torch::randn({2, 3, 9});
  auto eps = torch::randn({2, 2, 3});
  auto d = m->dlow_latents(past, eps);
  EXPECT_EQ(d.z.sizes(), (std::vector<int64_t>{2, 3, 2, 3}));  // [B, K, bands, Z]
  auto recovered = (d.z - d.mean) / torch::exp(0.5 * d.logvar);  // = eps for every k
  EXPECT_LT((recovered - eps.unsqueeze(1)).abs().max().item<double>(), 1e-5);
}

// DLow's losses with maps fixed at N(0, I) (last layers zero) and every band mapped: the K
// samples of a past are identical, so KL = 0, the diversity term exp(-0) = 1 and best-of-K is
// the one sample's error; only DLow's networks get gradients in its stage.
TEST(Mojo, DlowLossesByHand) {
  auto cfg = family_info("mojo").tiny_config;
  cfg["dlow_bands"] = 4;  // = future: no prior bands
  auto m = make(cfg);
  {
    torch::NoGradGuard no_grad;
    for (auto& kv : m->named_parameters())
      if (kv.key().rfind("dlow_heads", 0) == 0 && kv.key().find(".2.") != std::string::npos) kv.value().zero_();
  }
  m->begin_stage(1, TrainingStage{});
  EXPECT_TRUE(m->dlow_trained());
  auto t = m->loss(random_batch(2, 7, 6, 4)).terms;
  EXPECT_NEAR(t.at("dlow_kl").item<double>(), 0.0, 1e-7);
  EXPECT_NEAR(t.at("dlow_div").item<double>(), 1.0, 1e-3);
  EXPECT_GT(t.at("dlow_recon").item<double>(), 0.0);
  m->zero_grad();
  t.at("loss").backward();
  for (auto& kv : m->named_parameters()) {
    const bool dlow = kv.key().rfind("dlow", 0) == 0;
    const bool has = kv.value().grad().defined() && kv.value().grad().abs().sum().item<double>() > 0;
    if (kv.key().rfind("past_rnn", 0) == 0) {
      EXPECT_FALSE(has) << kv.key();  // no gradient through the frozen encoder
    }
    // Every band's map gets a gradient. Its last layer's bias always does; its weight only through
    // live hidden units (a tiny head's ReLUs can all be off for a given past).
    if (dlow && kv.key().find("dlow_heads") == 0 && kv.key().find(".2.bias") != std::string::npos) {
      EXPECT_TRUE(has) << kv.key();
    }
  }
}

TEST(Mojo, TwoStagesOfTheRun) {
  auto m = make();
  TrainStageDefaults d;
  d.steps = 100;
  auto stages = m->training_stages(d);
  ASSERT_EQ(stages.size(), 2u);
  EXPECT_EQ(stages[0].name, "cvae");
  EXPECT_EQ(stages[1].name, "dlow");
  EXPECT_EQ(stages[0].steps + stages[1].steps, 100);
  EXPECT_EQ(stages[1].steps, 25);
  EXPECT_EQ(stages[1].trained, (std::vector<std::string>{"dlow_rnn", "dlow_heads"}));
}

TEST(Mojo, SeedsAndDlowGroups) {
  auto cfg = family_info("mojo").tiny_config;
  cfg["dlow_bands"] = 4;
  auto m = make(cfg);
  {
    torch::NoGradGuard no_grad;
    for (auto& kv : m->named_parameters())
      if (kv.key().rfind("dlow_heads", 0) == 0 && kv.key().find(".2.") != std::string::npos) kv.value().zero_();
  }
  m->begin_stage(1, TrainingStage{});
  m->eval();
  SampleRequest r;
  const int k = 3;
  r.control = torch::zeros({2 * k, 10, 3});
  r.prefix_pose = torch::randn({1, 4, 6}).expand({2 * k, 4, 6}).contiguous();
  r.seed = 11;
  auto a = m->sample(r), b = m->sample(r);
  EXPECT_TRUE(torch::equal(a.pose, b.pose));
  EXPECT_TRUE(torch::equal(a.control, b.control));
  EXPECT_EQ(a.pose.sizes(), (std::vector<int64_t>{2 * k, 10, 6}));
  // Rows 0..K-1 are one past's K samples: one noise per band; the maps are identity here, so the
  // first pass (4 frames) is the same in the group and differs between groups.
  auto first = a.pose.narrow(1, 0, 4);
  EXPECT_LT((first[0] - first[k - 1]).abs().max().item<double>(), 1e-6);
  EXPECT_GT((first[0] - first[k]).abs().max().item<double>(), 1e-4);
  r.seed = 12;
  EXPECT_FALSE(torch::equal(m->sample(r).pose, a.pose));
}

// ---------------------------------------------------------------------------------------------
// Recursive projection

namespace {

// Marker features (metres, heading frame irrelevant here: the projector fits in whatever frame
// the markers are given) of a pose of the synthetic biped, standardised with mean 0, std 1.
std::vector<float> marker_row(const Skeleton& s, const Motion& m, int t) {
  const MarkerSet set = cmu41_markers(s);
  const WorldPoses w = forward_kinematics(s, m);
  std::vector<float> row;
  for (const auto& p : marker_positions(set, w, t))
    for (int k = 0; k < 3; ++k) row.push_back(static_cast<float>(p[k] * s.meters_per_unit));
  for (int k = 0; k < 3; ++k) row.push_back(0.5f);  // a control part, left alone
  return row;
}

}  // namespace

// With a negligible pose-change prior a valid body is its own projection; the prior's pull towards the
// previous frame's fit (1e-4 by default: 0.1-0.2 mm on this walk) is measured separately below.
TEST(MojoProjection, ABodysOwnMarkersComeBackAndNoiseBecomesABody) {
  const Skeleton s = make_synthetic_biped();
  const Motion walk = make_synthetic_walk(s, 12, 30.0);
  const std::vector<double> mean(123, 0.0), std(123, 1.0);
  mojo::ProjectionOptions po;
  po.threads = 2;
  po.iterations = 30;
  po.pose_prior = 1e-9;
  mojo::MarkerProjector proj(s, mean, std, 2, po);
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0, 0.01f);  // 1 cm
  for (int t = 0; t < walk.num_frames; ++t) {
    auto clean = marker_row(s, walk, t);
    std::vector<float> rows = clean;
    auto noisy = clean;
    for (int i = 0; i < 123; ++i) noisy[i] += noise(rng);
    rows.insert(rows.end(), noisy.begin(), noisy.end());
    proj.project(rows.data(), 126);
    double worst = 0;
    for (int i = 0; i < 123; ++i) worst = std::max(worst, static_cast<double>(std::abs(rows[i] - clean[i])));
    EXPECT_LT(worst, 1e-4) << "frame " << t;  // row 0: a valid body is its own projection
    EXPECT_FLOAT_EQ(rows[125], 0.5f);          // the control part is untouched
    // Row 1: the result is a body's markers: the fitted body reproduces them exactly.
    const auto body = marker_row(s, proj.bodies()[1], 0);
    for (int i = 0; i < 123; ++i) EXPECT_NEAR(rows[126 + i], body[i], 1e-5);
  }
  EXPECT_EQ(proj.timing().frames, 2L * walk.num_frames);
  // The first row recovered the walk's joint rotations where markers pin them (the pelvis).
  const WorldPoses a = forward_kinematics(s, walk), b = forward_kinematics(s, proj.bodies()[0]);
  EXPECT_LT(geodesic_angle(a.rotation(walk.num_frames - 1, 0), b.rotation(0, 0)), 1e-3);
}

TEST(MojoProjection, SamplingWithMarkersProjectsEveryFrame) {
  ModelContext c;
  c.skeleton = make_synthetic_biped();
  c.pose_form = data::PoseForm::kMarkers;
  c.layout = data::make_layout(c.skeleton, data::PoseForm::kMarkers, 0, Eigen::Vector3d(0, 0, 1));
  c.pose_dim = c.layout.pose_dim;
  c.control_dim = 3;
  c.stats.pose_mean.assign(c.pose_dim, 0.0f);
  c.stats.pose_std.assign(c.pose_dim, 0.1f);
  c.stats.control_mean.assign(3, 0.0f);
  c.stats.control_std.assign(3, 1.0f);
  auto m = make(family_info("mojo").tiny_config, c);
  m->eval();
  // Prefix: the walk's markers, standardised.
  const Motion walk = make_synthetic_walk(c.skeleton, 4, 30.0);
  std::vector<float> pose, control;
  data::encode(c.skeleton, walk, c.layout, &pose, &control);
  auto pre = torch::from_blob(pose.data(), {1, 4, 123}, torch::kFloat32).clone() / 0.1;
  SampleRequest r;
  r.control = torch::zeros({2, 6, 3});
  r.prefix_pose = pre.expand({2, 4, 123}).contiguous();
  auto out = m->sample(r);
  EXPECT_EQ(out.pose.sizes(), (std::vector<int64_t>{2, 6, 123}));
  EXPECT_TRUE(torch::isfinite(out.pose).all().item<bool>());
  const auto timing = m->last_projection_timing();
  EXPECT_EQ(timing.frames, 2L * 8);  // 2 passes of 4 predicted frames (the observed frame's start fit is not counted)
  EXPECT_EQ(timing.calls, 8L);
  ASSERT_EQ(m->last_sample_timings().size(), 1u);
  EXPECT_EQ(m->last_sample_timings()[0].rows, 16L);
}

// The shared foot objectives (MojoOptions::foot) in stage "cvae" on a walk's markers at 15 fps:
// the heel, toe and waist markers of the predicted future after the last observed frame, moving
// with the root steps the model predicts; logged by name, added in training on top of the loss
// the same draws make with the terms off.
TEST(Mojo, FootObjectivesOnThePredictedFuture) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::form_context(s, data::PoseForm::kMarkers, 0.3, 15.0);
  const Batch batch = nn::testing::walk_batch(s, ctx, 12);
  auto loss_of = [&](nlohmann::json cfg, bool training) {
    auto m = make(cfg, ctx);
    m->train(training);
    torch::manual_seed(4);
    return m->loss(batch);
  };
  auto on = family_info("mojo").tiny_config;
  on["foot_contact_weight"] = 2.0;
  on["bone_length_weight"] = 1.0;
  on["heel_speed_weight"] = 0.5;
  const LossTerms off = loss_of(family_info("mojo").tiny_config, true), with = loss_of(on, true);
  EXPECT_EQ(off.terms.count("planted_heel_mps"), 0u);
  const double planted = with.terms.at("planted_heel_mps").item<double>();
  const double bones = with.terms.at("bone_length_error_m").item<double>();
  const double heel = with.terms.at("heel_speed_error_mps").item<double>();
  EXPECT_GT(bones, 0.0);  // an untrained model's markers do not hold their distances
  EXPECT_NEAR(with.loss().item<double>(), off.loss().item<double>() + 2.0 * planted + bones + 0.5 * heel, 1e-4);
  EXPECT_EQ(loss_of(on, false).terms.count("bone_length_error_m"), 1u);  // logged outside training too
}
