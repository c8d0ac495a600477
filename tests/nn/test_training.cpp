// Trainer and run directories: exact resume, refusal to overwrite, divergence handling,
// corrupt checkpoints, load_run, sampling determinism from a run.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <torch/nn/module.h>
#include <torch/optim/adam.h>
#include <torch/utils.h>

#include <array>
#include <map>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include "core/error.h"
#include "core/synthetic.h"
#include "data/dataset.h"
#include "io/json_file.h"
#include "nn/checkpoint.h"
#include "nn/generator.h"
#include "nn/model.h"
#include "nn/run.h"
#include "nn/sampling.h"
#include "nn/training/batches.h"
#include "nn/training/train.h"
#include "nn_test_util.h"
#include "training_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;
using nn::testing::kDim;
using nn::testing::max_param_diff;
using nn::testing::synthetic_dataset;
using nn::testing::temp_dir;
using nn::testing::tiny_options;

TEST(Training, NoamSchedule) {
  EXPECT_DOUBLE_EQ(noam_lr(1e-3, 0, 7), 1e-3);
  EXPECT_DOUBLE_EQ(noam_lr(1e-3, 100, 50), 0.5e-3);
  EXPECT_DOUBLE_EQ(noam_lr(1e-3, 100, 100), 1e-3);
  EXPECT_DOUBLE_EQ(noam_lr(1e-3, 100, 400), 0.5e-3);
}

// With windows drawn by clip frames (the weighted draw), as the default draw is in every other test.
TEST(Training, ResumeEqualsUninterruptedTraining) {
  const auto ds = synthetic_dataset();
  const auto dir_a = temp_dir("full"), dir_b = temp_dir("resumed");
  auto oa = tiny_options(dir_a);
  oa.window_sampling = "frames";
  std::vector<TrainProgress> progress;
  TrainCallbacks cb;
  cb.on_progress = [&](const TrainProgress& p) { progress.push_back(p); };
  auto ra = train(oa, ds, cb);
  EXPECT_EQ(ra.step, 12);
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back().step, 12);
  EXPECT_TRUE(progress.back().has_val);
  EXPECT_TRUE(progress.back().metrics.count("nll_frame"));

  auto ob = tiny_options(dir_b);
  ob.window_sampling = "frames";
  ob.steps = 5;  // checkpoints at 4 and at the last step, 5
  train(ob, ds);
  ob.steps = 12;
  ob.resume = true;
  auto rb = train(ob, ds);
  EXPECT_EQ(rb.step, 12);
  EXPECT_EQ(ra.last_loss, rb.last_loss);

  auto a = load_run(dir_a.string(), {"checkpoint.pt", "cpu", 1});
  auto b = load_run(dir_b.string(), {"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(a.step, 12);
  EXPECT_EQ(b.step, 12);
  // Same thread count, same ops: the resumed run is bit-for-bit identical.
  EXPECT_EQ(max_param_diff(*a.model, *b.model), 0.0);
  EXPECT_TRUE(fs::exists(dir_a / "best.pt"));
  EXPECT_TRUE(fs::exists(dir_a / "log.jsonl"));
  EXPECT_TRUE(fs::exists(dir_a / "stats.json"));
  EXPECT_EQ(a.family, "moglow");
  EXPECT_EQ(a.context.pose_dim, kDim);
  EXPECT_EQ(a.dataset.content_labels, ds.info().content_labels);
  EXPECT_EQ(io::read_json((dir_a / "config.json").string()).at("train").at("window_sampling"), "frames");
  fs::remove_all(dir_a);
  fs::remove_all(dir_b);
}

TEST(Training, WindowSamplingIsReadAndChecked) {
  EXPECT_EQ(TrainOptions::from_json(nlohmann::json::object()).window_sampling, "windows");  // older runs
  EXPECT_EQ(TrainOptions::from_json({{"window_sampling", "frames"}}).window_sampling, "frames");
  EXPECT_EQ(TrainOptions::from_json(TrainOptions::from_json({{"window_sampling", "frames"}}).to_json()).window_sampling,
            "frames");
  try {
    TrainOptions::from_json({{"window_sampling", "clips"}});
    FAIL() << "an unknown window sampling was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("window_sampling must be \"windows\" or \"frames\", not \"clips\""));
  }
}

TEST(Training, ExistingRunIsNotOverwrittenWithoutFlag) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("exists");
  auto o = tiny_options(dir);
  o.steps = 2;
  train(o, ds);
  try {
    train(o, ds);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("already exists"), std::string::npos) << e.what();
  }
  o.overwrite = true;
  EXPECT_NO_THROW(train(o, ds));
  auto fresh = tiny_options(temp_dir("nothing"));
  fresh.resume = true;
  EXPECT_THROW(train(fresh, ds), Error);
  fs::remove_all(dir);
}

