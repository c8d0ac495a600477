// What the generic trainer (nn/training/train.h) needs of a model: a loss on a batch, a config
// that rebuilds it, and optionally a schedule hook. Motion models (nn/model.h) and the classifier
// (nn/classifier/classifier.h) are both trainable models; only motion models generate.
#pragma once

#include <torch/nn/module.h>
#include <torch/types.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace mosyn::nn {

// One training or validation mini-batch, standardised (x_std = (x_raw - mean) / std per
// dimension with the dataset statistics).
struct Batch {
  torch::Tensor pose;     // [B, T, D] float, standardised
  torch::Tensor control;  // [B, T, C] float, standardised
  torch::Tensor content;  // [B] int64, -1 = none (may be undefined: all none)
  torch::Tensor style;    // [B] int64, -1 = none (may be undefined: all none)
};

// Named scalar tensors returned by TrainableModel::loss. terms["loss"] is the total that the
// optimiser minimises (0-dim, differentiable); the others are detached metrics for logging,
// e.g. "nll_frame" (nats per predicted frame) and "nll_dim" (nats per frame and dimension).
struct LossTerms {
  std::map<std::string, torch::Tensor> terms;
  const torch::Tensor& loss() const { return terms.at("loss"); }
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

  // Called by the trainer before every training step (1-based step of total_steps), so a family
  // can schedule loss weights (e.g. KL annealing) without trainer special cases. Default: no-op.
  virtual void set_progress(int step, int total_steps) {}

  // Training objective on a batch. Uses training-only regularisers (e.g. data dropout) only when
  // is_training(). Random choices draw from the default CPU generator (torch::manual_seed).
  virtual LossTerms loss(const Batch& batch) = 0;
};

}  // namespace mosyn::nn
