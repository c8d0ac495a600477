// Dynamic Future Net (nn/dfn): the FK layer against core FK, shapes, the KL terms against their
// closed form by hand, each stage's loss falling, seeds, the stages freezing what they should and
// a run interrupted in its second stage resuming exactly.
#include <gtest/gtest.h>
#include <torch/optim/adam.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include <unistd.h>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/rotation.h"
#include "data/representation.h"
#include "nn/checkpoint.h"
#include "nn/dfn/dfn.h"
#include "nn/kinematics.h"
#include "nn/registry.h"
#include "nn/training/train.h"
#include "foot_test_util.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;

namespace {

// A five-joint skeleton in centimetres: a spine of two bones and a leg of two.
Skeleton test_skeleton() {
  Skeleton s;
  s.joint_names = {"Hips", "Spine", "Head", "Leg", "Foot"};
  s.parents = {-1, 0, 1, 0, 3};
  s.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 10, 0), Eigen::Vector3d(0, 12, 2),
               Eigen::Vector3d(5, 0, 0), Eigen::Vector3d(0, -20, 1)};
  s.meters_per_unit = 0.01;
  return s;
}

ModelContext skeleton_context(data::PoseForm form) {
  ModelContext c;
  c.skeleton = test_skeleton();
  c.pose_form = form;
  c.layout = data::make_layout(c.skeleton, form, 0, Eigen::Vector3d(0, 0, 1));
  c.pose_dim = c.layout.pose_dim;
  c.control_dim = 3;
  c.fps = 30;
  c.stats.pose_mean.assign(c.pose_dim, 0.0f);
  c.stats.pose_std.assign(c.pose_dim, 1.0f);
  c.stats.control_mean.assign(3, 0.0f);
  c.stats.control_std.assign(3, 1.0f);
  return c;
}

nlohmann::json tiny() { return family_info("dfn").tiny_config; }

std::shared_ptr<DfnImpl> make(const ModelContext& c, nlohmann::json config = tiny()) {
  torch::manual_seed(3);
  return std::make_shared<DfnImpl>(DfnOptions::from_json(config), c);
}

Motion random_motion(const Skeleton& s, int frames, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  Motion m = Motion::rest(s, frames, 30);
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j)
      m.rotation(t, j) = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
  for (int t = 0; t < frames; ++t) m.translation(t, 0) = Eigen::Vector3d(n(rng) * 30, 90 + n(rng), n(rng) * 30);
  return m;
}

// Three 14-frame windows of small random standardised features (seed 4) for the loss tests.
Batch random_batch(const ModelContext& c) {
  Batch b;
  torch::manual_seed(4);
  b.pose = torch::randn({3, 14, c.pose_dim}) * 0.3;
  b.control = torch::randn({3, 14, c.control_dim}) * 0.3;
  return b;
}

double dist(const torch::Tensor& p, int a, int b) { return (p[a] - p[b]).norm().item<double>(); }

// The dynamics-stage loss of b under config with every prior term but the code likelihood off
// (kl, m and td weights 0), back-propagated under seed 6; returns the loss terms and sets
// *prior_gradient to the summed absolute gradient of p(f | h), p(m | f, h) and p(s | m, h).
LossTerms dynamics_without_prior_terms(const ModelContext& c, const Batch& b, nlohmann::json config,
                                       double* prior_gradient) {
  config["kl_weight"] = 0.0;
  config["m_weight"] = 0.0;
  config["td_weight"] = 0.0;
  auto m = make(c, config);
  m->begin_stage(2, m->training_stages(TrainStageDefaults{})[2]);
  torch::manual_seed(6);
  m->zero_grad();
  LossTerms out = m->loss(b);
  out.loss().backward();
  *prior_gradient = 0;
  for (auto* net : {&m->dyn->prior_f_net, &m->dyn->m_net, &m->dyn->prior_s_net})
    for (const auto& w : (*net)->parameters())
      if (w.grad().defined()) *prior_gradient += w.grad().abs().sum().item<double>();
  return out;
}

}  // namespace

TEST(Dfn, FkLayerMatchesCoreForwardKinematics) {
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  auto m = make(c);
  ASSERT_EQ(m->ae->head(), DfnPoseHead::kPositionsFk);
  const Skeleton s = c.skeleton;
  const Motion motion = random_motion(s, 4, 1);
  const WorldPoses ref = forward_kinematics(s, motion);
  const int j = s.num_joints();
  auto r6 = torch::zeros({4, j, 6}), root = torch::zeros({4, 3});
  for (int t = 0; t < 4; ++t) {
    for (int k = 0; k < j; ++k) {
      const auto v = rot6d_from_quat(motion.rotation(t, k));
      for (int e = 0; e < 6; ++e) r6[t][k][e] = v[e];
    }
    for (int e = 0; e < 3; ++e) root[t][e] = motion.translation(t, 0)[e] * s.meters_per_unit;
  }
  auto pos = m->ae->fk(r6, root);  // metres
  ASSERT_EQ(pos.sizes(), (std::vector<int64_t>{4, j, 3}));
  for (int t = 0; t < 4; ++t)
    for (int k = 0; k < j; ++k)
      for (int e = 0; e < 3; ++e)
        EXPECT_NEAR(pos[t][k][e].item<double>(), ref.position(t, k)[e] * s.meters_per_unit, 1e-5) << t << " " << k;
}

