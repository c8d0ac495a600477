// Checkpoint files (LibTorch archives) shared by the trainer and load_run.
#pragma once

#include <torch/optim/optimizer.h>
#include <torch/types.h>

#include <limits>
#include <string>
#include <vector>

#include "nn/model.h"

namespace mosyn::nn {

// Everything besides parameters and optimiser state needed to continue a run exactly.
struct CheckpointState {
  int step = 0;
  std::string data_rng;     // std::mt19937_64 state as written by operator<<
  torch::Tensor torch_rng;  // default CPU generator state (uint8)
  double best_val_loss = std::numeric_limits<double>::quiet_NaN();  // NaN: never validated
  // Training stage (nn/training/stage.h) of the last step done, and the steps done in it; -1 when
  // not recorded (checkpoints made before stages: one stage, stage_step = step). The optimiser
  // state is that of this stage.
  int stage = -1;
  int stage_step = -1;
};

// Writes model (parameters + buffers), optimizer (may be null) and state to path atomically.
void save_checkpoint(const std::string& path, TrainableModel& model, const torch::optim::Optimizer* optimizer,
                     const CheckpointState& state);

// Converts the model's float32 parameters and buffers to float16 in place, to save a checkpoint
// at half the size (mosyn export --half). load_checkpoint widens them back to float32, so the
// loaded model computes in float32 with weights rounded to float16 (about 3 significant
// digits). The model is for saving only afterwards.
void narrow_to_half(TrainableModel& model);

// Loads into an already-built model (and optimizer, may be null) on device. Throws mosyn::Error
// naming path when the file is missing, truncated, corrupt or does not fit the model.
CheckpointState load_checkpoint(const std::string& path, TrainableModel& model, torch::optim::Optimizer* optimizer,
                                const torch::Device& device);

// What init_from_checkpoint did with the model's tensors.
struct InitReport {
  int step = 0;                       // optimiser steps of the checkpoint
  int copied = 0;                     // tensors copied exactly (same name and shape)
  std::vector<std::string> grown;     // tensors larger by one dimension than the stored ones:
                                      // the stored block copied, the new part zero (e.g. the input
                                      // weights of a condition added since, which then starts
                                      // with no effect); and the tensors of a recurrent layer
                                      // made wider (more hidden units): each gate's stored rows
                                      // copied, the new units' rows freshly initialised, the
                                      // columns reading new units zero, so the model computes
                                      // what the stored one did until training moves it
  std::vector<std::string> missing;   // tensors not in the checkpoint or of another shape: left
                                      // as initialised
  std::vector<std::string> relabelled;  // label inputs whose columns were matched by label name
};

// The content and style vocabularies of a run (its dataset's labels, in one-hot order).
struct LabelVocabularies {
  std::vector<std::string> content, style;
  bool operator==(const LabelVocabularies& o) const { return content == o.content && style == o.style; }
};

// The vocabularies of the checkpoint being read and of the model being initialised. When they
// differ, each TrainableModel::label_inputs() parameter takes the stored columns of every label
// both know, by name; labels new to the model start at zero (as "no label"), labels it dropped are
// left out, and the columns before and after the label block are copied as they are.
struct InitLabels {
  LabelVocabularies stored, model;
};

// Weight averaging (stochastic weight averaging, Izmailov et al. 2018): folds `other` into the
// running mean `mean` of n models already averaged (n >= 1), so that every floating-point parameter
// and buffer becomes mean + (other - mean) / (n + 1), the average of all n + 1. Integer tensors keep
// mean's values. Both models must be of one family and config. Throws mosyn::Error when their tensors
// differ in names or shapes, or n < 1.
void fold_into_mean(TrainableModel& mean, const TrainableModel& other, int n);

// Warm start (mosyn train --init-from): copies a checkpoint's model tensors into a freshly built
// model of the same family, tolerating architecture changes as InitReport describes. Optimiser
// state and step are not taken. Throws mosyn::Error naming path when the file is missing,
// corrupt or of another family.
// labels (optional): see InitLabels.
InitReport init_from_checkpoint(const std::string& path, TrainableModel& model, const torch::Device& device,
                                const InitLabels* labels = nullptr);

}  // namespace mosyn::nn
