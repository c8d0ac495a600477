// The trainer: a run directory, the model's stages one after another, checkpoints and resume.
// Run-directory plumbing is in run_dir.*, batches in batches.*, stage resolution and optimisers
// in stage_setup.*, the options' JSON in train_options.cpp, the process group of data-parallel
// runs in distributed.*.
#include <ATen/CPUGeneratorImpl.h>
#include <torch/types.h>
// clip_grad.h relies on torch/types.h being included first.
#include <torch/nn/utils/clip_grad.h>
#include <torch/cuda.h>
#include <torch/utils.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "io/json_number.h"
#include "nn/checkpoint.h"
#include "nn/cpu_block_cache.h"
#include "nn/model.h"
#include "nn/run_info.h"
#include "nn/training/batches.h"
#include "nn/training/distributed.h"
#include "nn/training/run_dir.h"
#include "nn/training/stage_setup.h"
#include "nn/training/train.h"

namespace mosyn::nn {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_options(const TrainOptions& opts) {
  if (opts.out_dir.empty()) throw Error("train: no output (run) directory given");
  if (opts.steps < 1) throw Error("train: steps must be >= 1");
  if (opts.batch < 1) throw Error("train: batch must be >= 1");
  if (opts.checkpoint_every < 1) throw Error("train: checkpoint_every must be >= 1");
  if (opts.log_every < 1) throw Error("train: log_every must be >= 1");
  if (opts.lr <= 0) throw Error("train: lr must be positive");
  if (opts.resume && !opts.init_from.empty()) throw Error("train: resume and init_from exclude each other");
  if (opts.batch < opts.distributed.world_size)
    throw Error("train: the batch (" + std::to_string(opts.batch) + " windows, global) is smaller than the world size (" +
                std::to_string(opts.distributed.world_size) + " processes)");
}

// Every rank's device: "cuda" without an index picks the GPU of the rank's LOCAL_RANK.
torch::Device rank_device(const TrainOptions& opts) {
  torch::Device d = parse_device(opts.device);
  const DistributedOptions& dist = opts.distributed;
  if (d.is_cuda() && !d.has_index() && dist.enabled()) {
    const int count = static_cast<int>(torch::cuda::device_count());
    if (count > 0) d = torch::Device(torch::kCUDA, static_cast<c10::DeviceIndex>(
                                                       dist.local_rank >= 0 ? dist.local_rank : dist.rank % count));
  }
  return d;
}

// The windows [begin, begin + count) of a global batch (or validation set) of n that rank r of
// world reads: contiguous, sizes differing by at most one, in rank order, so that the ranks
// together read exactly what one process reads.
struct Shard {
  size_t begin = 0, count = 0;
};
Shard shard_of(size_t n, int rank, int world) {
  const size_t lo = n * rank / world, hi = n * (rank + 1) / world;
  return {lo, hi - lo};
}

std::string rng_to_string(const std::mt19937_64& rng) {
  std::ostringstream s;
  s << rng;
  return s.str();
}

// One training run: set up in the constructor, trained by run().
class Trainer {
 public:
  Trainer(const TrainOptions& opts, const data::Dataset& dataset, const TrainCallbacks& cb);
  ~Trainer();
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;
  TrainResult run();

 private:
  void message(const std::string& m) const {
    if (leader() && cb_.on_message) cb_.on_message(m);
  }
  bool leader() const { return rank_ == 0; }
  void connect();
  void open_run_directory();
  std::string resolve_model();
  void build_model(const nlohmann::json& model_config);
  void prepare_data();
  void start_or_resume();
  void write_config();
  void resume_from_checkpoint();
  void locate_resume(const CheckpointState& state);
  bool run_stage();
  void enter_stage();
  bool train_step(const TrainingStage& stage, bool stop_requested);
  bool reduce_step(LossTerms& terms, double& loss, const Shard& shard, bool alone, bool stop_requested);
  void after_step(const LossTerms& terms, double loss, double lr, bool stage_end);
  void report(const LossTerms& terms, double loss, double lr, double val, bool has_val);
  double validate();
  void save(const std::string& path);
  [[noreturn]] void fail(const std::string& what, int step) const;