TEST(Training, DivergenceStopsNamingTheStepAndKeepsLastCheckpoint) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("nan");
  auto o = tiny_options(dir);
  o.lr = 1e6;
  o.warmup = 0;
  o.grad_clip = 0;
  o.steps = 60;
  o.checkpoint_every = 1;
  o.validate_every = 0;
  std::string msg;
  try {
    train(o, ds);
  } catch (const Error& e) {
    msg = e.what();
  }
  ASSERT_NE(msg.find("at step"), std::string::npos) << "training did not diverge: '" << msg << "'";
  const int failed = std::stoi(msg.substr(msg.find("at step") + 8));
  ASSERT_GT(failed, 1) << msg;  // deterministic: diverges after a good first step
  EXPECT_NE(msg.find("checkpoint.pt"), std::string::npos) << msg;
  auto run = load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(run.step, failed - 1);
  for (const auto& p : run.model->parameters()) EXPECT_TRUE(torch::isfinite(p).all().item<bool>());
  fs::remove_all(dir);
}

TEST(Training, TruncatedCheckpointGivesClearError) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("trunc");
  auto o = tiny_options(dir);
  o.steps = 2;
  train(o, ds);
  const auto ckpt = dir / "checkpoint.pt";
  const auto size = fs::file_size(ckpt);
  fs::resize_file(ckpt, size / 2);
  try {
    load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("checkpoint.pt"), std::string::npos) << e.what();
  }
  {
    std::ofstream(ckpt, std::ios::binary | std::ios::trunc) << "garbage";
  }
  EXPECT_THROW(load_run(dir.string(), {"checkpoint.pt", "cpu", 1}), Error);
  fs::remove(dir / "config.json");
  try {
    load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("config.json"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// Found by fuzz_run: LibTorch's importer crashed on a checkpoint whose TorchScript source had
// shuffled bytes, which it reads without checking the archive's CRC-32. Every entry's CRC is now
// checked first: a changed byte in any entry (here a tensor's, which LibTorch would have loaded
// silently) is a clear error naming the file and the entry.
TEST(Training, DamagedCheckpointEntryIsRefusedBeforeLibTorchReadsIt) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("damaged");
  auto o = tiny_options(dir);
  o.steps = 2;
  train(o, ds);
  const auto ckpt = dir / "checkpoint.pt";
  std::string bytes;
  {
    std::ifstream in(ckpt, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  // One byte of the first tensor's data (entries holding tensor data are stored uncompressed, so
  // the bytes after its local header are the tensor's): LibTorch would load the changed weights.
  const std::string entry = "archive/data/0";
  const size_t header = bytes.find(entry) - 30;
  ASSERT_EQ(bytes.compare(header, 4, "PK\x03\x04"), 0) << "no local header for " << entry;
  auto u16 = [&](size_t at) { return static_cast<size_t>(static_cast<unsigned char>(bytes[at])) |
                                     static_cast<size_t>(static_cast<unsigned char>(bytes[at + 1])) << 8; };
  const size_t data = header + 30 + u16(header + 26) + u16(header + 28);
  ASSERT_LT(data, bytes.size());
  bytes[data] = static_cast<char>(bytes[data] ^ 0x5a);
  {
    std::ofstream out(ckpt, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  try {
    load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("checkpoint.pt"), std::string::npos) << m;
    EXPECT_NE(m.find("damaged file"), std::string::npos) << m;
    EXPECT_NE(m.find(entry), std::string::npos) << m;
  }
  fs::remove_all(dir);
}

TEST(Sampling, SampleMotionsDeterministicPerSeedAndGeneratorMatches) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("sample");
  auto o = tiny_options(dir);
  o.steps = 6;
  train(o, ds);
  auto run = load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
  const auto& clip = ds.val_[0];
  const int t = 20;
  std::vector<float> control(clip.control.begin(), clip.control.begin() + 3 * t);
  auto a = sample_motions(run, control, 2, 5);
  auto b = sample_motions(run, control, 2, 5);
  auto c = sample_motions(run, control, 2, 6);
  ASSERT_EQ(a.size(), 2u);
  ASSERT_EQ(a[0].pose.size(), static_cast<size_t>(t * kDim));
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_NE(a[0], a[1]);

  // The real-time generator, stepping a batch of 2 with the same seed, gives the same frames.
  GeneratorOptions go;
  go.batch = 2;
  go.seed = 5;
  go.threads = 1;
  Generator gen(dir.string(), go);
  EXPECT_EQ(gen.pose_dim(), kDim);
  for (int f = 0; f < t; ++f) {
    std::vector<float> ctrl2;
    for (int k = 0; k < 2; ++k) ctrl2.insert(ctrl2.end(), control.begin() + 3 * f, control.begin() + 3 * f + 3);
    auto pose = gen.step(ctrl2);
    ASSERT_EQ(pose.size(), static_cast<size_t>(2 * kDim));
    for (int k = 0; k < 2; ++k)
      for (int d = 0; d < kDim; ++d) EXPECT_NEAR(pose[k * kDim + d], a[k].pose[f * kDim + d], 1e-4) << f;
  }
  EXPECT_EQ(gen.frames(), t);

  // Root pose integration: forward 0.1 m per frame facing +Z (heading 0, Y up, metres), then a
  // quarter turn.
  GeneratorOptions one;
  one.threads = 1;
  Generator walker(dir.string(), one);
  for (int f = 0; f < 3; ++f) walker.step({0.0f, 0.1f, 0.0f});
  EXPECT_NEAR((walker.root(0).position - Eigen::Vector3d(0, 0, 0.3)).norm(), 0.0, 1e-6);
  walker.step({0.0f, 0.0f, static_cast<float>(M_PI / 2)});
  EXPECT_NEAR(walker.root(0).heading_rad, M_PI / 2, 1e-6);
  walker.reset(1);
  EXPECT_EQ(walker.frames(), 0);
  EXPECT_NEAR(walker.root(0).position.norm(), 0.0, 1e-12);
  fs::remove_all(dir);
}

// One writer per run directory: while another process holds RUN/.lock, train refuses (and
// touches nothing); the log grows as training goes, not only at checkpoints.
TEST(Training, RunLockAndALogThatKeepsUp) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("lock");
  fs::create_directories(dir);
  const int fd = ::open((dir / ".lock").c_str(), O_RDWR | O_CREAT, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX | LOCK_NB), 0);
  auto o = tiny_options(dir);
  try {
    train(o, ds);
    ADD_FAILURE() << "a second writer was let in";
  } catch (const mosyn::Error& e) {
    EXPECT_NE(std::string(e.what()).find("another mosyn process"), std::string::npos) << e.what();
  }
  ::close(fd);  // released: the run goes ahead in the same directory
  o.checkpoint_every = 100;  // no checkpoint before the last step
  int lines_seen = 0;
  TrainCallbacks cb;
  cb.on_progress = [&](const TrainProgress& p) {
    if (p.step != 8) return;
    std::ifstream in(dir / "log.jsonl");
    std::string line;
    while (std::getline(in, line)) ++lines_seen;
  };
  train(o, ds, cb);
  EXPECT_GE(lines_seen, 4);  // steps 2, 4, 6, 8 logged before any checkpoint
  fs::remove_all(dir);
}

// Live controls are shaped like smoothed training trajectories: a sudden start ramps up without
// overshoot and settles on the input; the root follows the shaped control.
TEST(Sampling, GeneratorShapesLiveControls) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("shape");
  auto o = tiny_options(dir);
  o.steps = 2;
  train(o, ds);
  GeneratorOptions go;
  go.threads = 1;
  go.control_smoothing_s = 0.5;  // at the dataset's 20 fps: w = 0.131 per frame
  Generator gen(dir.string(), go);
  double previous = 0, travelled = 0;
  for (int f = 0; f < 120; ++f) {
    gen.step({0.0f, 0.1f, 0.0f});
    const double v = gen.last_control()[1];
    EXPECT_GE(v, previous - 1e-9);  // monotone: critically damped
    EXPECT_LE(v, 0.1 + 1e-6);       // no overshoot
    if (f == 0) {
      EXPECT_LT(v, 0.02);
    }
    previous = v;
    travelled += v;
  }
  EXPECT_NEAR(previous, 0.1, 1e-4);
  EXPECT_NEAR(gen.root(0).position.z(), travelled, 1e-6);
  EXPECT_THROW(gen.step({0.0f, std::nanf(""), 0.0f}), mosyn::Error);
  go.control_smoothing_s = 0.0;  // off: controls as given
  Generator raw(dir.string(), go);
  raw.step({0.0f, 0.1f, 0.0f});
  EXPECT_FLOAT_EQ(raw.last_control()[1], 0.1f);
  fs::remove_all(dir);
}

