// The trainer: a run directory, the model's stages one after another, checkpoints and resume.
// Run-directory plumbing is in run_dir.*, batches in batches.*, stage resolution and optimisers
// in stage_setup.*, the options' JSON in train_options.cpp.
#include <ATen/CPUGeneratorImpl.h>
#include <torch/types.h>
// clip_grad.h relies on torch/types.h being included first.
#include <torch/nn/utils/clip_grad.h>
#include <torch/utils.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

#include "core/error.h"
#include "io/json_file.h"
#include "nn/checkpoint.h"
#include "nn/model.h"
#include "nn/run_info.h"
#include "nn/training/batches.h"
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
  TrainResult run();

 private:
  void message(const std::string& m) const {
    if (cb_.on_message) cb_.on_message(m);
  }
  void build_model();
  void prepare_data();
  void start_or_resume();
  void locate_resume(const CheckpointState& state);
  bool run_stage();
  void enter_stage();
  void train_step(const TrainingStage& stage);
  void after_step(const LossTerms& terms, double loss, double lr, bool stage_end);
  void report(const LossTerms& terms, double loss, double lr, double val, bool has_val);
  double validate();
  void save(const std::string& path);
  [[noreturn]] void fail(const std::string& what, int step) const;

  const TrainOptions& opts_;
  const data::Dataset& dataset_;
  const TrainCallbacks& cb_;
  const training::RunPaths paths_;
  std::unique_ptr<training::RunLock> lock_;
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
  std::uniform_int_distribution<size_t> pick_;
  std::vector<data::WindowRef> chosen_;
  int step_ = 0;        // optimiser steps done, over all stages
  int stage_ = 0;       // current stage
  int stage_step_ = 0;  // steps done in it
  bool resume_pending_ = false;  // the current stage's optimiser state is still in the checkpoint
  double best_val_ = kNaN;  // NaN = not validated yet (a validation NLL may be negative)
  training::StageParams params_;
  std::unique_ptr<torch::optim::Optimizer> optimizer_;
  Clock::time_point t0_, t_last_;
  int step_last_ = 0;
  double rate_ = 0;  // smoothed steps per second
  TrainResult result_;
};

Trainer::Trainer(const TrainOptions& opts, const data::Dataset& dataset, const TrainCallbacks& cb)
    : opts_(opts), dataset_(dataset), cb_(cb), paths_(fs::path(opts.out_dir)), device_(torch::kCPU) {
  check_options(opts);
  set_num_threads(opts.threads);
  device_ = parse_device(opts.device);
  const bool existed = training::check_run_directory(paths_, opts.resume, opts.overwrite);
  lock_ = std::make_unique<training::RunLock>(paths_.dir);  // before touching anything
  training::clear_run(paths_, opts.resume, existed);
  context_ = context_for(dataset.info(), dataset.stats());
  if (context_.pose_dim <= 0) throw Error("train: the dataset has no pose dimensions");
  if (static_cast<int>(dataset.stats().pose_std.size()) != context_.pose_dim ||
      static_cast<int>(dataset.stats().control_std.size()) != context_.control_dim)
    throw Error("train: dataset statistics do not match its feature layout");
  build_model();
  prepare_data();
  start_or_resume();
}

void Trainer::build_model() {
  family_ = opts_.family;
  nlohmann::json model_config = opts_.model_config;
  if (opts_.resume) {
    const auto saved = io::read_json(paths_.config);
    family_ = saved.at("family").get<std::string>();
    model_config = saved.at("model");
  } else if (!opts_.init_from.empty()) {
    model_config = training::init_model_config(opts_.init_from, family_, model_config);
  }
  torch::manual_seed(opts_.seed);
  model_ = create_trainable(family_, model_config, context_);
  model_->to(device_);
  if (!opts_.resume && !opts_.init_from.empty()) {
    const std::string from = (fs::path(opts_.init_from) / "checkpoint.pt").string();
    const InitReport r = init_from_checkpoint(from, *model_, device_);
    std::string text = "initialised from " + from + " (step " + std::to_string(r.step) + "): " +
                       std::to_string(r.copied) + " tensors copied";
    if (!r.grown.empty()) text += ", " + std::to_string(r.grown.size()) + " grown (new inputs start at zero)";
    if (!r.missing.empty()) text += ", " + std::to_string(r.missing.size()) + " left as initialised";
    message(text);
  }
  stages_ = model_->training_stages(stage_defaults(opts_));
  check_stages(stages_, family_);
  for (const auto& s : stages_) {
    training::resolve_stage(*model_, s);  // every stage's prefixes fit, before any step
    total_steps_ += s.steps;
  }
}

void Trainer::prepare_data() {
  const int window = opts_.window > 0 ? opts_.window : dataset_.info().window_frames;
  if (window < 2) throw Error("train: window must be at least 2 frames (set window)");
  train_ = training::training_windows(dataset_, window);
  val_ = training::validation_windows(dataset_, window, opts_.val_windows);
  maker_ = std::make_unique<training::BatchMaker>(dataset_, context_.pose_dim, context_.control_dim, device_);
  pick_ = std::uniform_int_distribution<size_t>(0, train_.windows.size() - 1);
  chosen_.resize(opts_.batch);
}

