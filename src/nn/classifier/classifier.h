// Action / style classifier for recognisability metrics (Ghorbani et al. 2020, section 5.2): a
// one-dimensional convolutional network over pose-feature windows, with adaptive average pooling
// over time before the fully connected layers so any window length works. It is a trainable model
// (nn/trainable.h) registered as the family "classifier" of kind FamilyKind::kClassifier, so that
// `mosyn train classifier` trains it with the generic trainer; it does not generate motion.
//
//   input x [B, T, D (+ C)]  standardised pose (and control) features, time on the conv axis
//   Conv1d(D+C -> H, k) ReLU  Conv1d(H -> H, k, stride 2) ReLU  Conv1d(H -> H, k) ReLU
//   AdaptiveAvgPool1d(1) -> [B, H]
//   Linear(H -> F) ReLU     -> features [B, F]   (the "last feature extraction layer" of the paper, for FID)
//   Linear(F -> K_content)  -> content logits;  Linear(F -> K_style) -> style logits (when the
//                              dataset has styles)
// Dropout (config "dropout") on the features in training only.
#pragma once

#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>

#include <memory>
#include <string>
#include <vector>

#include "nn/classifier/classify.h"
#include "nn/registry.h"
#include "nn/trainable.h"

namespace mosyn::nn {

// Hyper-parameters; JSON keys are the field names.
struct ClassifierOptions {
  int channels = 64;          // H, channels of every convolution
  int kernel = 5;             // temporal kernel width (odd; "same" padding)
  int features = 64;          // F, size of the penultimate (feature) layer
  double dropout = 0.2;       // dropout on the features in training
  bool use_control = true;    // also feed the control (root deltas) besides the pose
  double style_weight = 1.0;  // weight of the style cross-entropy in the loss

  // Overrides of the defaults; throws mosyn::Error on an unknown key or bad value.
  static ClassifierOptions from_json(const nlohmann::json& config);
  nlohmann::json to_json() const;
};

class ClassifierImpl : public TrainableModel {
 public:
  // Throws mosyn::Error when the context has no content labels.
  ClassifierImpl(const ClassifierOptions& options, const ModelContext& context);

  std::string family() const override { return "classifier"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const ClassifierOptions& options() const { return options_; }
  int num_content() const { return context_.num_content; }
  int num_style() const { return context_.num_style; }

  // Cross-entropy of the content label (+ style_weight x that of the style when the model has a
  // style head), over windows whose label is not -1 (a window without any label contributes 0).
  // Terms: "loss", "content_ce", "content_acc" (fraction correct, 0..1) and, with styles,
  // "style_ce", "style_acc".
  LossTerms loss(const Batch& batch) override;

  struct Output {
    torch::Tensor features;        // [B, F] penultimate activations (after ReLU)
    torch::Tensor content_logits;  // [B, K_content]
    torch::Tensor style_logits;    // [B, K_style], undefined without styles
  };
  // pose [B, T, D], control [B, T, C] standardised (control ignored unless use_control), T >= 1.
  Output forward(const torch::Tensor& pose, const torch::Tensor& control);

  torch::nn::Conv1d conv1{nullptr}, conv2{nullptr}, conv3{nullptr};
  torch::nn::Linear feature{nullptr}, content_head{nullptr}, style_head{nullptr};

 private:
  ClassifierOptions options_;
  ModelContext context_;
};
TORCH_MODULE(Classifier);

}  // namespace mosyn::nn
