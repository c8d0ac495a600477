// A training stage applied to a model (internal to nn/training): which tensors it trains, which
// modules it freezes, its optimiser and the learning rate of each step.
#pragma once

#include <torch/nn/module.h>
#include <torch/optim/optimizer.h>

#include <memory>
#include <string>
#include <vector>

#include "nn/trainable.h"

namespace mosyn::nn::training {

// A stage resolved against a model's parameter and module names.
struct StageParams {
  std::vector<torch::Tensor> trained;  // in named_parameters() order
  std::vector<std::shared_ptr<torch::nn::Module>> frozen;  // modules kept in eval mode
};

// Resolves stage's prefixes (nn/training/stage.h) on model. Throws mosyn::Error "<family>: stage
// '<name>': ..." when a prefix matches nothing or nothing is left to train.
StageParams resolve_stage(TrainableModel& model, const TrainingStage& stage);

// Puts the model in training mode with the stage's frozen modules in eval mode, and sets
// requires_grad: true for the trained parameters, false for all others. Call at the start of a
// stage and after every validation (which switches the whole model to eval and back).
void apply_training_mode(TrainableModel& model, const StageParams& params);

// Only the modes of apply_training_mode (requires_grad untouched): after a validation.
void restore_training_mode(TrainableModel& model, const StageParams& params);

// A fresh optimiser of the spec's kind over params.trained, at the spec's peak lr.
std::unique_ptr<torch::optim::Optimizer> make_optimizer(const OptimizerSpec& spec, const StageParams& params);

// Sets the learning rate of every parameter group.
void set_learning_rate(torch::optim::Optimizer& optimizer, double lr);

// One line for the progress messages: "stage 2/3 'prior': 500 steps, training 12 tensors,
// frozen: encoder, decoder".
std::string describe_stage(const TrainingStage& stage, int index, int count, const StageParams& params);

}  // namespace mosyn::nn::training
