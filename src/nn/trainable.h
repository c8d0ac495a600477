// What the generic trainer (nn/training/train.h) needs of a model: a loss on a batch, a config
// that rebuilds it, and optionally its training stages and schedule hooks. Motion models (nn/model.h) and the classifier
// (nn/classifier/classifier.h) are both trainable models; only motion models generate.
#pragma once

#include <torch/nn/module.h>
#include <torch/types.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nn/training/stage.h"

namespace mosyn::nn {

// One training or validation mini-batch, standardised (x_std = (x_raw - mean) / std per
// dimension with the dataset statistics).
struct Batch {
  torch::Tensor pose;     // [B, T, D] float, standardised
  torch::Tensor control;  // [B, T, C] float, standardised
  torch::Tensor content;  // [B] int64, -1 = none (may be undefined: all none)
  torch::Tensor style;    // [B] int64, -1 = none (may be undefined: all none)
  // [B] int64, valid frames of each window, in 1..T (may be undefined: all T). Only families whose
  // short_window_min_frames() > 0 get windows with fewer: frames past it repeat the last valid one.
  torch::Tensor frames = {};
  // [B, K, C] float, standardised: the control of the K frames that follow each window in its clip
  // (past the clip's end its last frame repeats), K = TrainableModel::control_frames_after().
  // Undefined when the family reads none.
  torch::Tensor control_after = {};
};

// Named scalar tensors returned by TrainableModel::loss. terms["loss"] is the total that the
// optimiser minimises (0-dim, differentiable); the others are detached metrics for logging,
// e.g. "nll_frame" (nats per predicted frame) and "nll_dim" (nats per frame and dimension).
struct LossTerms {
  std::map<std::string, torch::Tensor> terms;
  const torch::Tensor& loss() const { return terms.at("loss"); }
};

// Where a model's label features (nn/label_features.h: one-hot content, then one-hot style) enter
// a parameter: along `axis` of the parameter named `parameter` (as in named_parameters()), from
// column `offset`. A warm start from a run with other vocabularies moves these columns by label
// name (init_from_checkpoint).
struct LabelInput {
  std::string parameter;  // e.g. "control_encoder.convs.0.weight"
  int64_t axis = 1;       // the input axis (1 for Linear [out, in], Conv1d [out, in, k], LSTM weight_ih)
  int64_t offset = 0;     // first label column along axis
};

// A torch::nn::Module whose parameters and buffers are everything a checkpoint must hold besides
// config().
class TrainableModel : public torch::nn::Module {
 public:
  explicit TrainableModel(std::string name) : torch::nn::Module(std::move(name)) {}
  ~TrainableModel() override = default;

  // Family name as registered (nn/registry.h), e.g. "moglow".
  virtual std::string family() const = 0;

  // The fully resolved config (defaults filled in): create_trainable(family(), config(), context)
  // rebuilds the same architecture.
  virtual nlohmann::json config() const = 0;

  // Called by the trainer before every training step (1-based step of total_steps, counted over
  // all stages), so a family can schedule loss weights (e.g. KL annealing) without trainer
  // special cases. Default: no-op.
  virtual void set_progress(int step, int total_steps) {}

  // The stages the trainer runs, in order (nn/training/stage.h): e.g. an autoencoder first, then
  // a prior on its frozen latents. `defaults` carries the run's steps, lr and warm-up (TrainOptions)
  // for the family to build from. The list must not depend on anything but the config and
  // defaults: a resumed run rebuilds it to find where it stopped. Default: one stage,
  // default_training_stage(defaults), training every parameter with Adam and the Noam schedule.
  virtual std::vector<TrainingStage> training_stages(const TrainStageDefaults& defaults) const {
    return {default_training_stage(defaults)};
  }

  // Called by the trainer when a stage begins (index into training_stages(), also on resume
  // inside it), before its first step, so a family can switch its objective (e.g. loss() of the
  // prior stage scores the prior only). Default: no-op.
  virtual void begin_stage(int index, const TrainingStage& stage) {}

  // Clips shorter than the training window: 0 (the default) leaves them out; n > 0 includes each
  // clip of at least n frames as one window padded to the window's length, with Batch::frames
  // telling the valid part, for families whose loss masks padding.
  virtual int short_window_min_frames() const { return 0; }

  // Frames of control past each window's end that loss() reads (a look-ahead of the path), handed
  // over in Batch::control_after; 0 (the default) hands none. Without them a look-ahead near the
  // window's end would see a path that stops there, which sampling along a longer path never does.
  virtual int control_frames_after() const { return 0; }

  // The parameters that take the label features, for warm starts across vocabularies. Default:
  // none (a family without label inputs, or one whose label columns are not to be remapped).
  virtual std::vector<LabelInput> label_inputs() const { return {}; }

  // Training objective on a batch. Uses training-only regularisers (e.g. data dropout) only when
  // is_training(). Random choices draw from the default CPU generator (torch::manual_seed).
  virtual LossTerms loss(const Batch& batch) = 0;
};

}  // namespace mosyn::nn
