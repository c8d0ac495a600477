// Training of any model family (nn/model.h) on a prepared dataset, into a run directory.
//
// A run directory holds
//   config.json    {"format": "mosyn-run-1", "family", "model" (resolved model config),
//                   "context" (ModelContext), "train" (TrainOptions), "world_size" (processes of
//                   the latest start or resume), "dataset" (skeleton, layout, fps, window, label
//                   vocabularies, file split: nn/run_info.h)}
//   stats.json     the dataset's standardisation statistics (nn/run_info.h stats_to_json)
//   checkpoint.pt  latest state: model parameters and buffers, the current stage's optimiser
//                  state, step, stage and step within it, data-order RNG, torch CPU RNG, best
//                  validation loss (LibTorch archive)
//   best.pt        the same at the step with the lowest validation loss so far (of the latest
//                  stage reached: losses of different stages need not be comparable)
//   checkpoint-<step>.pt  with TrainOptions::keep_checkpoints, every checkpoint.pt as written
//   log.jsonl      one JSON object per logged step: {"step", "loss", "lr", "time_s", metrics...}
//                  and, at validation steps, "val_loss" and the mean of each other term as
//                  "val_<term>"; runs of several stages add "stage" (name)
// Every file is written atomically (temporary file + rename), so an interrupted run always
// leaves the previous complete files.
//
// Training runs the model's stages (TrainableModel::training_stages, nn/training/stage.h) one
// after another; most families have one, built from TrainOptions (steps, lr, warmup). Each stage
// starts a fresh optimiser; validation, logging and checkpointing also happen at a stage's end.
//
// Data-parallel training (TrainOptions::distributed, from the launcher's environment:
// nn/training/distributed.h): N processes run the same options on the same dataset. `batch` is
// the global batch: every rank draws the same global batch of windows from the same seeded data
// order and reads its contiguous shard (B/N windows, sizes differing by at most one); after the
// backward each rank's gradients, weighted by its share of the batch, are summed in one flattened
// allreduce, so clipping and the optimiser step see the gradient of the whole batch's mean loss
// and every rank keeps identical weights and optimiser state. This equals one process with batch
// B exactly (up to float rounding) for losses that are means over the batch's windows (MoGlow's
// is; a family whose loss is not checks its own case); what stays per rank are dropout masks and other random draws inside the loss
// (each rank its own torch seed), and buffers a model updates from its data in training. A
// stage's first step runs on rank 0 alone with the whole batch, so that data-dependent
// initialisation (MoGlow's ActNorm) sees what one process sees; its weights then go to every
// rank. Validation is sharded the same way and the sums reduced. Rank 0 alone creates, locks and
// writes the run directory (config, stats, checkpoints, log) and reports progress and messages;
// its options (steps, batch, lr, ...) and, on resume, its checkpoint are sent to the other ranks,
// which need only the dataset (no shared file system), so a run resumes at any world size. A stop
// request on any rank (should_stop) ends every rank after the current step.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <limits>
#include <string>
#include <vector>

#include "data/dataset.h"
#include "nn/options_fields.h"
#include "nn/training/distributed.h"
#include "nn/training/stage.h"

namespace mosyn::nn {

struct TrainOptions {
  std::string family;             // registered model family (nn/registry.h), e.g. from `mosyn train FAMILY`
  std::string data_dir;           // prepared dataset directory (train(options) overload)
  std::string out_dir;            // run directory to create (or resume)
  nlohmann::json model_config = nlohmann::json::object();  // overrides of the family defaults
  int steps = 10000;              // total optimiser steps (on resume: the new total); families with
                                  // several stages divide them as they declare
  int batch = 100;                // windows per batch (global: all ranks of a data-parallel run together)
  int window = 0;                 // frames per window; 0 = the dataset's window_frames
  // How training windows are drawn. "windows": every window alike, so a clip weighs by how many
  // windows it gives (T - window + 1 with hop 1; a padded short clip, one). "frames": a clip is
  // drawn in proportion to its frames and its windows alike within it, so every content and style
  // weighs what it does in the data whatever the window length (with 80-frame windows the
  // Bandai-Namco runs, median 63 frames, hold 22% of the frames but got 6% of the windows).
  std::string window_sampling = "windows";
  // Flattens the draws over mean root speed: each window's weight (as window_sampling gives it)
  // times s^-speed_balance, s the share of the draws held by its clip's 0.5-m/s bin of mean root
  // speed (training::speed_balanced). 0 = off; 1 = every occupied speed bin drawn alike.
  // For data whose rare speeds the model gets wrong (Bandai-Namco's fast runs, 3% of the frames).
  double speed_balance = 0;
  // Draws the windows of some labels more (or less) often: {"CONTENT:STYLE": factor}, "*" on
  // either side for any label (e.g. {"run:elderly": 3}). A window's weight, as window_sampling
  // gives it, is multiplied by the factor of every entry its clip matches, before speed_balance.
  // For a combination the data holds little of at the speeds others fill: the model blends it
  // into its neighbours (Bandai-Namco's elderly runs, 1.2-1.8 m/s, were drawn with the longer
  // stances of walks at those speeds; docs/experiments.md). Empty = off.
  std::map<std::string, double> label_weights;
  double lr = 1e-3;               // peak learning rate (Adam; the default stage's)
  int warmup = 1000;              // Noam warm-up steps: lr * min(s / w, sqrt(w / s)); 0 = constant lr
  double grad_clip = 5.0;         // max global gradient L2 norm; <= 0 disables clipping
  std::uint64_t seed = 1;         // model init, data order and dropout
  int threads = 0;                // CPU threads for LibTorch; 0 = all cores
  std::string device = "cpu";     // "cpu", "cuda" or "cuda:N"
  bool resume = false;            // continue the run in out_dir exactly where its checkpoint ended
  // Warm start from another run or shipped model directory (its checkpoint.pt): same family; its
  // model config is the base that model_config overrides; its weights initialise the model
  // (nn/checkpoint.h init_from_checkpoint), so training accumulates across runs. The step count
  // and optimiser start afresh; the new dataset's statistics are used. Not with resume.
  std::string init_from;
  bool overwrite = false;         // replace an existing run in out_dir
  int checkpoint_every = 500;     // steps between checkpoints (the last step always checkpoints)
  // Also keep every checkpoint as checkpoint-<step>.pt beside checkpoint.pt (the same state), for
  // choosing among steps afterwards (`mosyn export --checkpoint checkpoint-300.pt`, `--average`):
  // continued training can pass its best point within a few hundred steps (docs/experiments.md).
  // --overwrite removes a run's kept checkpoints with the rest.
  bool keep_checkpoints = false;
  int validate_every = 500;       // steps between validations (and at the last step); 0 = never
  int val_windows = 256;          // size of the fixed validation subset (evenly spread windows)
  int log_every = 10;             // steps between progress reports and log lines
  // This process's place in a data-parallel run (see above); not saved in "train" (config.json
  // records "world_size"). Default: one process.
  DistributedOptions distributed;