// --init-from: a run trained without labels warm-starts one with labels. The grown inputs start at
// zero, so the new model computes what the old one did; the labelled model then takes labels, and
// the unlabelled one refuses them with a clear message.
TEST(Training, InitFromGrowsNewConditionsAndLabelsCondition) {
  auto ds = synthetic_dataset();
  const auto dir_a = temp_dir("init_a"), dir_b = temp_dir("init_b");
  auto oa = tiny_options(dir_a);
  oa.steps = 4;
  train(oa, ds);
  ds.info_.content_labels = {"walk", "run"};
  for (size_t i = 0; i < ds.train_.size(); ++i) ds.train_[i].content = static_cast<int>(i % 2);

  // The warm-started model before any step equals the old one on any labels.
  auto a = load_run(dir_a.string(), {"checkpoint.pt", "cpu", 1});
  ModelContext ctx = a.context;
  ctx.num_content = 2;
  nlohmann::json cfg = a.config["model"];
  cfg["labels"] = true;
  auto grown = create_model("moglow", cfg, ctx);
  const InitReport report = init_from_checkpoint((dir_a / "checkpoint.pt").string(), *grown, torch::kCPU);
  EXPECT_GT(report.copied, 0);
  EXPECT_EQ(report.grown.size(), 2u);  // the input weights of each coupling LSTM
  EXPECT_TRUE(report.missing.empty());
  grown->eval();
  auto batch = mosyn::nn::testing::noisy_sinusoid_batch(2, 12, kDim);
  batch.content = torch::tensor({0, 1}, torch::kInt64);
  EXPECT_NEAR(grown->loss(batch).loss().item<double>(), a.model->loss(batch).loss().item<double>(), 1e-5);

  auto ob = tiny_options(dir_b);
  ob.steps = 4;
  ob.init_from = dir_a.string();
  ob.model_config = {{"labels", true}};
  std::vector<std::string> messages;
  TrainCallbacks cb;
  cb.on_message = [&](const std::string& m) { messages.push_back(m); };
  train(ob, ds, cb);
  ASSERT_FALSE(messages.empty());
  EXPECT_NE(messages.front().find("initialised from"), std::string::npos) << messages.front();
  auto b = load_run(dir_b.string(), {"checkpoint.pt", "cpu", 1});
  EXPECT_TRUE(b.model->traits().labels);
  EXPECT_EQ(b.config["model"]["hidden"], 8);  // the init run's architecture
  const std::vector<float> control(3 * 10, 0.1f);
  SampleExtras walk, run;
  walk.content = 0;
  run.content = 1;
  EXPECT_NE(sample_motions(b, control, 1, 3, 1.0, walk), sample_motions(b, control, 1, 3, 1.0, run));
  SampleExtras unknown;
  unknown.content = 2;
  EXPECT_THROW(sample_motions(b, control, 1, 3, 1.0, unknown), mosyn::Error);
  try {
    sample_motions(a, control, 1, 3, 1.0, walk);
    ADD_FAILURE() << "an unlabelled model accepted a label";
  } catch (const mosyn::Error& e) {
    EXPECT_NE(std::string(e.what()).find("trained without labels"), std::string::npos) << e.what();
  }
  ob.resume = true;
  EXPECT_THROW(train(ob, ds), mosyn::Error);  // resume and init_from exclude each other
  fs::remove_all(dir_a);
  fs::remove_all(dir_b);
}

