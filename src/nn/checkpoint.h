// Checkpoint files (LibTorch archives) shared by the trainer and load_run.
#pragma once

#include <torch/optim/optimizer.h>
#include <torch/types.h>

#include <limits>
#include <string>

#include "nn/model.h"

namespace mosyn::nn {

// Everything besides parameters and optimiser state needed to continue a run exactly.
struct CheckpointState {
  int step = 0;
  std::string data_rng;     // std::mt19937_64 state as written by operator<<
  torch::Tensor torch_rng;  // default CPU generator state (uint8)
  double best_val_loss = std::numeric_limits<double>::quiet_NaN();  // NaN: never validated
};

// Writes model (parameters + buffers), optimizer (may be null) and state to path atomically.
void save_checkpoint(const std::string& path, MotionModel& model, const torch::optim::Optimizer* optimizer,
                     const CheckpointState& state);

// Converts the model's float32 parameters and buffers to float16 in place, to save a checkpoint
// at half the size (mosyn export --half). load_checkpoint widens them back to float32, so the
// loaded model computes in float32 with weights rounded to float16 (about 3 significant
// digits). The model is for saving only afterwards.
void narrow_to_half(MotionModel& model);

// Loads into an already-built model (and optimizer, may be null) on device. Throws mosyn::Error
// naming path when the file is missing, truncated, corrupt or does not fit the model.
CheckpointState load_checkpoint(const std::string& path, MotionModel& model, torch::optim::Optimizer* optimizer,
                                const torch::Device& device);

}  // namespace mosyn::nn
