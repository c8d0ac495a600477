// Staged training (nn/training/stage.h): frozen modules stay fixed and in eval mode, each stage
// gets a fresh optimiser, a run interrupted inside a later stage resumes exactly, and one-stage
// families train step for step as before stages existed.
#include <gtest/gtest.h>
#include <torch/nn/modules/batchnorm.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/linear.h>
#include <torch/optim/adam.h>
#include <torch/optim/sgd.h>
#include <torch/utils.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include <unistd.h>

#include "core/error.h"
#include "nn/checkpoint.h"
#include "nn/registry.h"
#include "nn/training/train.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;
using nn::testing::kDim;

namespace {

fs::path stage_dir(const std::string& name) {
  auto p = fs::temp_directory_path() / ("mosyn_stages_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

using Snapshot = std::map<std::string, torch::Tensor>;

Snapshot snapshot(torch::nn::Module& m) {
  Snapshot s;
  for (const auto& kv : m.named_parameters()) s[kv.key()] = kv.value().detach().clone();
  for (const auto& kv : m.named_buffers()) s[kv.key()] = kv.value().detach().clone();
  return s;
}

// Whether every tensor whose name starts with prefix is equal in a and b.
bool same_under(const Snapshot& a, const Snapshot& b, const std::string& prefix) {
  for (const auto& [name, t] : a)
    if (name.rfind(prefix, 0) == 0 && !torch::equal(t, b.at(name))) return false;
  return true;
}

// A tiny two-stage family: an autoencoder (encoder with batch norm, head) trained first with the
// prior frozen, then the prior on the frozen encoder's codes with SGD and a cosine schedule.
class TwoStageModel : public TrainableModel {
 public:
  explicit TwoStageModel(nlohmann::json config) : TrainableModel("TwoStageModel"), config_(std::move(config)) {
    encoder = register_module("encoder", torch::nn::Sequential(torch::nn::Linear(kDim, 4), torch::nn::BatchNorm1d(4)));
    head = register_module("head", torch::nn::Linear(4, kDim));
    prior = register_module("prior", torch::nn::Linear(4, 4));
  }
  std::string family() const override { return "test_two_stage"; }
  nlohmann::json config() const override { return config_; }

  std::vector<TrainingStage> training_stages(const TrainStageDefaults& d) const override {
    TrainingStage a;
    a.name = "autoencoder";
    a.steps = d.steps / 2;
    a.frozen = {"prior"};
    a.optimizer.lr = d.lr;
    a.schedule.warmup = d.warmup;
    TrainingStage b;
    b.name = "prior";
    b.steps = d.steps - a.steps;
    b.trained = {config_.value("bad_prefix", false) ? "priors" : "prior"};
    b.frozen = {"encoder"};
    b.optimizer.kind = OptimizerSpec::Kind::kSgd;
    b.optimizer.lr = 0.05;
    b.optimizer.momentum = 0.9;
    b.schedule.kind = ScheduleSpec::Kind::kCosine;
    b.schedule.warmup = 2;
    return {a, b};
  }

  void begin_stage(int index, const TrainingStage& stage) override {
    begun.push_back(index);
    at_begin[index] = snapshot(*this);
  }

  LossTerms loss(const Batch& batch) override {
    const int64_t b = batch.pose.size(0), t = batch.pose.size(1);
    auto x = batch.pose.reshape({-1, kDim});
    auto z = encoder->forward(x);
    auto recon = (head->forward(z) - x).pow(2).mean();
    auto codes = z.reshape({b, t, 4});
    auto pred = prior->forward(codes.narrow(1, 0, t - 1));
    auto prior_term = (pred - codes.narrow(1, 1, t - 1).detach()).pow(2).mean();
    if (is_training()) {
      encoder_training.push_back(encoder->is_training());
      head_requires_grad.push_back(head->weight.requires_grad());
    }
    return LossTerms{{{"loss", recon + prior_term}, {"recon", recon.detach()}}};
  }

  torch::nn::Sequential encoder{nullptr};
  torch::nn::Linear head{nullptr}, prior{nullptr};
  std::vector<int> begun;
  std::map<int, Snapshot> at_begin;
  std::vector<bool> encoder_training, head_requires_grad;

 private:
  nlohmann::json config_;
};

std::shared_ptr<TwoStageModel> g_last;  // the model the last training built

void register_two_stage() {
  register_family(FamilyInfo{"test_two_stage", FamilyKind::kClassifier, "test: two training stages",
                             [](const nlohmann::json& config, const ModelContext&) {
                               g_last = std::make_shared<TwoStageModel>(config);
                               return g_last;
                             }});
}

TrainOptions two_stage_options(const fs::path& dir) {
  TrainOptions o;
  o.family = "test_two_stage";
  o.out_dir = dir.string();
  o.steps = 12;  // 6 + 6
  o.batch = 4;
  o.lr = 1e-2;
  o.warmup = 3;
  o.threads = 1;
  o.checkpoint_every = 4;
  o.validate_every = 4;
  o.log_every = 1;
  o.seed = 9;
  return o;
}

// The model tensors a checkpoint holds.
Snapshot checkpoint_tensors(const fs::path& run) {
  TwoStageModel m(nlohmann::json::object());
  load_checkpoint((run / "checkpoint.pt").string(), m, nullptr, torch::kCPU);
  return snapshot(m);
}

}  // namespace

TEST(Stages, FrozenModulesStayFixedAndInEvalModeTrainedOnesMove) {
  register_two_stage();
  const auto ds = nn::testing::synthetic_dataset();
  const auto dir = stage_dir("freeze");
  std::vector<TrainProgress> progress;
  std::vector<std::string> messages;
  TrainCallbacks cb;
  cb.on_progress = [&](const TrainProgress& p) { progress.push_back(p); };
  cb.on_message = [&](const std::string& m) { messages.push_back(m); };
  const TrainResult r = train(two_stage_options(dir), ds, cb);
  EXPECT_EQ(r.step, 12);
  auto& m = *g_last;
  EXPECT_EQ(m.begun, (std::vector<int>{0, 1}));
  const Snapshot& start = m.at_begin.at(0);
  const Snapshot& middle = m.at_begin.at(1);
  const Snapshot end = snapshot(m);
  // Stage 1 trains encoder (batch statistics included) and head; the prior is frozen.
  EXPECT_TRUE(same_under(start, middle, "prior."));
  EXPECT_FALSE(same_under(start, middle, "encoder.0."));
  EXPECT_FALSE(same_under(start, middle, "encoder.1.running_mean"));
  EXPECT_FALSE(same_under(start, middle, "head."));
  // Stage 2 trains the prior only; the frozen encoder's batch statistics do not move either.
  EXPECT_TRUE(same_under(middle, end, "encoder."));
  EXPECT_TRUE(same_under(middle, end, "head."));
  EXPECT_FALSE(same_under(middle, end, "prior."));
  ASSERT_EQ(m.encoder_training.size(), 12u);
  for (int i = 0; i < 12; ++i) {
    EXPECT_EQ(m.encoder_training[i], i < 6) << i;
    EXPECT_EQ(m.head_requires_grad[i], i < 6) << i;
  }
  // Progress names the stages; the log of a multi-stage run says the stage; each stage is announced.
  ASSERT_EQ(progress.size(), 12u);
  EXPECT_EQ(progress[5].stage, "autoencoder");
  EXPECT_EQ(progress[5].stage_step, 6);
  EXPECT_EQ(progress[6].stage, "prior");
  EXPECT_EQ(progress[6].stage_index, 1);
  EXPECT_EQ(progress[6].num_stages, 2);
  EXPECT_EQ(progress[6].stage_step, 1);
  EXPECT_EQ(progress[6].total_steps, 12);
  EXPECT_DOUBLE_EQ(progress[6].lr, 0.05 * 0.5);  // the prior's cosine warm-up, not the first stage's Noam
  EXPECT_TRUE(progress[5].has_val);              // validated at the end of every stage
  std::ifstream log(dir / "log.jsonl");
  std::string first;
  std::getline(log, first);
  EXPECT_NE(first.find("\"stage\":\"autoencoder\""), std::string::npos) << first;
  ASSERT_EQ(messages.size(), 2u);
  EXPECT_EQ(messages[1], "stage 2/2 'prior': 6 steps, training 2 tensors, frozen: encoder");

  // The checkpoint holds a fresh SGD over the prior's two tensors (the stage's own optimiser), not
  // the first stage's Adam over everything.
  TwoStageModel probe(nlohmann::json::object());
  torch::optim::SGD sgd(probe.prior->parameters(), torch::optim::SGDOptions(0.05).momentum(0.9));
  const CheckpointState st = load_checkpoint((dir / "checkpoint.pt").string(), probe, &sgd, torch::kCPU);
  EXPECT_EQ(st.stage, 1);
  EXPECT_EQ(st.stage_step, 6);
  torch::optim::Adam adam(probe.parameters(), torch::optim::AdamOptions(0.01));
  EXPECT_THROW(load_checkpoint((dir / "checkpoint.pt").string(), probe, &adam, torch::kCPU), Error);
  fs::remove_all(dir);
}

TEST(Stages, InterruptedInTheSecondStageResumesExactly) {
  register_two_stage();
  const auto ds = nn::testing::synthetic_dataset();
  const auto full = stage_dir("full");
  train(two_stage_options(full), ds);
  const Snapshot expected = checkpoint_tensors(full);
  // Stop before step 9 (stage 2, after 2 of its steps) and before step 7 (the stage boundary).
  for (int stop_before : {9, 7}) {
    const auto dir = stage_dir("stop" + std::to_string(stop_before));
    int calls = 0;
    TrainCallbacks cb;
    cb.should_stop = [&] { return ++calls == stop_before; };
    const TrainResult first = train(two_stage_options(dir), ds, cb);
    EXPECT_TRUE(first.stopped_early);
    EXPECT_EQ(first.step, stop_before - 1);
    auto o = two_stage_options(dir);
    o.resume = true;
    std::vector<std::string> messages;
    TrainCallbacks cb2;
    cb2.on_message = [&](const std::string& m) { messages.push_back(m); };
    const TrainResult second = train(o, ds, cb2);
    EXPECT_EQ(second.step, 12);
    ASSERT_FALSE(messages.empty());
    EXPECT_NE(messages[0].find("stage 2/2 'prior', step " + std::to_string(stop_before - 7)), std::string::npos)
        << messages[0];
    const Snapshot got = checkpoint_tensors(dir);
    for (const auto& [name, t] : expected) EXPECT_TRUE(torch::equal(t, got.at(name))) << stop_before << " " << name;
    fs::remove_all(dir);
  }
  fs::remove_all(full);
}

TEST(Stages, APrefixThatMatchesNothingIsAnError) {
  register_two_stage();
  const auto dir = stage_dir("bad");
  auto o = two_stage_options(dir);
  o.model_config = {{"bad_prefix", true}};
  try {
    train(o, nn::testing::synthetic_dataset());
    ADD_FAILURE() << "a stage training nothing was accepted";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "test_two_stage: stage 'prior': no parameter matches the trained prefix 'priors'");
  }
  EXPECT_FALSE(fs::exists(dir / "checkpoint.pt"));
  fs::remove_all(dir);
}

TEST(Stages, Schedules) {
  ScheduleSpec s;
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 5, 10), 1e-3);  // Noam without warm-up
  s.warmup = 100;
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 50, 1000), noam_lr(1e-3, 100, 50));
  s.kind = ScheduleSpec::Kind::kConstant;
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 50, 1000), 1e-3);
  s.kind = ScheduleSpec::Kind::kCosine;
  s.warmup = 10;
  s.min_lr = 1e-4;
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 5, 110), 0.5e-3);
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 60, 110), 0.55e-3);
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 110, 110), 1e-4);
  s.kind = ScheduleSpec::Kind::kStep;
  s.every = 10;
  s.gamma = 0.5;
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 10, 100), 1e-3);
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 11, 100), 0.5e-3);
  EXPECT_DOUBLE_EQ(scheduled_lr(s, 1e-3, 21, 100), 0.25e-3);
  TrainingStage bad;
  bad.steps = 0;
  EXPECT_THROW(check_stages({bad}, "f"), Error);
  EXPECT_THROW(check_stages({}, "f"), Error);
  TrainingStage a, b;
  EXPECT_THROW(check_stages({a, b}, "f"), Error);  // two stages named "train"
  b.name = "second";
  b.optimizer.beta1 = 1.0;
  EXPECT_THROW(check_stages({a, b}, "f"), Error);
  b.optimizer.beta1 = 0.9;
  EXPECT_NO_THROW(check_stages({a, b}, "f"));
}