  TrainOptions opts_;  // a copy: the other ranks of a data-parallel run take rank 0's (constructor)
  const data::Dataset& dataset_;
  const TrainCallbacks& cb_;
  const training::RunPaths paths_;
  std::unique_ptr<training::RunLock> lock_;  // rank 0's
  std::unique_ptr<ProcessGroup> group_;      // data-parallel runs only
  int rank_ = 0, world_ = 1;
  std::string resume_checkpoint_;  // what resuming loads: the run's checkpoint, or rank 0's copy
  bool resume_copy_ = false;       // resume_checkpoint_ is a private copy, removed once loaded
  torch::Device device_;
  ModelContext context_;
  std::string family_;
  std::shared_ptr<TrainableModel> model_;
  std::vector<TrainingStage> stages_;
  int total_steps_ = 0;
  training::SplitWindows train_, val_;
  std::unique_ptr<training::BatchMaker> maker_;
  std::unique_ptr<training::LogAppender> log_;
  std::mt19937_64 rng_;
  std::uniform_int_distribution<size_t> pick_;  // window_sampling "windows" without speed_balance or label_weights
  std::optional<std::discrete_distribution<size_t>> pick_weighted_;  // "frames", speed_balance or label_weights
  std::vector<data::WindowRef> chosen_;
  int step_ = 0;        // optimiser steps done, over all stages
  int stage_ = 0;       // current stage
  int stage_step_ = 0;  // steps done in it
  bool resume_pending_ = false;  // the current stage's optimiser state is still in the checkpoint
  double best_val_ = kNaN;  // NaN = not validated yet (a validation NLL may be negative)
  std::map<std::string, double> val_terms_;  // the last validation's term means (not "loss")
  training::StageParams params_;
  std::unique_ptr<torch::optim::Optimizer> optimizer_;
  Clock::time_point t0_, t_last_;
  int step_last_ = 0;
  double rate_ = 0;  // smoothed steps per second
  TrainResult result_;
};

Trainer::Trainer(const TrainOptions& opts, const data::Dataset& dataset, const TrainCallbacks& cb)
    : opts_(opts), dataset_(dataset), cb_(cb), paths_(fs::path(opts.out_dir)), device_(torch::kCPU) {
  check_options(opts_);
  set_num_threads(opts_.threads);
  use_cpu_block_cache();  // a step reallocates the same large activations: keep them (cpu_block_cache.h)
  device_ = rank_device(opts_);
  if (opts_.distributed.enabled()) connect();
  context_ = context_for(dataset.info(), dataset.stats());
  if (context_.pose_dim <= 0) throw Error("train: the dataset has no pose dimensions");
  if (static_cast<int>(dataset.stats().pose_std.size()) != context_.pose_dim ||
      static_cast<int>(dataset.stats().control_std.size()) != context_.control_dim)
    throw Error("train: dataset statistics do not match its feature layout");
  // Rank 0 alone owns the run directory; what it decides (family, model config, options) rules.
  const auto setup = nlohmann::json::parse(group_ ? share_from_root(*group_, [this] { return resolve_model(); })
                                                  : resolve_model());
  if (!leader()) {
    TrainOptions theirs = TrainOptions::from_json(setup.at("train"));
    theirs.data_dir = opts_.data_dir;
    theirs.out_dir = opts_.out_dir;
    theirs.threads = opts_.threads;
    theirs.device = opts_.device;
    theirs.distributed = opts_.distributed;
    theirs.resume = setup.at("resume").get<bool>();
    opts_ = theirs;
  }
  family_ = setup.at("family").get<std::string>();
  auto prepare = [&] {
    build_model(setup.at("model"));
    prepare_data();
    // What must agree between ranks: the model's size and the data each one reads.
    int64_t size = 0;
    for (const auto& p : model_->parameters()) size += p.numel();
    return family_ + " " + std::to_string(size) + " parameters, " + std::to_string(train_.windows.size()) +
           " training and " + std::to_string(val_.windows.size()) + " validation windows of " +
           std::to_string(train_.window) + " frames, pose " + std::to_string(context_.pose_dim) + ", control " +
           std::to_string(context_.control_dim);
  };
  if (group_) check_agreement(*group_, prepare, "model and dataset");
  else prepare();
  start_or_resume();
}

Trainer::~Trainer() {
  std::error_code ec;
  if (resume_copy_) fs::remove(resume_checkpoint_, ec);
}

// Joins the data-parallel group of the launcher's environment (nn/training/distributed.h).
void Trainer::connect() {
  group_ = std::make_unique<ProcessGroup>(opts_.distributed, device_);
  rank_ = group_->rank();
  world_ = group_->world_size();
}

// Rank 0: checks and locks the run directory, then the family and model config to build, as JSON
// {"family", "model", "train" (the options), "resume"} for the other ranks.
std::string Trainer::resolve_model() {
  const bool existed = training::check_run_directory(paths_, opts_.resume, opts_.overwrite);
  lock_ = std::make_unique<training::RunLock>(paths_.dir);  // before touching anything
  training::clear_run(paths_, opts_.resume, existed);
  std::string family = opts_.family;
  nlohmann::json model_config = opts_.model_config;
  if (opts_.resume) {
    const auto saved = io::read_json(paths_.config);
    family = saved.at("family").get<std::string>();
    model_config = saved.at("model");
  } else if (!opts_.init_from.empty()) {
    model_config = training::init_model_config(opts_.init_from, family, model_config);
  }
  return nlohmann::json{{"family", family}, {"model", model_config}, {"train", opts_.to_json()}, {"resume", opts_.resume}}
      .dump();
}

void Trainer::build_model(const nlohmann::json& model_config) {
  torch::manual_seed(opts_.seed);  // the same initial weights on every rank
  model_ = create_trainable(family_, model_config, context_);
  model_->to(device_);
  // A warm start is read by rank 0 and reaches the others with its weights (start_or_resume).
  if (leader() && !opts_.resume && !opts_.init_from.empty()) {
    const std::string from = (fs::path(opts_.init_from) / "checkpoint.pt").string();
    const InitLabels labels{training::init_label_vocabularies(opts_.init_from),
                            {dataset_.info().content_labels, dataset_.info().style_labels}};
    const InitReport r = init_from_checkpoint(from, *model_, device_, &labels);
    std::string text = "initialised from " + from + " (step " + std::to_string(r.step) + "): " +
                       std::to_string(r.copied) + " tensors copied";
    if (!r.grown.empty()) text += ", " + std::to_string(r.grown.size()) + " grown (new inputs and units start silent)";
    if (!r.relabelled.empty())
      text += ", " + std::to_string(r.relabelled.size()) + " label inputs matched by label name (new labels start at zero)";
    if (!r.missing.empty()) text += ", " + std::to_string(r.missing.size()) + " left as initialised";
    message(text);
  }
  stages_ = model_->training_stages(stage_defaults(opts_));
  check_stages(stages_, family_);
  total_steps_ = 0;
  for (const auto& s : stages_) {
    training::resolve_stage(*model_, s);  // every stage's prefixes fit, before any step
    total_steps_ += s.steps;
  }
}

namespace {

// "label weights: run:elderly x3 3.1% -> 8.8% of the draws" for the log.
std::string label_weights_message(const training::SplitWindows& split, const std::vector<double>& before,
                                  const std::vector<double>& after,
                                  const std::vector<training::LabelWeight>& entries) {
  std::ostringstream out;
  out << "label weights: share of the draws";
  for (const training::LabelWeight& e : entries) {
    out << (&e == &entries.front() ? " " : ", ") << e.key << " x" << e.factor << " " << std::fixed
        << std::setprecision(1) << 100 * training::label_share(split, before, e) << "% -> "
        << 100 * training::label_share(split, after, e) << "%";
    out.unsetf(std::ios::fixed);
  }
  return out.str();
}

// "speed balance: draws per mean root speed 0-0.5 m/s 3% -> 9%, ..." for the log.
std::string speed_balance_message(const std::map<int, double>& before, const std::map<int, double>& after) {
  std::ostringstream out;
  out << "speed balance: share of the draws per mean root speed (m/s)";
  for (const auto& [bin, share] : before) {
    out << (bin == before.begin()->first ? " " : ", ") << std::fixed << std::setprecision(1)
        << bin * training::kSpeedBinMps << "-" << (bin + 1) * training::kSpeedBinMps << " " << 100 * share << "% -> "
        << 100 * after.at(bin) << "%";
  }
  return out.str();
}

}  // namespace

void Trainer::prepare_data() {
  const int window = opts_.window > 0 ? opts_.window : dataset_.info().window_frames;
  if (window < 2) throw Error("train: window must be at least 2 frames (set window)");
  const int min_short = model_->short_window_min_frames();
  train_ = training::training_windows(dataset_, window, min_short);
  val_ = training::validation_windows(dataset_, window, opts_.val_windows, min_short);
  train_.control_after = val_.control_after = model_->control_frames_after();
  if (const std::string w = training::left_out_warning(dataset_, window, min_short); !w.empty()) message(w);
  maker_ = std::make_unique<training::BatchMaker>(dataset_, context_.pose_dim, context_.control_dim, device_);
  pick_ = std::uniform_int_distribution<size_t>(0, train_.windows.size() - 1);
  if (opts_.window_sampling == "frames" || opts_.speed_balance > 0 || !opts_.label_weights.empty()) {
    std::vector<double> weights = opts_.window_sampling == "frames" ? training::clip_frame_weights(train_)
                                                                    : std::vector<double>(train_.windows.size(), 1.0);
    if (!opts_.label_weights.empty()) {
      const auto entries = training::resolve_label_weights(opts_.label_weights, dataset_.info().content_labels,
                                                           dataset_.info().style_labels);
      const std::vector<double> weighted = training::label_weighted(train_, weights, entries);
      message(label_weights_message(train_, weights, weighted, entries));
      weights = weighted;
    }
    if (opts_.speed_balance > 0) {
      training::SpeedBalance balance = training::speed_balanced(train_, weights, context_.control_dim,
                                                                dataset_.info().fps, opts_.speed_balance);
      message(speed_balance_message(balance.shares_before, balance.shares_after));
      weights = std::move(balance.weights);
    }
    pick_weighted_.emplace(weights.begin(), weights.end());
  }
  chosen_.resize(opts_.batch);
}

void Trainer::start_or_resume() {
  // The data order is drawn alike on every rank: each draws the whole global batch and reads its
  // shard of it.
  rng_.seed(opts_.seed * 0x9E3779B97F4A7C15ull + 1);
  resume_checkpoint_ = paths_.checkpoint;
  if (leader()) log_ = std::make_unique<training::LogAppender>(paths_.log);
  if (!opts_.resume) {
    if (leader()) write_config();
    if (group_) broadcast_module(*group_, *model_);  // rank 0's weights (a warm start's, too)
  } else if (group_) {
    check_agreement(*group_, [this] { resume_from_checkpoint(); return std::to_string(step_); }, "checkpoint step");
  } else {
    resume_from_checkpoint();
  }
  // Dropout masks differ between ranks, as the windows they draw them for do.
  if (!leader()) torch::manual_seed(opts_.seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull * rank_ + step_);
}

void Trainer::write_config() {
  nlohmann::json config = {{"format", "mosyn-run-1"},
                           {"family", family_},
                           {"model", model_->config()},
                           {"context", context_to_json(context_)},
                           {"train", opts_.to_json()},
                           {"world_size", world_},
                           {"dataset", data::info_to_json(dataset_.info())}};
  config["train"]["window"] = train_.window;
  io::write_json(paths_.config, config);
  io::write_json(paths_.stats, data::stats_to_json(dataset_.stats()));
}

// The model, the step and the data order from the checkpoint (the optimiser state when its stage
// is entered, enter_stage). The other ranks load rank 0's checkpoint, sent to them, so resuming
// needs no shared file system and works at any world size.
void Trainer::resume_from_checkpoint() {
  if (group_) {
    const std::string bytes = share_from_root(*group_, [this] {
      std::ifstream in(paths_.checkpoint, std::ios::binary);
      std::string b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (!in.good() && !in.eof()) throw Error(paths_.checkpoint + ": cannot read the checkpoint");
      return b;
    });
    if (!leader()) {
      resume_checkpoint_ = (fs::temp_directory_path() / ("mosyn-resume-" + std::to_string(::getpid()) + ".pt")).string();
      resume_copy_ = true;
      std::ofstream out(resume_checkpoint_, std::ios::binary);
      out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      if (!out.flush()) throw Error(resume_checkpoint_ + ": cannot write rank 0's checkpoint here");
    }
  }
  const auto state = load_checkpoint(resume_checkpoint_, *model_, nullptr, device_);
  step_ = state.step;
  best_val_ = state.best_val_loss;
  std::istringstream s(state.data_rng);
  s >> rng_;
  if (s.fail()) throw Error(paths_.checkpoint + ": corrupt data-order RNG state");
  locate_resume(state);
  if (!leader()) return;
  if (state.torch_rng.defined()) {
    auto gen = at::detail::getDefaultCPUGenerator();  // a handle sharing the global state
    gen.set_state(state.torch_rng);
  }
  // Drop what was logged after the checkpoint (and a line torn by a crash).
  training::truncate_log(paths_.log, step_);
  nlohmann::json config = io::read_json(paths_.config);
  const int before = io::json_value(config, "world_size", 1);
  if (before != world_) {
    config["world_size"] = world_;
    io::write_json(paths_.config, config);
  }
  std::string text = "resumed " + opts_.out_dir + " at step " + std::to_string(step_);
  if (stages_.size() > 1)
    text += " (stage " + std::to_string(stage_ + 1) + "/" + std::to_string(stages_.size()) + " '" +
            stages_[stage_].name + "', step " + std::to_string(stage_step_) + ")";
  if (before != world_) text += " with " + std::to_string(world_) + " processes (was " + std::to_string(before) + ")";
  message(text);
}

// The stage and step within it where a checkpoint ended: as recorded, or for a checkpoint made
// before stages, by counting the global step through the stages.
void Trainer::locate_resume(const CheckpointState& state) {
  if (state.stage >= 0) {
    if (state.stage >= static_cast<int>(stages_.size()))
      throw Error(paths_.checkpoint + ": the checkpoint is in training stage " + std::to_string(state.stage + 1) +
                  " but the " + family_ + " family declares " + std::to_string(stages_.size()));
    stage_ = state.stage;
    stage_step_ = state.stage_step;
  } else {
    int rest = step_;
    stage_ = 0;
    while (stage_ + 1 < static_cast<int>(stages_.size()) && rest > stages_[stage_].steps)
      rest -= stages_[stage_++].steps;
    stage_step_ = rest;
  }
  resume_pending_ = true;
}

TrainResult Trainer::run() {
  result_.run_dir = opts_.out_dir;
  t0_ = t_last_ = Clock::now();
  step_last_ = step_;
  for (; stage_ < static_cast<int>(stages_.size()); ++stage_, stage_step_ = 0) {
    if (!run_stage()) {
      result_.stopped_early = true;
      break;
    }
  }
  result_.step = step_;
  result_.best_val_loss = best_val_;
  return result_;
}

// Runs the current stage's remaining steps; false when should_stop ended the run.
bool Trainer::run_stage() {
  const TrainingStage& stage = stages_[stage_];
  if (stage_step_ >= stage.steps) {  // resumed at (or past) the end of this stage
    resume_pending_ = false;
    return true;
  }
  enter_stage();
  while (stage_step_ < stage.steps) {
    const bool stop = cb_.should_stop && cb_.should_stop();
    // One process stops before the step; a group finishes the step in which any rank asked, so
    // that all stop together (the request travels with the step's gradients).
    if ((stop && !group_) || train_step(stage, stop)) {
      save(paths_.checkpoint);
      message("stopped at step " + std::to_string(step_) + "; checkpoint saved");
      return false;
    }
  }
  return true;
}

// A fresh optimiser over the stage's parameters, frozen modules in eval mode; on resume the
// optimiser state from the checkpoint. Best-validation tracking restarts with each later stage.
void Trainer::enter_stage() {
  const TrainingStage& stage = stages_[stage_];
  params_ = training::resolve_stage(*model_, stage);
  training::apply_training_mode(*model_, params_);
  optimizer_ = training::make_optimizer(stage.optimizer, params_);
  if (resume_pending_) {
    load_checkpoint(resume_checkpoint_, *model_, optimizer_.get(), device_);
    resume_pending_ = false;
    if (resume_copy_) fs::remove(resume_checkpoint_);
    resume_copy_ = false;
  } else if (stage_ > 0 && stage_step_ == 0) {
    best_val_ = kNaN;
  }
  model_->begin_stage(stage_, stage);
  if (stages_.size() > 1)
    message(training::describe_stage(stage, stage_, static_cast<int>(stages_.size()), params_));
}

// One optimiser step; true when a rank of a data-parallel run asked to stop (the step is done).
bool Trainer::train_step(const TrainingStage& stage, bool stop_requested) {
  const int next = step_ + 1;
  const double lr = scheduled_lr(stage.schedule, stage.optimizer.lr, stage_step_ + 1, stage.steps);
  training::set_learning_rate(*optimizer_, lr);
  for (auto& w : chosen_) w = train_.windows[pick_weighted_ ? (*pick_weighted_)(rng_) : pick_(rng_)];
  // A stage's first step runs on rank 0 alone with the whole batch: what a model initialises from
  // its first batch (MoGlow's ActNorm) then sees what one process sees, and reaches the others.
  const bool alone = group_ && stage_step_ == 0;
  const Shard shard = alone ? Shard{0, leader() ? chosen_.size() : 0} : shard_of(chosen_.size(), rank_, world_);
  model_->set_progress(next, total_steps_);
  optimizer_->zero_grad();
  LossTerms terms;
  double loss = 0;
  if (shard.count > 0) {
    const std::vector<data::WindowRef> mine(chosen_.begin() + shard.begin, chosen_.begin() + shard.begin + shard.count);
    terms = model_->loss(maker_->make(train_, mine));
    loss = terms.loss().item<double>();
    if (!group_ && !std::isfinite(loss)) fail("non-finite loss (" + std::to_string(loss) + ")", next);
    terms.loss().backward();
  }
  bool stop = false;
  if (group_) {
    if (alone) broadcast_module(*group_, *model_);
    stop = reduce_step(terms, loss, shard, alone, stop_requested);
    if (!std::isfinite(loss)) fail("non-finite loss (" + std::to_string(loss) + ")", next);
  }
  {
    // The norm is checked even without clipping, so a NaN gradient never reaches a checkpoint.
    const double max_norm = opts_.grad_clip > 0 ? opts_.grad_clip : std::numeric_limits<double>::infinity();
    const double norm = torch::nn::utils::clip_grad_norm_(params_.trained, max_norm);
    if (!std::isfinite(norm)) fail("non-finite gradient norm", next);
  }
  optimizer_->step();
  step_ = next;
  ++stage_step_;
  result_.last_loss = loss;
  after_step(terms, loss, lr, stage_step_ == stage.steps);
  return stop;
}

// Averages the gradients of the global batch over the ranks (after the backward, before
// clipping), and the loss and its terms with them: each rank weighs its shard by its share of the
// batch, so the result is what one process computes on the whole batch. Leaves the global values
// in loss and terms; returns whether any rank asked to stop.
bool Trainer::reduce_step(LossTerms& terms, double& loss, const Shard& shard, bool alone, bool stop_requested) {
  const double weight = static_cast<double>(shard.count) / static_cast<double>(chosen_.size());
  std::vector<double> scalars = {loss * weight, stop_requested ? 1.0 : 0.0};
  // The terms are reduced when every rank has them; a step on rank 0 alone has them whole there.
  std::vector<std::string> names;
  if (!alone)
    for (const auto& kv : terms.terms)
      if (kv.first != "loss") {
        names.push_back(kv.first);
        scalars.push_back(kv.second.item<double>() * weight);
      }
  const std::vector<double> sums = allreduce_gradients(*group_, params_.trained, weight, scalars);
  loss = sums[0];
  for (size_t i = 0; i < names.size(); ++i) terms.terms[names[i]] = torch::tensor(sums[2 + i]);
  return sums[1] > 0;
}

// Validation, progress and checkpoints at their intervals and at the end of every stage.
void Trainer::after_step(const LossTerms& terms, double loss, double lr, bool stage_end) {
  const bool do_val = opts_.validate_every > 0 && (step_ % opts_.validate_every == 0 || stage_end);
  double val = kNaN;
  if (do_val) {
    val = validate();
    if (std::isfinite(val) && (!std::isfinite(best_val_) || val < best_val_)) {
      best_val_ = val;
      if (leader()) save(paths_.best);
    }
  }
  if (!leader()) return;
  if (step_ % opts_.log_every == 0 || do_val || stage_end) report(terms, loss, lr, val, do_val && std::isfinite(val));
  if (step_ % opts_.checkpoint_every == 0 || stage_end) {
    save(paths_.checkpoint);
    // The same bytes, not a second serialisation of the model and optimiser.
    if (opts_.keep_checkpoints)
      io::write_file_atomically(paths_.kept_checkpoint(step_), io::read_file(paths_.checkpoint));
  }
}

void Trainer::report(const LossTerms& terms, double loss, double lr, double val, bool has_val) {
  const auto now = Clock::now();
  const double dt = std::chrono::duration<double>(now - t_last_).count();
  if (dt > 0 && step_ > step_last_) {
    const double r = (step_ - step_last_) / dt;
    rate_ = rate_ == 0 ? r : 0.7 * rate_ + 0.3 * r;
  }
  t_last_ = now;
  step_last_ = step_;
  TrainProgress p;
  p.step = step_;
  p.total_steps = total_steps_;
  p.stage = stages_[stage_].name;
  p.stage_index = stage_;
  p.num_stages = static_cast<int>(stages_.size());
  p.stage_step = stage_step_;
  p.stage_steps = stages_[stage_].steps;
  p.loss = loss;
  for (const auto& kv : terms.terms)
    if (kv.first != "loss") p.metrics[kv.first] = kv.second.item<double>();
  p.has_val = has_val;
  p.val_loss = val;
  p.lr = lr;
  p.steps_per_s = rate_;
  p.eta_s = rate_ > 0 ? (total_steps_ - step_) / rate_ : 0;
  p.elapsed_s = std::chrono::duration<double>(now - t0_).count();
  nlohmann::json line = {{"step", step_}, {"loss", loss}, {"lr", lr}, {"time_s", p.elapsed_s}};
  for (const auto& kv : p.metrics) line[kv.first] = kv.second;
  if (p.has_val) {
    line["val_loss"] = val;
    for (const auto& [name, value] : val_terms_) line["val_" + name] = value;
  }
  if (p.num_stages > 1) line["stage"] = p.stage;
  log_->append(line.dump());
  if (cb_.on_progress) cb_.on_progress(p);
}

// The mean loss over the validation windows; in a data-parallel run each rank scores its shard
// of them (in batches of its share of the batch) and the sums are added up. The means of the
// model's other terms go to val_terms_ (logged as "val_<term>").
double Trainer::validate() {
  val_terms_.clear();
  if (val_.windows.empty()) return kNaN;
  torch::NoGradGuard no_grad;
  model_->eval();
  const Shard shard = shard_of(val_.windows.size(), rank_, world_);
  const size_t batch = (static_cast<size_t>(opts_.batch) + world_ - 1) / world_;
  double total = 0, n = 0;
  std::map<std::string, double> term_sums;
  for (size_t b = 0; b < shard.count; b += batch) {
    const size_t count = std::min(batch, shard.count - b);
    auto terms = model_->loss(maker_->make(val_, shard.begin + b, count));
    total += terms.loss().item<double>() * count;
    for (const auto& [name, value] : terms.terms)
      if (name != "loss" && value.numel() == 1) term_sums[name] += value.item<double>() * count;
    n += count;
  }
  training::restore_training_mode(*model_, params_);
  if (group_) {
    // Every rank's model returns the same term names (a std::map: the same order).
    std::vector<double> sums = {total, n};
    for (const auto& kv : term_sums) sums.push_back(kv.second);
    torch::Tensor t = torch::tensor(sums, torch::kDouble);
    group_->allreduce_sum(t);
    total = t[0].item<double>();
    n = t[1].item<double>();
    int64_t i = 2;
    for (auto& kv : term_sums) kv.second = t[i++].item<double>();
  }
  for (const auto& [name, sum] : term_sums) val_terms_[name] = sum / n;
  return total / n;
}

void Trainer::save(const std::string& path) {
  if (!leader()) return;  // rank 0's state is every rank's
  CheckpointState st;
  st.step = step_;
  st.best_val_loss = best_val_;
  st.data_rng = rng_to_string(rng_);
  st.torch_rng = at::detail::getDefaultCPUGenerator().get_state();
  st.stage = stage_;
  st.stage_step = stage_step_;
  save_checkpoint(path, *model_, optimizer_.get(), st);
}

void Trainer::fail(const std::string& what, int step) const {
  throw Error("training diverged: " + what + " at step " + std::to_string(step) +
              (fs::exists(paths_.checkpoint) ? "; the last good checkpoint (" + paths_.checkpoint + ") is kept"
                                             : "; no checkpoint was written yet"));
}

}  // namespace

TrainResult train(const TrainOptions& opts, const data::Dataset& dataset, const TrainCallbacks& cb) {
  Trainer trainer(opts, dataset, cb);
  return trainer.run();
}

}  // namespace mosyn::nn
