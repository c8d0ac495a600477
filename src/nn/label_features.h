// Content and style labels as network inputs, shared by the families that condition on them
// (MoGlow, the recurrent VAE): one-hot vectors, all zeros for "none" (-1), so one network serves
// labelled and unlabelled requests.
#pragma once

#include <torch/types.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

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

// [num_content + 1, num_style + 1] float on the CPU: 1 at (c + 1, s + 1) when a clip of content c
// and style s (-1 = none, row or column 0) matches one of `patterns` ("CONTENT:STYLE",
// nn/label_pattern.h), else 0. Throws mosyn::Error starting with `what` for a malformed pattern, an
// unknown label, or vocabularies whose sizes are not num_content and num_style (a context built by
// hand has none).
torch::Tensor label_pattern_table(const std::vector<std::string>& patterns, const std::vector<std::string>& content_labels,
                                  const std::vector<std::string>& style_labels, int num_content, int num_style,
                                  const std::string& what);

// As label_pattern_table, with a factor per pattern: each entry is the product of the factors of
// the patterns its labels match (1 where none does). The factors are the caller's to check
// (label_factor_problem).
torch::Tensor label_weight_table(const std::map<std::string, double>& factors,
                                 const std::vector<std::string>& content_labels,
                                 const std::vector<std::string>& style_labels, int num_content, int num_style,
                                 const std::string& what);

// [B] float on table's device: table's entry for each row's labels; content and style are [B]
// int64 (undefined: all none).
torch::Tensor label_table_rows(const torch::Tensor& table, const torch::Tensor& content, const torch::Tensor& style,
                               int64_t batch);

}  // namespace mosyn::nn