TEST(Dfn, RotationFeaturesGiveTheJointPositionsOfCoreFk) {
  // The FK positions the rotation form's Eq. 2 term compares: rotation features written by
  // data::encode give the pairwise joint distances of core FK (they are in the heading frame).
  const ModelContext c = skeleton_context(data::PoseForm::kRotations);
  auto m = make(c);
  ASSERT_EQ(m->ae->head(), DfnPoseHead::kRotationsFk);
  const Motion motion = random_motion(c.skeleton, 3, 2);
  std::vector<float> pose, control;
  data::encode(c.skeleton, motion, c.layout, &pose, &control);
  auto x = torch::tensor(pose).reshape({3, c.pose_dim});
  auto pos = m->ae->feature_positions(x);
  const WorldPoses ref = forward_kinematics(c.skeleton, motion);
  const int j = c.skeleton.num_joints();
  for (int t = 0; t < 3; ++t)
    for (int a = 0; a < j; ++a)
      for (int b = a + 1; b < j; ++b)
        EXPECT_NEAR(dist(pos[t], a, b), (ref.position(t, a) - ref.position(t, b)).norm() * 0.01, 1e-5);
}

TEST(Dfn, DecodedPosesKeepTheBoneLengths) {
  for (auto form : data::kPoseForms) {
    // Markers decode through a plain head (the marker fit restores the rotations, tested there).
    if (form == data::PoseForm::kMarkers) continue;
    const ModelContext c = skeleton_context(form);
    auto m = make(c);
    auto d = m->ae->decode(torch::randn({2, 5, 6}));
    ASSERT_EQ(d.pose.sizes(), (std::vector<int64_t>{2, 5, c.pose_dim}));
    ASSERT_EQ(d.control.sizes(), (std::vector<int64_t>{2, 5, 3}));
    auto pos = m->ae->feature_positions(d.pose).reshape({10, 5, 3});
    for (int i = 0; i < 10; ++i)
      for (int k = 1; k < 5; ++k)
        EXPECT_NEAR(dist(pos[i], k, c.skeleton.parents[k]), c.skeleton.offsets[k].norm() * 0.01, 1e-5)
            << data::to_string(form) << " joint " << k;
  }
}

TEST(Dfn, ShapesOfCodesWindowsLossesAndSamples) {
  const ModelContext c = nn::testing::small_context(6, 3);
  auto m = make(c);
  EXPECT_EQ(m->ae->head(), DfnPoseHead::kPlain);  // no skeleton: the plain decoder
  const Batch b = nn::testing::noisy_sinusoid_batch(3, 12, 6);
  auto z = m->codes(b.pose, b.control);
  EXPECT_EQ(z.sizes(), (std::vector<int64_t>{3, 12, 6}));
  auto w = m->future_windows(z);  // H = 3
  ASSERT_EQ(w.sizes(), (std::vector<int64_t>{3, 9, 3, 6}));
  EXPECT_TRUE(torch::equal(w[1][4], z[1].narrow(0, 5, 3)));  // frames t+1..t+H of t = 4
  EXPECT_EQ(m->future->embed(w.reshape({-1, 3, 6})).sizes(), (std::vector<int64_t>{27, 4}));
  EXPECT_TRUE(std::isfinite(m->loss(b).loss().item<double>()));  // before any stage: all three
  const auto stages = m->training_stages(TrainStageDefaults{});
  for (int s = 0; s < 3; ++s) {
    m->begin_stage(s, stages[s]);
    EXPECT_TRUE(std::isfinite(m->loss(b).loss().item<double>())) << s;
  }
  EXPECT_THROW(m->loss(nn::testing::noisy_sinusoid_batch(2, 3, 6)), Error);  // T <= H
  SampleRequest r;
  r.control = torch::zeros({2, 7, 3});
  r.prefix_pose = torch::randn({2, 5, 6});
  auto out = m->sample(r);
  EXPECT_EQ(out.pose.sizes(), (std::vector<int64_t>{2, 7, 6}));
  EXPECT_EQ(out.control.sizes(), (std::vector<int64_t>{2, 7, 3}));
  const ModelTraits t = m->traits();
  EXPECT_EQ(t.control, InputUse::kGenerates);
  EXPECT_FALSE(t.labels);
  EXPECT_TRUE(t.prefix);
}