void Trainer::start_or_resume() {
  rng_.seed(opts_.seed * 0x9E3779B97F4A7C15ull + 1);
  log_ = std::make_unique<training::LogAppender>(paths_.log);
  if (!opts_.resume) {
    nlohmann::json config = {{"format", "mosyn-run-1"},
                             {"family", family_},
                             {"model", model_->config()},
                             {"context", context_to_json(context_)},
                             {"train", opts_.to_json()},
                             {"dataset", data::info_to_json(dataset_.info())}};
    config["train"]["window"] = train_.window;
    io::write_json(paths_.config, config);
    io::write_json(paths_.stats, data::stats_to_json(dataset_.stats()));
    return;
  }
  // The model now; the optimiser state when its stage is entered (enter_stage).
  const auto state = load_checkpoint(paths_.checkpoint, *model_, nullptr, device_);
  step_ = state.step;
  best_val_ = state.best_val_loss;
  std::istringstream s(state.data_rng);
  s >> rng_;
  if (s.fail()) throw Error(paths_.checkpoint + ": corrupt data-order RNG state");
  if (state.torch_rng.defined()) {
    auto gen = at::detail::getDefaultCPUGenerator();  // a handle sharing the global state
    gen.set_state(state.torch_rng);
  }
  locate_resume(state);
  // Drop what was logged after the checkpoint (and a line torn by a crash).
  training::truncate_log(paths_.log, step_);
  std::string text = "resumed " + opts_.out_dir + " at step " + std::to_string(step_);
  if (stages_.size() > 1)
    text += " (stage " + std::to_string(stage_ + 1) + "/" + std::to_string(stages_.size()) + " '" +
            stages_[stage_].name + "', step " + std::to_string(stage_step_) + ")";
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
    if (cb_.should_stop && cb_.should_stop()) {
      save(paths_.checkpoint);
      message("stopped at step " + std::to_string(step_) + "; checkpoint saved");
      return false;
    }
    train_step(stage);
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
    load_checkpoint(paths_.checkpoint, *model_, optimizer_.get(), device_);
    resume_pending_ = false;
  } else if (stage_ > 0 && stage_step_ == 0) {
    best_val_ = kNaN;
  }
  model_->begin_stage(stage_, stage);
  if (stages_.size() > 1)
    message(training::describe_stage(stage, stage_, static_cast<int>(stages_.size()), params_));
}

void Trainer::train_step(const TrainingStage& stage) {
  const int next = step_ + 1;
  const double lr = scheduled_lr(stage.schedule, stage.optimizer.lr, stage_step_ + 1, stage.steps);
  training::set_learning_rate(*optimizer_, lr);
  for (auto& w : chosen_) w = train_.windows[pick_(rng_)];
  auto batch = maker_->make(train_, chosen_);
  model_->set_progress(next, total_steps_);
  auto terms = model_->loss(batch);
  const double loss = terms.loss().item<double>();
  if (!std::isfinite(loss)) fail("non-finite loss (" + std::to_string(loss) + ")", next);
  optimizer_->zero_grad();
  terms.loss().backward();
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
}

// Validation, progress and checkpoints at their intervals and at the end of every stage.
void Trainer::after_step(const LossTerms& terms, double loss, double lr, bool stage_end) {
  const bool do_val = opts_.validate_every > 0 && (step_ % opts_.validate_every == 0 || stage_end);
  double val = kNaN;
  if (do_val) {
    val = validate();
    if (std::isfinite(val) && (!std::isfinite(best_val_) || val < best_val_)) {
      best_val_ = val;
      save(paths_.best);
    }
  }
  if (step_ % opts_.log_every == 0 || do_val || stage_end) report(terms, loss, lr, val, do_val && std::isfinite(val));
  if (step_ % opts_.checkpoint_every == 0 || stage_end) save(paths_.checkpoint);
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
  if (p.has_val) line["val_loss"] = val;
  if (p.num_stages > 1) line["stage"] = p.stage;
  log_->append(line.dump());
  if (cb_.on_progress) cb_.on_progress(p);
}

double Trainer::validate() {
  if (val_.windows.empty()) return kNaN;
  torch::NoGradGuard no_grad;
  model_->eval();
  double total = 0;
  size_t n = 0;
  for (size_t b = 0; b < val_.windows.size(); b += opts_.batch) {
    const size_t count = std::min<size_t>(opts_.batch, val_.windows.size() - b);
    auto terms = model_->loss(maker_->make(val_, b, count));
    total += terms.loss().item<double>() * count;
    n += count;
  }
  training::restore_training_mode(*model_, params_);
  return total / n;
}

void Trainer::save(const std::string& path) {
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
