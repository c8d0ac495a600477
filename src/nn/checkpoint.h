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

// Loads into an already-built model (and optimizer, may be null) on device. Throws mosyn::Error
// naming path when the file is missing, truncated, corrupt or does not fit the model.
CheckpointState load_checkpoint(const std::string& path, MotionModel& model, torch::optim::Optimizer* optimizer,
                                const torch::Device& device);

}  // namespace mosyn::nn