// --init-from across vocabularies: label columns move by name. A model warm-started with labels
// reordered, one added and one dropped computes, for every label both runs know, exactly what the
// old model did; a label new to it acts as "no label".
TEST(Training, InitFromMatchesLabelColumnsByName) {
  const std::vector<std::pair<std::string, nlohmann::json>> families = {
      {"moglow", {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"labels", true}}},
      {"rvae",
       {{"encoder_channels", {8, 12}}, {"control_channels", {6, 10}}, {"decoder_channels", {8}}, {"latent", 5},
        {"kernel", 5}, {"input_dropout", 0.0}, {"labels", true}, {"label_dropout", 0.0}}}};
  for (const auto& [family, cfg] : families) {
    SCOPED_TRACE(family);
    const auto dir = temp_dir("relabel_" + family);
    fs::create_directories(dir);
    InitLabels labels;
    labels.stored = {{"walk", "run", "crawl"}, {"normal", "tired"}};
    labels.model = {{"run", "jump", "walk"}, {"tired", "normal", "proud"}};
    ModelContext old_ctx = mosyn::nn::testing::small_context(kDim);
    old_ctx.num_content = 3;
    old_ctx.num_style = 2;
    torch::manual_seed(5);
    auto old_model = create_model(family, cfg, old_ctx);
    // Non-zero label weights, so that a misplaced column shows.
    {
      torch::NoGradGuard no_grad;
      for (auto& p : old_model->parameters()) p.add_(0.1 * torch::randn(p.sizes()));
    }
    const std::string path = (dir / "checkpoint.pt").string();
    save_checkpoint(path, *old_model, nullptr, CheckpointState{});
    ModelContext new_ctx = old_ctx;
    new_ctx.num_content = 3;
    new_ctx.num_style = 3;
    auto new_model = create_model(family, cfg, new_ctx);
    const InitReport report = init_from_checkpoint(path, *new_model, torch::kCPU, &labels);
    EXPECT_FALSE(report.relabelled.empty());
    EXPECT_TRUE(report.missing.empty()) << report.missing.front();
    EXPECT_TRUE(report.grown.empty());
    old_model->eval();
    new_model->eval();
    auto batch = mosyn::nn::testing::noisy_sinusoid_batch(1, 12, kDim);
    auto loss_of = [&](MotionModel& m, int content, int style) {
      Batch b = batch;
      b.content = torch::tensor({content}, torch::kInt64);
      b.style = torch::tensor({style}, torch::kInt64);
      torch::manual_seed(9);  // the same latent draws for both models
      return m.loss(b).loss().item<double>();
    };
    // (old content, old style) -> (new content, new style), by name; -1 = none.
    const std::vector<std::array<int, 4>> same = {{0, 0, 2, 1}, {1, 1, 0, 0}, {0, 1, 2, 0}, {-1, -1, 1, 2}, {-1, 0, 1, 1}};
    for (const auto& c : same)
      EXPECT_NEAR(loss_of(*new_model, c[2], c[3]), loss_of(*old_model, c[0], c[1]), 1e-5)
          << c[0] << "," << c[1] << " -> " << c[2] << "," << c[3];
    // Without the vocabularies the same checkpoint cannot be placed column by column.
    auto unmapped = create_model(family, cfg, new_ctx);
    const InitReport plain = init_from_checkpoint(path, *unmapped, torch::kCPU);
    EXPECT_TRUE(plain.relabelled.empty());
    unmapped->eval();
    EXPECT_GT(std::abs(loss_of(*unmapped, 2, 1) - loss_of(*old_model, 0, 0)), 1e-4);  // the test can tell
    fs::remove_all(dir);
  }
}

