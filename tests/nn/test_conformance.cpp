// The contract every registered family keeps, run over the registry (nn/registry.h) so that a new
// family is tested by being registered: its tiny config builds; configs round-trip; samples have
// the documented shapes and return the given control (families that take it) or a finite root
// motion of their own; the same seed gives the same motion and another seed another; streaming
// equals offline sampling where supported; a prefix is continued where supported; weights survive a
// save / load round trip; the loss is finite and has gradients.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include <unistd.h>

#include "core/error.h"
#include "nn/checkpoint.h"
#include "nn/model.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

ModelContext conformance_context() {
  ModelContext ctx = nn::testing::small_context(6, 3);
  ctx.num_content = 3;  // classifiers need labels; motion families may take them
  ctx.num_style = 2;
  ctx.fps = 20;
  ctx.pose_form = data::PoseForm::kPositions;
  return ctx;
}

std::shared_ptr<TrainableModel> build(const std::string& family) {
  torch::manual_seed(11);
  return create_trainable(family, family_info(family).tiny_config, conformance_context());
}

SampleRequest request(int64_t b, int64_t t, std::uint64_t seed) {
  torch::manual_seed(5);
  SampleRequest req;
  req.control = torch::randn({b, t, 3}) * 0.5;
  req.seed = seed;
  req.batch = static_cast<int>(b);
  return req;
}

Batch batch(int64_t b, int64_t t) {
  torch::manual_seed(3);
  Batch x = nn::testing::noisy_sinusoid_batch(b, t, 6);
  x.content = torch::tensor({0, 1, 2, -1}, torch::kInt64).narrow(0, 0, b);
  x.style = torch::tensor({1, 0, -1, 1}, torch::kInt64).narrow(0, 0, b);
  return x;
}

class FamilyConformance : public ::testing::TestWithParam<std::string> {};

TEST(Registry, HoldsTheBuiltInFamiliesAndRefusesUnknownOnes) {
  const auto motion = families_of_kind(FamilyKind::kMotion);
  EXPECT_GE(motion.size(), 2u);
  EXPECT_EQ(families_of_kind(FamilyKind::kClassifier), std::vector<std::string>{"classifier"});
  try {
    family_info("nosuchfamily");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("moglow"), std::string::npos) << "lists the known families";
  }
}

TEST_P(FamilyConformance, ConfigRoundTripsAndLossIsFiniteWithGradients) {
  auto m = build(GetParam());
  EXPECT_EQ(m->family(), GetParam());
  auto again = create_trainable(GetParam(), m->config(), conformance_context());
  EXPECT_EQ(again->config(), m->config());
  EXPECT_THROW(create_trainable(GetParam(), {{"no_such_option", 1}}, conformance_context()), Error);
  m->train();
  const LossTerms terms = m->loss(batch(4, 24));
  ASSERT_TRUE(terms.loss().defined());
  EXPECT_TRUE(std::isfinite(terms.loss().item<double>()));
  terms.loss().backward();
  double grad = 0;
  for (const auto& p : m->parameters())
    if (p.grad().defined()) grad += p.grad().abs().sum().item<double>();
  EXPECT_GT(grad, 0.0);
}

TEST_P(FamilyConformance, CheckpointRoundTrip) {
  auto m = build(GetParam());
  const auto path = std::filesystem::temp_directory_path() /
                    ("mosyn_conformance_" + GetParam() + std::to_string(::getpid()) + ".pt");
  CheckpointState state;
  state.step = 7;
  save_checkpoint(path.string(), *m, nullptr, state);
  torch::manual_seed(99);  // other initial weights
  auto loaded = create_trainable(GetParam(), m->config(), conformance_context());
  EXPECT_EQ(load_checkpoint(path.string(), *loaded, nullptr, torch::kCPU).step, 7);
  auto a = m->named_parameters(), b = loaded->named_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (const auto& kv : a) EXPECT_TRUE(torch::equal(kv.value(), b[kv.key()])) << kv.key();
  std::filesystem::remove(path);
}

TEST_P(FamilyConformance, SamplesFollowTheTraits) {
  if (family_info(GetParam()).kind != FamilyKind::kMotion) GTEST_SKIP() << "does not generate motion";
  auto m = std::dynamic_pointer_cast<MotionModel>(build(GetParam()));
  ASSERT_NE(m, nullptr);
  m->eval();
  const ModelTraits traits = m->traits();
  const SampleRequest req = request(2, 13, 4);
  const SampleOutput a = m->sample(req);
  ASSERT_EQ(a.pose.sizes(), (std::vector<int64_t>{2, 13, 6}));
  ASSERT_EQ(a.control.sizes(), (std::vector<int64_t>{2, 13, 3}));
  EXPECT_TRUE(torch::isfinite(a.pose).all().item<bool>());
  EXPECT_TRUE(torch::isfinite(a.control).all().item<bool>());
  if (traits.control == InputUse::kTakes) {
    EXPECT_TRUE(torch::equal(a.control, req.control));
  }
  EXPECT_TRUE(torch::equal(a.pose, m->sample(req).pose)) << "same seed, same motion";
  EXPECT_FALSE(torch::equal(a.pose[0], a.pose[1])) << "samples within a batch differ";
  SampleRequest other = req;
  other.seed = 5;
  EXPECT_FALSE(torch::equal(a.pose, m->sample(other).pose)) << "another seed, another motion";
  if (traits.prefix) {
    SampleRequest cont = req;
    cont.prefix_pose = torch::randn({2, 8, 6});
    cont.prefix_control = torch::randn({2, 8, 3});
    EXPECT_EQ(m->sample(cont).pose.sizes(), (std::vector<int64_t>{2, 13, 6}));
  }
}

TEST_P(FamilyConformance, StreamingEqualsOfflineWhereSupported) {
  if (family_info(GetParam()).kind != FamilyKind::kMotion) GTEST_SKIP() << "does not generate motion";
  auto m = std::dynamic_pointer_cast<MotionModel>(build(GetParam()));
  m->eval();
  const SampleRequest req = request(2, 9, 8);
  if (!m->traits().streaming) {
    EXPECT_THROW(m->begin_stream(req), Error);
    return;
  }
  const SampleOutput offline = m->sample(req);
  auto stream = m->begin_stream(req);
  const bool takes = m->traits().control == InputUse::kTakes;
  for (int64_t t = 0; t < 9; ++t) {
    const StreamFrame f = m->step_stream(*stream, takes ? req.control.select(1, t) : torch::Tensor());
    EXPECT_TRUE(torch::allclose(f.pose, offline.pose.select(1, t), 1e-5, 1e-5)) << "frame " << t;
    EXPECT_TRUE(torch::allclose(f.control, offline.control.select(1, t), 1e-5, 1e-5)) << "frame " << t;
  }
}

std::string name_of(const ::testing::TestParamInfo<std::string>& info) { return info.param; }

INSTANTIATE_TEST_SUITE_P(EveryRegisteredFamily, FamilyConformance, ::testing::ValuesIn(model_families()), name_of);

}  // namespace
