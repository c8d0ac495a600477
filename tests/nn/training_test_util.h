// Helpers of the trainer's tests: a fresh temporary run directory and options for a tiny MoGlow run.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include <torch/torch.h>

#include "nn/training/train.h"

namespace mosyn::nn::testing {

namespace fs = std::filesystem;

inline fs::path temp_dir(const std::string& name) {
  auto p = fs::temp_directory_path() / ("mosyn_nn_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

inline TrainOptions tiny_options(const fs::path& dir) {
  TrainOptions o;
  o.family = "moglow";
  o.out_dir = dir.string();
  o.model_config = {{"num_steps", 2}, {"hidden", 8}, {"tau", 2}, {"dropout", 0.5}};
  o.steps = 12;
  o.batch = 4;
  o.lr = 1e-3;
  o.warmup = 5;
  o.threads = 1;
  o.checkpoint_every = 4;
  o.validate_every = 4;
  o.log_every = 2;
  o.seed = 3;
  return o;
}

inline double max_param_diff(torch::nn::Module& a, torch::nn::Module& b) {
  auto pa = a.named_parameters(), pb = b.named_parameters();
  double m = 0;
  for (const auto& kv : pa) m = std::max(m, (kv.value() - pb[kv.key()]).abs().max().item<double>());
  auto ba = a.named_buffers(), bb = b.named_buffers();
  for (const auto& kv : ba) m = std::max(m, (kv.value() - bb[kv.key()]).abs().max().item<double>());
  return m;
}

}  // namespace mosyn::nn::testing