namespace {

// A model whose loss is a fixed negative number (as a good model's NLL often is): validation
// bookkeeping must not mistake it for "not validated".
class NegativeLossModel : public TrainableModel {
 public:
  NegativeLossModel() : TrainableModel("NegativeLossModel") { w_ = register_parameter("w", torch::zeros({1})); }
  std::string family() const override { return "test_negative_loss"; }
  nlohmann::json config() const override { return nlohmann::json::object(); }
  LossTerms loss(const Batch&) override { return LossTerms{{{"loss", w_.sum() * 0 - 2.5}}}; }

 private:
  torch::Tensor w_;
};

}  // namespace

TEST(Training, NegativeValidationLossIsLoggedAndKeepsBest) {
  register_family(FamilyInfo{"test_negative_loss", FamilyKind::kClassifier, "test: a constant negative loss",
                             [](const nlohmann::json&, const ModelContext&) {
                               return std::make_shared<NegativeLossModel>();
                             }});
  const auto dir = temp_dir("negative_val");
  TrainOptions o = tiny_options(dir);
  o.family = "test_negative_loss";
  o.model_config = nlohmann::json::object();
  o.steps = 4;
  o.validate_every = 2;
  const TrainResult r = train(o, synthetic_dataset());
  EXPECT_DOUBLE_EQ(r.best_val_loss, -2.5);
  EXPECT_TRUE(fs::exists(dir / "best.pt"));
  std::ifstream log(dir / "log.jsonl");
  int val_lines = 0;
  for (std::string line; std::getline(log, line);)
    if (line.find("\"val_loss\":-2.5") != std::string::npos) ++val_lines;
  EXPECT_EQ(val_lines, 2);
  fs::remove_all(dir);
}

// A checkpoint written before training stages existed (no "stage" keys) resumes as the one stage,
// exactly where it ended.
TEST(Training, CheckpointWithoutStageResumesInTheOneStage) {
  const auto ds = synthetic_dataset();
  const auto dir_a = temp_dir("legacy_full"), dir_b = temp_dir("legacy_resumed");
  train(tiny_options(dir_a), ds);
  auto ob = tiny_options(dir_b);
  ob.steps = 5;
  train(ob, ds);
  {  // Rewrite the checkpoint as the single-stage trainer did: the same tensors, no stage.
    const std::string ckpt = (dir_b / "checkpoint.pt").string();
    auto run = load_run(dir_b.string(), {"checkpoint.pt", "cpu", 1});
    torch::optim::Adam adam(run.trainable->parameters(), torch::optim::AdamOptions(1e-3));
    CheckpointState state = load_checkpoint(ckpt, *run.trainable, &adam, torch::kCPU);
    EXPECT_EQ(state.stage, 0);
    EXPECT_EQ(state.stage_step, 5);
    state.stage = state.stage_step = -1;
    save_checkpoint(ckpt, *run.trainable, &adam, state);
    EXPECT_EQ(load_checkpoint(ckpt, *run.trainable, nullptr, torch::kCPU).stage, -1);
  }
  ob.steps = 12;
  ob.resume = true;
  train(ob, ds);
  auto a = load_run(dir_a.string(), {"checkpoint.pt", "cpu", 1});
  auto b = load_run(dir_b.string(), {"checkpoint.pt", "cpu", 1});
  EXPECT_EQ(b.step, 12);
  EXPECT_EQ(max_param_diff(*a.model, *b.model), 0.0);
  fs::remove_all(dir_a);
  fs::remove_all(dir_b);
}

// Bad numbers in, clear errors out: a checkpoint holding a NaN or infinite weight is refused
// naming the file and the tensor (by load_run and by a resumed training), and a dataset too small
// for the window asked names both sizes.
TEST(Training, NonFiniteCheckpointAndTooSmallDatasetAreRefused) {
  const auto ds = synthetic_dataset();
  const auto dir = temp_dir("non_finite");
  auto o = tiny_options(dir);
  o.steps = 4;
  train(o, ds);
  const std::string ckpt = (dir / "checkpoint.pt").string();
  const std::string good = (dir / "good.pt").string();
  fs::copy_file(ckpt, good);
  for (const float bad : {std::nanf(""), INFINITY}) {
    fs::copy_file(good, ckpt, fs::copy_options::overwrite_existing);
    auto run = load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
    torch::optim::Adam adam(run.trainable->parameters(), torch::optim::AdamOptions(1e-3));
    CheckpointState state = load_checkpoint(ckpt, *run.trainable, &adam, torch::kCPU);
    {
      torch::NoGradGuard no_grad;
      run.trainable->parameters().back().view(-1)[0] = bad;
    }
    save_checkpoint(ckpt, *run.trainable, &adam, state);
    try {
      load_run(dir.string(), {"checkpoint.pt", "cpu", 1});
      ADD_FAILURE() << "a checkpoint with a non-finite weight loaded";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("checkpoint.pt"), std::string::npos) << what;
      EXPECT_NE(what.find("NaN or infinite"), std::string::npos) << what;
    }
    auto resumed = o;
    resumed.steps = 8;
    resumed.resume = true;
    EXPECT_THROW(train(resumed, ds), Error);
  }
  fs::remove_all(dir);

  auto big = tiny_options(temp_dir("too_small"));
  big.model_config["short_clips"] = false;  // a family that trains on whole windows only
  int longest = 0;
  for (const auto& c : ds.clips("train")) longest = std::max(longest, c.num_frames);
  big.window = longest + 1;
  try {
    train(big, ds);
    ADD_FAILURE() << "a window longer than every clip was accepted";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(std::to_string(longest + 1) + " frames"), std::string::npos) << what;
    EXPECT_NE(what.find("has " + std::to_string(longest) + " frames"), std::string::npos) << what;
  }
  fs::remove_all(big.out_dir);
  // MoGlow by default trains on clips shorter than the window, each as one padded window.
  auto padded = tiny_options(temp_dir("padded"));
  padded.window = longest + 1;
  padded.steps = 2;
  EXPECT_EQ(train(padded, ds).step, 2);
  fs::remove_all(padded.out_dir);
}

