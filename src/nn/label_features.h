// Content and style labels as network inputs, shared by the families that condition on them
// (MoGlow, the recurrent VAE): one-hot vectors, all zeros for "none" (-1), so one network serves
// labelled and unlabelled requests.
#pragma once

#include <torch/types.h>

#include <cstdint>

namespace mosyn::nn {

// [B, num_content + num_style] float: one-hot content, then one-hot style; a label of -1 (or an
// undefined tensor: all none) gives zeros in its part. content and style are [B] int64. Throws
// mosyn::Error for a label outside [-1, vocabulary size) or a batch mismatch.
torch::Tensor label_features(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                             int num_content, int num_style, const torch::TensorOptions& options);

// Training-time label dropout: each defined label is replaced by -1 with probability p, drawn
// from the default CPU generator, so the model also learns the motion of no label in particular.
// Returns the labels unchanged for p <= 0 or an undefined tensor.
torch::Tensor drop_labels(const torch::Tensor& labels, double p);

}  // namespace mosyn::nn