TEST(Dfn, KlAndLogDensityMatchTheClosedFormByHand) {
  // KL(N(1, 0.5^2) || N(-0.5, 2^2)) = log(2 / 0.5) + (0.25 + 1.5^2) / (2 * 4) - 1/2, and a
  // second dimension with equal Gaussians adds 0.
  auto qm = torch::tensor({1.0, 0.3}, torch::kFloat64), qlv = torch::tensor({std::log(0.25), 0.2}, torch::kFloat64);
  auto pm = torch::tensor({-0.5, 0.3}, torch::kFloat64), plv = torch::tensor({std::log(4.0), 0.2}, torch::kFloat64);
  const double expected = std::log(4.0) + (0.25 + 2.25) / 8.0 - 0.5;
  EXPECT_NEAR(diagonal_gaussian_kl(qm, qlv, pm, plv).item<double>(), expected, 1e-12);
  EXPECT_NEAR(diagonal_gaussian_kl(qm, qlv, qm, qlv).item<double>(), 0.0, 1e-12);
  // Monte Carlo agrees: E_q[log q - log p].
  torch::manual_seed(1);
  auto x = qm + torch::exp(0.5 * qlv) * torch::randn({200000, 2}, torch::kFloat64);
  const double mc = (diagonal_gaussian_log_density(x, qm, qlv) - diagonal_gaussian_log_density(x, pm, plv)).mean().item<double>();
  EXPECT_NEAR(mc, expected, 0.01);
  // log N(0.5; 1, 0.25) = -0.5 log(2 pi 0.25) - 0.25 / (2 * 0.25)
  auto one = torch::tensor({0.5}, torch::kFloat64);
  EXPECT_NEAR(diagonal_gaussian_log_density(one, torch::tensor({1.0}, torch::kFloat64), torch::tensor({std::log(0.25)}, torch::kFloat64))
                  .item<double>(),
              -0.5 * std::log(2 * M_PI * 0.25) - 0.5, 1e-12);
}

TEST(Dfn, EachStageLossFalls) {
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  auto m = make(c);
  m->train();
  torch::manual_seed(4);
  Batch b;
  b.pose = torch::randn({4, 12, c.pose_dim}) * 0.3;
  b.control = torch::randn({4, 12, 3}) * 0.3;
  const std::vector<std::string> prefixes = {"ae.", "future.", "dyn."};
  const auto stages = m->training_stages(TrainStageDefaults{});
  for (int s = 0; s < 3; ++s) {
    m->begin_stage(s, stages[s]);
    std::vector<torch::Tensor> params;
    for (const auto& kv : m->named_parameters())
      if (kv.key().rfind(prefixes[s], 0) == 0) params.push_back(kv.value());
    torch::optim::Adam opt(params, torch::optim::AdamOptions(1e-2));
    torch::manual_seed(5);
    const double first = m->loss(b).loss().item<double>();
    for (int i = 0; i < 80; ++i) {
      opt.zero_grad();
      m->loss(b).loss().backward();
      opt.step();
    }
    torch::manual_seed(5);
    const double last = m->loss(b).loss().item<double>();
    EXPECT_LT(last, 0.8 * first) << "stage " << s << ": " << first << " -> " << last;
  }
}

TEST(Dfn, SeedsTemperatureAndLongOpenLoopSamples) {
  const ModelContext c = skeleton_context(data::PoseForm::kRotations);
  auto m = make(c);
  m->eval();
  SampleRequest r;
  r.control = torch::zeros({2, 30, 3});
  r.prefix_pose = torch::randn({2, 8, c.pose_dim});
  r.seed = 1;
  auto a = m->sample(r), again = m->sample(r);
  EXPECT_TRUE(torch::equal(a.pose, again.pose));
  EXPECT_TRUE(torch::equal(a.control, again.control));
  SampleRequest other = r;
  other.seed = 2;
  EXPECT_FALSE(torch::equal(a.pose, m->sample(other).pose));
  // Temperature 0: every latent is its mean, so the seed no longer matters.
  r.temperature = other.temperature = 0;
  EXPECT_TRUE(torch::equal(m->sample(r).pose, m->sample(other).pose));
  // 900 frames open loop without a prefix: finite, and the decoded rotations are rotations.
  SampleRequest longer;
  longer.control = torch::zeros({1, 900, 3});
  longer.seed = 3;
  auto l = m->sample(longer);
  EXPECT_TRUE(torch::isfinite(l.pose).all().item<bool>());
  EXPECT_TRUE(torch::isfinite(l.control).all().item<bool>());
  auto pos = m->ae->feature_positions(l.pose[0]);
  EXPECT_NEAR(dist(pos[899], 4, 3), 0.2002498, 1e-5);
}