namespace {

data::ClipRecord labelled_clip(const std::string& source, int frames, int pose_dim, int content) {
  data::ClipRecord r;
  r.source = source;
  r.content = content;
  r.style = 0;
  r.num_frames = frames;
  for (int i = 0; i < frames * pose_dim; ++i) r.pose.push_back(0.25f * i);
  for (int i = 0; i < frames * 3; ++i) r.control.push_back(-0.5f * i);
  return r;
}

}  // namespace

// Speed balance by hand: three 1.2-m/s clips and one 3.2-m/s clip of 10 frames at 20 fps, one
// window each. Exponent 1 draws both bins alike (the fast clip 3x each slow one), 0.5 by the
// square root of the shares, 0 as before.
TEST(Training, SpeedBalanceFlattensTheDrawsOverRootSpeed) {
  const double fps = 20;
  auto clip_at = [&](double speed_mps) {
    data::ClipRecord r;
    r.num_frames = 10;
    for (int t = 0; t < r.num_frames; ++t) {
      const double step_m = speed_mps / fps;  // along a 30-degree heading, so both dx and dz count
      r.control.insert(r.control.end(), {static_cast<float>(step_m * std::cos(0.5236)),
                                         static_cast<float>(step_m * std::sin(0.5236)), 0.01f});
    }
    return r;
  };
  const std::vector<data::ClipRecord> clips = {clip_at(1.2), clip_at(1.2), clip_at(1.2), clip_at(3.2)};
  EXPECT_NEAR(training::clip_root_speed_mps(clips[0], 3, fps), 1.2, 1e-5);
  EXPECT_NEAR(training::clip_root_speed_mps(clips[3], 3, fps), 3.2, 1e-5);
  training::SplitWindows split;
  split.clips = &clips;
  split.window = 10;
  for (int c = 0; c < 4; ++c) split.windows.push_back({c, 0, 0});
  const std::vector<double> even(4, 1.0);

  const training::SpeedBalance flat_balance = training::speed_balanced(split, even, 3, fps, 1.0);
  const auto& shares = flat_balance.shares_before;
  ASSERT_EQ(shares.size(), 2u);
  EXPECT_DOUBLE_EQ(shares.at(2), 0.75);  // 1.0-1.5 m/s
  EXPECT_DOUBLE_EQ(shares.at(6), 0.25);  // 3.0-3.5 m/s

  const std::vector<double>& flat = flat_balance.weights;
  EXPECT_NEAR(flat[3] / flat[0], 3.0, 1e-12);
  const auto& flat_shares = flat_balance.shares_after;
  EXPECT_NEAR(flat_shares.at(2), 0.5, 1e-12);
  EXPECT_NEAR(flat_shares.at(6), 0.5, 1e-12);
  const std::vector<double> root = training::speed_balanced(split, even, 3, fps, 0.5).weights;
  EXPECT_NEAR(root[3] / root[0], std::sqrt(3.0), 1e-12);
  EXPECT_EQ(training::speed_balanced(split, even, 3, fps, 0.0).weights, even);
  // Weights already uneven (by frames) are scaled, not replaced.
  const std::vector<double> by_frames = {2, 1, 1, 4};
  const std::vector<double> scaled = training::speed_balanced(split, by_frames, 3, fps, 1.0).weights;
  EXPECT_NEAR(scaled[0] / scaled[1], 2.0, 1e-12);
  EXPECT_NEAR(scaled[3] / (scaled[0] + scaled[1] + scaled[2]), 1.0, 1e-12);  // 4 of 8 vs 4 of 8
  EXPECT_THROW(training::speed_balanced(split, {1.0}, 3, fps, 1.0), Error);

  nlohmann::json bad = {{"speed_balance", 1.5}};
  EXPECT_THROW(TrainOptions::from_json(bad), Error);
  EXPECT_DOUBLE_EQ(TrainOptions::from_json({{"speed_balance", 0.5}}).speed_balance, 0.5);
}