  // The named preset these options started from ("" = none): train_preset(family, preset) was
  // applied before the other keys. Recorded in to_json as "preset" beside the resolved values.
  std::string preset;

  // Every option above as one field list (nn/options_fields.h), as the model families declare
  // theirs: its keys, types, checks and one-line docs.
  static const OptionFields<TrainOptions>& fields();
  // The options as JSON: every field (label_weights and keep_checkpoints only when set; resume and
  // overwrite never), "family", and "preset" when set.
  nlohmann::json to_json() const;
  // Reads a (partial) JSON object: "family" first, then the preset named by "preset" (if any),
  // then every other key over it, then the value checks. Throws mosyn::Error "training config:
  // ..." for an unknown key, a wrong type, a bad value or an unknown preset.
  static TrainOptions from_json(const nlohmann::json& j);
};

// Named training presets: the keys of TrainOptions that a preset sets. Every family takes
// "smoke" (a handful of steps on a few windows: what `make test` runs the recipes with) and
// "finetune" (continuing a trained model: peak 2e-4, 100 warm-up steps, every 100 steps kept and
// validated); a family adds its own (FamilyInfo::train_presets, e.g. "paper": its paper's
// optimiser settings). Throws mosyn::Error naming the known presets for an unknown one.
nlohmann::json train_preset(const std::string& family, const std::string& name);
// The names train_preset knows for a family ("" = the generic ones only), generic ones first.
std::vector<std::string> train_preset_names(const std::string& family);

// Reported to TrainCallbacks::on_progress every log_every steps and at validations.
struct TrainProgress {
  int step = 0;                 // optimiser steps done, over all stages
  int total_steps = 0;          // of all stages
  std::string stage = "train";  // the current stage's name (TrainingStage::name)
  int stage_index = 0;          // 0-based index of the current stage
  int num_stages = 1;
  int stage_step = 0;           // steps done in the current stage
  int stage_steps = 0;          // steps of the current stage
  double loss = 0.0;            // training loss of this step
  std::map<std::string, double> metrics;  // the model's other loss terms (e.g. nll_frame)
  double val_loss = std::numeric_limits<double>::quiet_NaN();  // validation loss at this step (see has_val)
  bool has_val = false;
  double lr = 0.0;              // learning rate of this step
  double steps_per_s = 0.0;     // recent training throughput
  double eta_s = 0.0;           // estimated seconds to the last step
  double elapsed_s = 0.0;       // wall time of this process's training so far
};

struct TrainCallbacks {
  std::function<void(const TrainProgress&)> on_progress;  // optional
  std::function<void(const std::string&)> on_message;      // optional: "resumed at step 500", ...
  std::function<bool()> should_stop;  // optional: true = checkpoint now and return early
};

struct TrainResult {
  std::string run_dir;
  int step = 0;               // steps done when train returned (over all stages)
  double last_loss = 0.0;     // training loss of the last step
  double best_val_loss = std::numeric_limits<double>::quiet_NaN();  // NaN when never validated
  bool stopped_early = false;   // should_stop returned true
};

// Opens options.data_dir with data::Dataset::open and trains (see the overload).
TrainResult train(const TrainOptions& options, const TrainCallbacks& callbacks = {});

// Trains options.family on the dataset's train split into options.out_dir, stage by stage.
// Resuming continues inside the stage where the checkpoint ended (its optimiser state included).
// Throws mosyn::Error when out_dir exists without resume/overwrite, when resuming finds no
// (or a corrupt) checkpoint, when the dataset has no window long enough, when the family's stages
// are invalid or do not fit the model, and when the loss or gradient becomes NaN/inf (the message
// names the step; the last good checkpoint is kept).
TrainResult train(const TrainOptions& options, const data::Dataset& dataset, const TrainCallbacks& callbacks = {});

// The stage defaults (steps, lr, warmup) of options.
TrainStageDefaults stage_defaults(const TrainOptions& options);

}  // namespace mosyn::nn