namespace {

// Losses of every step (validation losses after '/') of a tiny run of a registered family.
std::string loss_sequence(const std::string& family) {
  auto ds = nn::testing::synthetic_dataset();
  for (auto& c : ds.train_) c.content = 0;
  for (auto& c : ds.val_) c.content = 0;
  const auto dir = stage_dir("seq_" + family);
  TrainOptions o;
  o.family = family;
  o.out_dir = dir.string();
  o.model_config = family_info(family).tiny_config;
  if (family == "rvae") o.model_config["kl_anneal"] = 0.5;
  o.steps = 9;
  o.batch = 4;
  o.warmup = 3;
  o.threads = 1;
  o.checkpoint_every = 4;
  o.validate_every = 4;
  o.log_every = 1;
  o.seed = 5;
  std::string out;
  char buf[64];
  TrainCallbacks cb;
  cb.on_progress = [&](const TrainProgress& p) {
    std::snprintf(buf, sizeof buf, "%.9g", p.loss);
    out += (out.empty() ? "" : " ") + std::string(buf);
    if (p.has_val) {
      std::snprintf(buf, sizeof buf, "/%.9g", p.val_loss);
      out += buf;
    }
  };
  train(o, ds, cb);
  fs::remove_all(dir);
  return out;
}

}  // namespace

// Recorded with the single-stage trainer before stages existed (same seed, data and options).
TEST(Stages, OneStageFamiliesTrainAsBefore) {
  EXPECT_EQ(loss_sequence("moglow"),
            "1.17086172 1.24506986 1.30857098 1.22959387/1.21431965 1.15138042 1.25142968 1.18990314 "
            "1.27718747/1.17950517 1.12875652/1.17248017");
  EXPECT_EQ(loss_sequence("rvae"),
            "1.46524096 1.44610357 1.46221769 1.46766663/1.43390709 1.45558167 1.42228425 1.45870173 "
            "1.42670012/1.43342441 1.45132792/1.43176937");
  EXPECT_EQ(loss_sequence("classifier"), "0 0 0 0/0 0 0 0 0/0 0/0");
}