// Label weights by hand: four clips (walk/elderly, run/elderly, run/active, unlabelled), one window
// each, by-frames weights 1, 2, 3, 4. "run:elderly" x3 scales the second only, "*:elderly" x2
// the first two, and both together multiply (the second x6); unknown labels and bad keys or
// factors are errors that name what was expected.
TEST(Training, LabelWeightsScaleTheDrawsOfTheirLabels) {
  std::vector<data::ClipRecord> clips(4);
  const std::vector<std::pair<int, int>> labels = {{0, 0}, {1, 0}, {1, 1}, {-1, -1}};
  for (size_t c = 0; c < clips.size(); ++c) std::tie(clips[c].content, clips[c].style) = labels[c];
  training::SplitWindows split;
  split.clips = &clips;
  split.window = 10;
  for (int c = 0; c < 4; ++c) split.windows.push_back({c, 0, 0});
  const std::vector<double> by_frames = {1, 2, 3, 4};
  const std::vector<std::string> contents = {"walk", "run"}, styles = {"elderly", "active"};

  const auto run_elderly = training::resolve_label_weights({{"run:elderly", 3.0}}, contents, styles);
  ASSERT_EQ(run_elderly.size(), 1u);
  EXPECT_EQ(run_elderly[0].content, 1);
  EXPECT_EQ(run_elderly[0].style, 0);
  EXPECT_EQ(training::label_weighted(split, by_frames, run_elderly), (std::vector<double>{1, 6, 3, 4}));
  EXPECT_DOUBLE_EQ(training::label_share(split, by_frames, run_elderly[0]), 0.2);
  EXPECT_DOUBLE_EQ(training::label_share(split, {1, 6, 3, 4}, run_elderly[0]), 6.0 / 14.0);

  const auto both = training::resolve_label_weights({{"run:elderly", 3.0}, {"*:elderly", 2.0}}, contents, styles);
  EXPECT_EQ(training::label_weighted(split, by_frames, both), (std::vector<double>{2, 12, 3, 4}));
  // "*:*" matches the unlabelled clip too.
  const auto all = training::resolve_label_weights({{"*:*", 0.5}}, contents, styles);
  EXPECT_EQ(training::label_weighted(split, by_frames, all), (std::vector<double>{0.5, 1, 1.5, 2}));
  EXPECT_EQ(training::label_weighted(split, by_frames, {}), by_frames);
  EXPECT_THROW(training::label_weighted(split, {1.0}, run_elderly), Error);

  auto message_of = [&](const std::map<std::string, double>& entries) {
    try {
      training::resolve_label_weights(entries, contents, styles);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of({{"jog:elderly", 2.0}}).find("unknown content label 'jog' (known: walk, run, or *)"),
            std::string::npos);
  EXPECT_NE(message_of({{"run:old", 2.0}}).find("unknown style label 'old'"), std::string::npos);
  EXPECT_NE(message_of({{"run", 2.0}}).find("expected CONTENT:STYLE"), std::string::npos);
  EXPECT_NE(message_of({{"run:a:b", 2.0}}).find("expected CONTENT:STYLE"), std::string::npos);
  EXPECT_NE(message_of({{"run:elderly", 0.0}}).find("(0, 1000]"), std::string::npos);

  // Through the options: read, written back only when set, bad factors refused.
  const TrainOptions read = TrainOptions::from_json({{"label_weights", {{"run:elderly", 3.0}}}});
  EXPECT_DOUBLE_EQ(read.label_weights.at("run:elderly"), 3.0);
  EXPECT_EQ(read.to_json()["label_weights"], (nlohmann::json{{"run:elderly", 3.0}}));
  EXPECT_FALSE(TrainOptions{}.to_json().contains("label_weights"));
  EXPECT_THROW(TrainOptions::from_json({{"label_weights", {{"run:elderly", -1.0}}}}), Error);
  EXPECT_THROW(TrainOptions::from_json({{"label_weights", {{"run:elderly", "three"}}}}), Error);
}

// Clips shorter than the window: left out (with a warning that names the labels never seen) for
// most families, or one padded window with its length for families that mask padding (hvrnn).
TEST(Training, ShortClipsAreNamedOrPaddedWithTheirLength) {
  const fs::path dir = temp_dir("short_clips");
  data::DatasetInfo info;
  info.skeleton = make_synthetic_biped();
  info.layout = data::make_layout(info.skeleton, data::PoseForm::kPositions, 0, Eigen::Vector3d(0, 0, 1));
  info.window_frames = 4;
  info.window_hop = 2;
  info.content_labels = {"walk", "raise-hand"};
  info.style_labels = {"normal"};
  info.train_files = {"a.bvh", "b.bvh"};
  info.val_files = {"c.bvh"};
  info.source_dir = "/src";
  const int d = info.layout.pose_dim;
  const std::vector<data::ClipRecord> train = {labelled_clip("a.bvh", 9, d, 0), labelled_clip("b.bvh", 3, d, 1)};
  data::write_dataset(dir.string(), info, data::compute_stats(train, d, 3), train, {labelled_clip("c.bvh", 6, d, 0)},
                      false);
  const data::Dataset dataset = data::Dataset::open(dir.string());

  const std::string warning = training::left_out_warning(dataset, 4, 0);
  EXPECT_THAT(warning, ::testing::HasSubstr("1 of 2 training clips (25% of the frames)"));
  EXPECT_THAT(warning, ::testing::HasSubstr("contents never seen: raise-hand (longest clip 3 frames)"));
  EXPECT_THAT(warning, ::testing::Not(::testing::HasSubstr("styles never seen")));
  EXPECT_EQ(training::left_out_warning(dataset, 4, 2), "");
  EXPECT_EQ(training::left_out_warning(dataset, 3, 0), "");

  const training::SplitWindows plain = training::training_windows(dataset, 4);
  EXPECT_EQ(plain.windows.size(), 6u);  // starts 0..5 of the 9-frame clip
  const training::SplitWindows padded = training::training_windows(dataset, 4, 2);
  ASSERT_EQ(padded.windows.size(), 7u);
  // Drawn by clip frames: the 9-frame clip's six windows share 9, the 3-frame clip's one has 3
  // (a quarter of the draws, as a quarter of the frames; drawn alike, one in seven).
  EXPECT_EQ(training::clip_frame_weights(plain), std::vector<double>(6, 1.5));
  std::vector<double> expected(6, 1.5);
  expected.push_back(3.0);
  EXPECT_EQ(training::clip_frame_weights(padded), expected);
  const training::BatchMaker maker(dataset, d, 3, torch::kCPU);
  EXPECT_FALSE(maker.make(plain, 0, 2).frames.defined());
  const data::WindowRef short_window = padded.windows[6];
  ASSERT_EQ(short_window.frames, 3);
  const Batch b = maker.make(padded, std::vector<data::WindowRef>{padded.windows[0], short_window});
  ASSERT_TRUE(b.frames.defined());
  EXPECT_EQ(b.frames[0].item<int64_t>(), 4);
  EXPECT_EQ(b.frames[1].item<int64_t>(), 3);
  EXPECT_EQ(b.pose.sizes(), (std::vector<int64_t>{2, 4, d}));
  EXPECT_TRUE(torch::equal(b.pose[1][3], b.pose[1][2]));  // padding repeats the last frame
  EXPECT_TRUE(torch::equal(b.control[1][3], b.control[1][2]));
  EXPECT_FALSE(torch::equal(b.pose[1][2], b.pose[1][1]));
  EXPECT_EQ(b.content[1].item<int64_t>(), 1);
  EXPECT_FALSE(b.control_after.defined());
  // With control_after, each window carries the control of the frames after it in its clip,
  // the clip's last frame repeating past its end (as for a path that ends there).
  training::SplitWindows ahead = padded;
  ahead.control_after = 3;
  const std::vector<data::WindowRef> picks = {padded.windows[0], padded.windows[5], short_window};
  const Batch a = maker.make(ahead, picks);
  ASSERT_EQ(a.control_after.sizes(), (std::vector<int64_t>{3, 3, 3}));
  const Batch later = maker.make(ahead, std::vector<data::WindowRef>{padded.windows[4]});  // frames 4..7
  EXPECT_TRUE(torch::equal(a.control_after[0], later.control[0].narrow(0, 0, 3)));
  EXPECT_FALSE(torch::equal(a.control_after[0][0], a.control_after[0][1]));
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(torch::equal(a.control_after[1][k], a.control[1][3]));  // window 5..8 ends the clip
    EXPECT_TRUE(torch::equal(a.control_after[2][k], a.control[2][2]));  // the short clip's last frame
  }
  fs::remove_all(dir);
}