TEST(Dfn, StreamingAfterAPrefixEqualsOfflineSampling) {
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  auto m = make(c);
  m->eval();
  SampleRequest r;
  r.control = torch::zeros({2, 6, 3});
  r.prefix_pose = torch::randn({2, 7, c.pose_dim});
  r.prefix_control = torch::randn({2, 7, 3});
  r.seed = 12;
  r.temperature = 0.7;
  const SampleOutput offline = m->sample(r);
  auto stream = m->begin_stream(r);
  for (int t = 0; t < 6; ++t) {
    const StreamFrame f = m->step_stream(*stream, {});
    EXPECT_TRUE(torch::equal(f.pose, offline.pose.select(1, t))) << t;
    EXPECT_TRUE(torch::equal(f.control, offline.control.select(1, t))) << t;
  }
  // The prefix matters.
  SampleRequest other = r;
  other.prefix_pose = r.prefix_pose + 0.5;
  EXPECT_FALSE(torch::equal(m->sample(other).pose, offline.pose));
}

// ---------------------------------------------------------------------------------------------
// Through the shared trainer.

namespace {

using Snapshot = std::map<std::string, torch::Tensor>;

TrainOptions dfn_options(const fs::path& dir) {
  TrainOptions o;
  o.family = "dfn";
  o.out_dir = dir.string();
  o.model_config = tiny();
  o.model_config["stage_steps"] = {4, 4, 4};
  o.steps = 12;
  o.batch = 4;
  o.lr = 1e-2;
  o.warmup = 2;
  o.threads = 1;
  o.checkpoint_every = 4;
  o.validate_every = 4;
  o.log_every = 1;
  o.seed = 9;
  return o;
}

fs::path run_dir(const std::string& name) {
  auto p = fs::temp_directory_path() / ("mosyn_dfn_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

Snapshot checkpoint_tensors(const fs::path& run, const ModelContext& c) {
  auto m = make(c, dfn_options(run).model_config);
  load_checkpoint((run / "checkpoint.pt").string(), *m, nullptr, torch::kCPU);
  Snapshot s;
  for (const auto& kv : m->named_parameters()) s[kv.key()] = kv.value().detach().clone();
  return s;
}

bool same_under(const Snapshot& a, const Snapshot& b, const std::string& prefix) {
  for (const auto& [name, t] : a)
    if (name.rfind(prefix, 0) == 0 && !torch::equal(t, b.at(name))) return false;
  return true;
}

ModelContext dataset_context(const data::Dataset& ds) {
  ModelContext c = nn::testing::small_context(nn::testing::kDim, 3);
  c.fps = ds.info().fps;
  c.pose_form = ds.info().layout.form;
  c.skeleton = ds.info().skeleton;
  c.layout = ds.info().layout;
  c.stats = ds.stats();
  return c;
}

// Trains until just before step `stop_before` (0 = to the end); returns the checkpoint.
Snapshot train_until(const fs::path& dir, const data::Dataset& ds, int stop_before) {
  int calls = 0;
  TrainCallbacks cb;
  if (stop_before > 0) cb.should_stop = [&] { return ++calls == stop_before; };
  train(dfn_options(dir), ds, cb);
  return checkpoint_tensors(dir, dataset_context(ds));
}

}  // namespace

TEST(Dfn, TheThreeStagesTrainAndFreezeWhatTheyShould) {
  auto m = make(nn::testing::small_context());
  TrainStageDefaults d;
  d.steps = 1000;
  const auto stages = m->training_stages(d);
  ASSERT_EQ(stages.size(), 3u);
  EXPECT_EQ(stages[0].steps + stages[1].steps + stages[2].steps, 1000);
  EXPECT_EQ(stages[0].steps, 300);
  EXPECT_EQ(stages[1].frozen, (std::vector<std::string>{"ae"}));
  EXPECT_EQ(stages[2].frozen, (std::vector<std::string>{"ae", "future"}));
  EXPECT_EQ(stages[2].trained, (std::vector<std::string>{"dyn"}));

  const auto ds = nn::testing::synthetic_dataset();
  const auto dir = run_dir("freeze");
  const Snapshot after_ae = train_until(dir, ds, 5);
  fs::remove_all(dir);
  const Snapshot after_future = train_until(dir, ds, 9);
  fs::remove_all(dir);
  const Snapshot end = train_until(dir, ds, 0);
  EXPECT_FALSE(same_under(after_ae, after_future, "future."));
  EXPECT_TRUE(same_under(after_ae, after_future, "ae."));
  EXPECT_TRUE(same_under(after_ae, after_future, "dyn."));
  EXPECT_FALSE(same_under(after_future, end, "dyn."));
  EXPECT_TRUE(same_under(after_future, end, "ae."));
  EXPECT_TRUE(same_under(after_future, end, "future."));
  fs::remove_all(dir);
}

TEST(Dfn, ZeroStageStepsSkipTrainedStages) {
  auto config = tiny();
  config["stage_steps"] = {0, 0, 7};
  auto m = make(nn::testing::small_context(), config);
  const auto stages = m->training_stages(TrainStageDefaults{});
  ASSERT_EQ(stages.size(), 1u);
  EXPECT_EQ(stages[0].name, "dynamics");
  EXPECT_EQ(stages[0].steps, 7);
  m->begin_stage(0, stages[0]);  // the trainer's index 0 is the family's third stage
  EXPECT_EQ(m->stage(), 2);
  TrainingStage unknown;
  unknown.name = "warm-up";
  EXPECT_THROW(m->begin_stage(0, unknown), Error);
  config["stage_steps"] = {0, 0, 0};
  EXPECT_THROW(DfnOptions::from_json(config), Error);
  config["stage_steps"] = {3, -1, 2};
  EXPECT_THROW(DfnOptions::from_json(config), Error);
}

TEST(Dfn, FreeNatsFloorEachKlTermInTheLoss) {
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  const Batch b = random_batch(c);
  for (double free : {0.0, 0.05, 1e3}) {
    auto config = tiny();
    config["kl_free_nats"] = free;
    config["kl_weight"] = 0.7;
    auto m = make(c, config);
    m->begin_stage(2, m->training_stages(TrainStageDefaults{})[2]);
    torch::manual_seed(6);
    const LossTerms out = m->loss(b);
    auto term = [&](const char* k) { return out.terms.at(k).item<double>(); };
    const double expected = term("nll_z") + term("nll_m") +
                            0.7 * (std::max(term("kl_s"), free) + std::max(term("kl_f"), free)) + term("td_kl") +
                            term("td_nll");
    EXPECT_NEAR(out.loss().item<double>(), expected, 1e-4 * std::max(1.0, std::abs(expected))) << "free " << free;
    if (free == 1e3) {
      // Both terms are under this budget, so the floor, not the KL, is what entered the loss.
      EXPECT_LT(term("kl_s"), free);
      EXPECT_LT(term("kl_f"), free);
    }
  }
}

TEST(Dfn, PriorRolloutAdvancesTheStateWithThePriorsDraws) {
  // With only the code likelihood in the loss, the priors p(f | h), p(m | f, h) and p(s | m, h)
  // can receive a gradient only through states that their draws advanced: none at prior_rollout
  // 0, some at 1.
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  const Batch b = random_batch(c);
  auto prior_gradient = [&](double p) {
    auto config = tiny();
    config["prior_rollout"] = p;
    double g = 0;
    dynamics_without_prior_terms(c, b, config, &g);
    return g;
  };
  EXPECT_EQ(prior_gradient(0.0), 0.0);
  EXPECT_GT(prior_gradient(1.0), 1e-6);
  auto bad = tiny();
  bad["prior_rollout"] = 1.5;
  EXPECT_THROW(DfnOptions::from_json(bad), Error);
}

TEST(Dfn, WindowSpeedsOfKnownMotion) {
  // Root: dx 0.03, dz 0.04 standardised, de-standardised with mean (0.01, 0) and std (2, 1):
  // (0.07, 0.04) m per frame at 30 fps. Body: of two joints one moves 0.1 m a frame, one stands.
  ModelContext c = skeleton_context(data::PoseForm::kPositions);
  c.stats.control_mean = {0.01f, 0.0f, 0.0f};
  c.stats.control_std = {2.0f, 1.0f, 1.0f};
  auto m = make(c);
  auto control = torch::zeros({1, 3, 3});
  control.select(2, 0).fill_(0.03);
  control.select(2, 1).fill_(0.04);
  auto positions = torch::zeros({1, 3, 2, 3});
  for (int t = 0; t < 3; ++t) positions[0][t][0][0] = 0.1 * t;
  const auto w = m->window_speeds(control, positions);
  EXPECT_NEAR(w.root_mps.item<double>(), std::sqrt(0.07 * 0.07 + 0.04 * 0.04) * 30, 1e-4);
  EXPECT_NEAR(w.body_mps.item<double>(), 0.1 * 30 / 2, 3e-3);  // the still joint: sqrt(1e-8) m a frame
}

TEST(Dfn, RolloutSpeedTermEntersTheLossAndReachesThePriors) {
  // With only the code likelihood and the speed term in the loss, the priors receive a gradient
  // only through the open-loop frames: none at weight 0, some at 2; the loss grows by exactly
  // weight x term (the posterior pass draws the same numbers under one seed).
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  const Batch b = random_batch(c);
  auto run = [&](double weight, double* prior_gradient) {
    auto config = tiny();
    config["rollout_speed_weight"] = weight;
    config["rollout_frames"] = 5;
    return dynamics_without_prior_terms(c, b, config, prior_gradient);
  };
  double g0 = 0, g2 = 0;
  const LossTerms off = run(0.0, &g0), on = run(2.0, &g2);
  EXPECT_EQ(off.terms.count("rollout_speed"), 0u);
  ASSERT_EQ(on.terms.count("rollout_speed"), 1u);
  const double term = on.terms.at("rollout_speed").item<double>();
  EXPECT_TRUE(std::isfinite(term));
  EXPECT_GT(term, 0.0);
  EXPECT_NEAR(on.loss().item<double>(), off.loss().item<double>() + 2 * term, 1e-4 * (1 + std::abs(term)));
  EXPECT_EQ(g0, 0.0);
  EXPECT_GT(g2, 1e-6);
  auto bad = tiny();
  bad["rollout_frames"] = 1;
  EXPECT_THROW(DfnOptions::from_json(bad), Error);
}

TEST(Dfn, RolloutSpeedToleranceOnlyPenalisesSpeedsOutsideItsBand) {
  // The same draws under one seed: a band wider than any ratio zeroes the term and the priors'
  // gradient; a band of 1 is exact matching; a band between gives a term between.
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  const Batch b = random_batch(c);
  auto run = [&](double tolerance, double* prior_gradient) {
    auto config = tiny();
    config["rollout_speed_weight"] = 1.0;
    config["rollout_frames"] = 5;
    config["rollout_speed_tolerance"] = tolerance;
    return dynamics_without_prior_terms(c, b, config, prior_gradient).terms.at("rollout_speed").item<double>();
  };
  double g_exact = 0, g_mid = 0, g_wide = 0;
  const double exact = run(1.0, &g_exact), mid = run(1.05, &g_mid), wide = run(1e6, &g_wide);
  EXPECT_GT(exact, 0.0);
  EXPECT_GT(g_exact, 1e-6);
  EXPECT_LT(mid, exact);
  EXPECT_EQ(wide, 0.0);
  EXPECT_EQ(g_wide, 0.0);
  auto bad = tiny();
  bad["rollout_speed_tolerance"] = 0.9;
  EXPECT_THROW(DfnOptions::from_json(bad), Error);
}

TEST(Dfn, ObservationLogVarianceFloorBoundsTheCodeAndFutureTerms) {
  // log p(z | s, h) by hand: -1/2 sum(log 2 pi + lv + (z - mean)^2 / e^lv), lv the floored
  // variance; below the floor no gradient reaches the log-variance parameter.
  auto config = tiny();
  for (double floor : {-8.0, -1.0}) {
    config["observation_logvar_min"] = floor;
    const DfnOptions o = DfnOptions::from_json(config);
    torch::manual_seed(2);
    DfnDynamics dyn(o);
    {
      torch::NoGradGuard no_grad;
      dyn->z_logvar.fill_(-20.0);
      dyn->m_logvar.fill_(0.5);
    }
    auto s = torch::randn({4, o.current_latent}), f = torch::randn({4, o.future_latent});
    auto h = torch::randn({4, o.state}), z = torch::randn({4, o.code}), m = torch::randn({4, o.future});
    const double lv_z = std::max(floor, 8.0 * std::tanh(-20.0 / 8.0)), lv_m = 8.0 * std::tanh(0.5 / 8.0);
    auto by_hand = [](const torch::Tensor& x, const torch::Tensor& mean, double lv) {
      return (-0.5 * (std::log(2 * M_PI) + lv + (x - mean).pow(2) / std::exp(lv))).sum(-1);
    };
    auto lpz = dyn->log_p_z(z, s, h), lpm = dyn->log_p_m(m, f, h);
    EXPECT_TRUE(torch::allclose(lpz, by_hand(z, dyn->decode_z(s, h), lv_z), 1e-4, 1e-3)) << "floor " << floor;
    EXPECT_TRUE(torch::allclose(lpm, by_hand(m, dyn->decode_m(f, h), lv_m), 1e-4, 1e-3)) << "floor " << floor;
    (lpz.sum() + lpm.sum()).backward();
    const double g_z = dyn->z_logvar.grad().abs().sum().item<double>();
    if (floor > -8.0) {
      EXPECT_EQ(g_z, 0.0);
    } else {
      EXPECT_GT(g_z, 0.0);
    }
    EXPECT_GT(dyn->m_logvar.grad().abs().sum().item<double>(), 0.0);  // above the floor: learns
  }
  // The TD prediction's log-variances (about 0 at initialisation) are floored in the loss too.
  const ModelContext c = skeleton_context(data::PoseForm::kPositions);
  const Batch b = random_batch(c);
  for (double floor : {-8.0, 2.0}) {
    config["observation_logvar_min"] = floor;
    auto m = make(c, config);
    m->begin_stage(2, m->training_stages(TrainStageDefaults{})[2]);
    torch::manual_seed(6);
    const double td_logvar = m->loss(b).terms.at("td_logvar").item<double>();
    if (floor > -8.0) {
      EXPECT_NEAR(td_logvar, floor, 1e-6);
    } else {
      EXPECT_LT(std::abs(td_logvar), 1.0);
    }
  }
}

TEST(Dfn, InterruptedInTheSecondStageResumesExactly) {
  const auto ds = nn::testing::synthetic_dataset();
  const auto full = run_dir("full");
  const Snapshot expected = train_until(full, ds, 0);
  const auto dir = run_dir("stop");
  int calls = 0;
  TrainCallbacks cb;
  cb.should_stop = [&] { return ++calls == 7; };  // stage 2, after 2 of its 4 steps
  const TrainResult first = train(dfn_options(dir), ds, cb);
  EXPECT_TRUE(first.stopped_early);
  EXPECT_EQ(first.step, 6);
  auto o = dfn_options(dir);
  o.resume = true;
  EXPECT_EQ(train(o, ds).step, 12);
  const Snapshot got = checkpoint_tensors(dir, dataset_context(ds));
  for (const auto& [name, t] : expected) EXPECT_TRUE(torch::equal(t, got.at(name))) << name;
  fs::remove_all(dir);
  fs::remove_all(full);
}

TEST(Dfn, LabelsConditionTheDynamicsAndAWarmStartFromAnUnlabelledRunStartsAsIt) {
  ModelContext c = skeleton_context(data::PoseForm::kPositions);
  c.num_content = 3;
  c.num_style = 2;
  auto plain = make(c);
  plain->eval();
  EXPECT_FALSE(plain->traits().labels);
  auto config = tiny();
  config["labels"] = true;
  auto labelled = make(c, config);
  labelled->eval();
  EXPECT_TRUE(labelled->traits().labels);
  // Every declared label block lies at the end of its parameter's input axis, 5 columns wide.
  const auto params = labelled->named_parameters();
  ASSERT_EQ(labelled->label_inputs().size(), 5u);
  for (const LabelInput& in : labelled->label_inputs()) {
    ASSERT_NE(params.find(in.parameter), nullptr) << in.parameter;
    EXPECT_EQ(params[in.parameter].size(in.axis), in.offset + 5) << in.parameter;
  }
  // A warm start from the unlabelled model grows the five labelled inputs with zero columns: with
  // any label it then generates exactly what the unlabelled model does.
  const fs::path dir = run_dir("labels");
  fs::create_directories(dir);
  save_checkpoint((dir / "checkpoint.pt").string(), *plain, nullptr, CheckpointState{});
  const InitReport report = init_from_checkpoint((dir / "checkpoint.pt").string(), *labelled, torch::kCPU);
  EXPECT_EQ(report.grown.size(), 5u);
  EXPECT_TRUE(report.missing.empty());
  SampleRequest r;
  r.control = torch::zeros({3, 12, 3});
  r.prefix_pose = torch::randn({3, 6, c.pose_dim});
  r.seed = 4;
  const SampleOutput unlabelled = plain->sample(r);
  SampleRequest with = r;
  with.content = torch::tensor({0, 2, -1}, torch::kInt64);
  with.style = torch::tensor({1, -1, 0}, torch::kInt64);
  EXPECT_TRUE(torch::equal(labelled->sample(with).pose, unlabelled.pose));
  // Once the label columns are trained (here: set), a label changes the motion and "none" (-1)
  // equals no label at all.
  {
    torch::NoGradGuard no_grad;
    for (const LabelInput& in : labelled->label_inputs())
      params[in.parameter].narrow(in.axis, in.offset, 5).normal_(0, 1);
  }
  const SampleOutput conditioned = labelled->sample(with);
  const SampleOutput none = labelled->sample(r);
  EXPECT_FALSE(torch::equal(conditioned.pose.select(0, 0), none.pose.select(0, 0)));
  SampleRequest all_none = r;
  all_none.content = torch::full({3}, -1, torch::kInt64);
  EXPECT_TRUE(torch::equal(labelled->sample(all_none).pose, none.pose));
  // The dynamics loss takes the batch's labels (and drops some in training).
  labelled->begin_stage(2, labelled->training_stages(TrainStageDefaults{})[2]);
  Batch b = random_batch(c);
  b.content = torch::tensor({0, 1, 2}, torch::kInt64);
  b.style = torch::tensor({-1, 0, 1}, torch::kInt64);
  EXPECT_TRUE(std::isfinite(labelled->loss(b).loss().item<double>()));
  // A label outside the vocabulary is an error, not an index out of bounds.
  SampleRequest bad = r;
  bad.content = torch::tensor({0, 3, 1}, torch::kInt64);
  EXPECT_THROW(labelled->sample(bad), Error);
  fs::remove_all(dir);
}

// The shared foot objectives (DfnOptions::foot) on a walk in the rotations form: on the
// autoencoder's reconstruction in its stage, on the frames decoded from the posterior's codes in the
// dynamics stage, each with the root steps the model decodes; logged by name and added in
// training on top of the loss the same draws make with the terms off.
TEST(Dfn, FootObjectivesInTheAutoencoderAndDynamicsStages) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::form_context(s, data::PoseForm::kRotations);
  const Batch batch = nn::testing::walk_batch(s, ctx, 16);
  auto on = tiny();
  on["foot_contact_weight"] = 2.0;
  on["pelvis_follow_weight"] = 1.0;
  for (int stage : {0, 2}) {
    auto loss_of = [&](const nlohmann::json& cfg) {
      auto m = make(ctx, cfg);
      m->begin_stage(stage, m->training_stages(TrainStageDefaults{})[stage]);
      m->train(true);
      torch::manual_seed(4);
      return m->loss(batch);
    };
    const LossTerms off = loss_of(tiny()), with = loss_of(on);
    EXPECT_EQ(off.terms.count("planted_heel_mps"), 0u);
    const double planted = with.terms.at("planted_heel_mps").item<double>();
    const double pelvis = with.terms.at("pelvis_offset_m").item<double>();
    EXPECT_GT(planted + pelvis, 0.0) << "stage " << stage;
    EXPECT_NEAR(with.loss().item<double>(), off.loss().item<double>() + 2.0 * planted + pelvis, 1e-4)
        << "stage " << stage;
  }
  // The future stage has no frames of its own to read: nothing logged.
  auto m = make(ctx, on);
  m->begin_stage(1, m->training_stages(TrainStageDefaults{})[1]);
  EXPECT_EQ(m->loss(batch).terms.count("planted_heel_mps"), 0u);
}

// The phase-free foot terms on the open-loop rollout (rollout_stance_weight and the others): the
// frames drawn from the priors after the window, against the window's last frames. Logged with the
// "rollout_" prefix, each added times its weight on top of the loss the same draws make without
// them, and they reach the priors (the only way the prior networks get a gradient here); written
// back only when on, and a negative weight is refused.
TEST(Dfn, RolloutFootTermsEnterTheLossAndReachThePriors) {
  const Skeleton s = make_synthetic_biped();
  const ModelContext ctx = nn::testing::form_context(s, data::PoseForm::kRotations);
  const Batch batch = nn::testing::walk_batch(s, ctx, 16);
  auto run = [&](const nlohmann::json& cfg, double* prior_gradient) {
    return dynamics_without_prior_terms(ctx, batch, cfg, prior_gradient);
  };
  auto on = tiny();
  on["rollout_frames"] = 8;
  on["rollout_speed_distribution_weight"] = 2.0;
  on["rollout_toe_slide_weight"] = 1.0;
  auto off = tiny();
  off["rollout_frames"] = 8;
  double g_off = 0, g_on = 0;
  const LossTerms without = run(off, &g_off), with = run(on, &g_on);
  EXPECT_EQ(without.terms.count("rollout_speed_distribution_mps"), 0u);
  ASSERT_EQ(with.terms.count("rollout_speed_distribution_mps"), 1u);
  ASSERT_EQ(with.terms.count("rollout_toe_slide_mps"), 1u);
  EXPECT_EQ(with.terms.count("speed_distribution_mps"), 0u);  // the posterior frames' terms stay off
  const double dist = with.terms.at("rollout_speed_distribution_mps").item<double>();
  const double toe = with.terms.at("rollout_toe_slide_mps").item<double>();
  EXPECT_GT(dist, 0.0);
  EXPECT_NEAR(with.loss().item<double>(), without.loss().item<double>() + 2.0 * dist + toe, 1e-4 * (1 + dist));
  EXPECT_EQ(g_off, 0.0);
  EXPECT_GT(g_on, 1e-8);
  const auto o = DfnOptions::from_json(on);
  EXPECT_EQ(o.rollout_foot().speed_distribution_weight, 2.0);
  EXPECT_EQ(o.rollout_foot().foot_contact_weight, 0.0);
  EXPECT_EQ(o.to_json().at("rollout_speed_distribution_weight"), 2.0);
  EXPECT_EQ(DfnOptions::from_json(tiny()).to_json().count("rollout_stance_weight"), 0u);
  auto bad = tiny();
  bad["rollout_stance_weight"] = -1.0;
  EXPECT_THROW(DfnOptions::from_json(bad), Error);
}