TEST(Training, FoldIntoMeanAveragesEveryFloatingPointTensor) {
  const ModelContext ctx = nn::testing::small_context(nn::testing::kDim, 3);
  const nlohmann::json cfg = family_info("moglow").tiny_config;
  torch::manual_seed(1);
  auto a = create_model("moglow", cfg, ctx);
  torch::manual_seed(2);
  auto b = create_model("moglow", cfg, ctx);
  torch::manual_seed(3);
  auto c = create_model("moglow", cfg, ctx);
  std::map<std::string, torch::Tensor> expected;
  const auto pb = b->named_parameters(), pc = c->named_parameters();
  for (const auto& p : a->named_parameters())
    expected[p.key()] = (p.value() + pb[p.key()] + pc[p.key()]).detach() / 3.0;
  fold_into_mean(*a, *b, 1);  // a = (a + b) / 2
  fold_into_mean(*a, *c, 2);  // a = (a + b + c) / 3
  ASSERT_FALSE(expected.empty());
  for (const auto& p : a->named_parameters())
    EXPECT_TRUE(torch::allclose(p.value(), expected.at(p.key()), 1e-5, 1e-6)) << p.key();
  // Another config's tensors, or a count below one, are refused.
  nlohmann::json other = cfg;
  other["hidden"] = cfg.value("hidden", 8) + 1;
  auto d = create_model("moglow", other, ctx);
  EXPECT_THROW(fold_into_mean(*a, *d, 1), Error);
  EXPECT_THROW(fold_into_mean(*a, *b, 0), Error);
  for (const auto& p : a->named_parameters())  // a refused fold changes nothing
    EXPECT_TRUE(torch::allclose(p.value(), expected.at(p.key()), 1e-5, 1e-6)) << p.key();
}
