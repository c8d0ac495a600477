#include "nn/label_features.h"

#include <string>

#include "core/error.h"
#include "nn/label_pattern.h"

namespace mosyn::nn {
namespace {

// One-hot [B, size] of labels [B] (-1 = zeros).
torch::Tensor one_hot_or_zero(const torch::Tensor& labels, int64_t batch, int size, const char* what,
                              const torch::TensorOptions& options) {
  auto out = torch::zeros({batch, size}, options);
  if (!labels.defined() || size == 0) return out;
  if (labels.dim() != 1 || labels.size(0) != batch)
    throw Error(std::string(what) + " labels must be [" + std::to_string(batch) + "]");
  const auto cpu = labels.to(torch::kCPU, torch::kLong).contiguous();
  const int64_t* id = cpu.data_ptr<int64_t>();
  auto hot = torch::zeros({batch, size});
  auto acc = hot.accessor<float, 2>();
  for (int64_t b = 0; b < batch; ++b) {
    if (id[b] < -1 || id[b] >= size)
      throw Error(std::string(what) + " label " + std::to_string(id[b]) + " is outside the model's vocabulary of " +
                  std::to_string(size));
    if (id[b] >= 0) acc[b][id[b]] = 1.0f;
  }
  return hot.to(options);
}

}  // namespace

torch::Tensor label_features(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                             int num_content, int num_style, const torch::TensorOptions& options) {
  return torch::cat({one_hot_or_zero(content, batch, num_content, "content", options),
                     one_hot_or_zero(style, batch, num_style, "style", options)},
                    1);
}

namespace {

// [num_content + 1, num_style + 1] float, 1 where a clip of content c and style s (-1 = none: row or
// column 0) matches `key`, else 0.
torch::Tensor pattern_mask(const std::string& key, const std::vector<std::string>& content_labels,
                           const std::vector<std::string>& style_labels, const std::string& what) {
  const int num_content = static_cast<int>(content_labels.size()), num_style = static_cast<int>(style_labels.size());
  const LabelPattern p = resolve_label_pattern(key, content_labels, style_labels, what);
  auto mask = torch::zeros({num_content + 1, num_style + 1});
  auto acc = mask.accessor<float, 2>();
  for (int c = -1; c < num_content; ++c)
    for (int s = -1; s < num_style; ++s) acc[c + 1][s + 1] = label_pattern_matches(p, c, s) ? 1.0f : 0.0f;
  return mask;
}

void check_vocabularies(const std::vector<std::string>& content_labels, const std::vector<std::string>& style_labels,
                        int num_content, int num_style, const std::string& what) {
  if (static_cast<int>(content_labels.size()) != num_content || static_cast<int>(style_labels.size()) != num_style)
    throw Error(what + ": needs the dataset's label vocabularies (" + std::to_string(num_content) + " content and " +
                std::to_string(num_style) + " style labels; this context has " +
                std::to_string(content_labels.size()) + " and " + std::to_string(style_labels.size()) + ")");
}

}  // namespace

torch::Tensor label_pattern_table(const std::vector<std::string>& patterns, const std::vector<std::string>& content_labels,
                                  const std::vector<std::string>& style_labels, int num_content, int num_style,
                                  const std::string& what) {
  check_vocabularies(content_labels, style_labels, num_content, num_style, what);
  auto table = torch::zeros({num_content + 1, num_style + 1});
  for (const std::string& key : patterns) table = torch::max(table, pattern_mask(key, content_labels, style_labels, what));
  return table;
}

torch::Tensor label_weight_table(const std::map<std::string, double>& factors,
                                 const std::vector<std::string>& content_labels,
                                 const std::vector<std::string>& style_labels, int num_content, int num_style,
                                 const std::string& what) {
  check_vocabularies(content_labels, style_labels, num_content, num_style, what);
  auto table = torch::ones({num_content + 1, num_style + 1});
  for (const auto& [key, factor] : factors)
    table = table * (1.0 + (factor - 1.0) * pattern_mask(key, content_labels, style_labels, what));
  return table;
}

torch::Tensor label_table_rows(const torch::Tensor& table, const torch::Tensor& content, const torch::Tensor& style,
                               int64_t batch) {
  const auto opts = torch::dtype(torch::kLong).device(table.device());
  const auto none = torch::full({batch}, -1L, opts);
  const auto c = content.defined() ? content.to(opts) : none, s = style.defined() ? style.to(opts) : none;
  return table.flatten().index_select(0, (c + 1) * table.size(1) + (s + 1));
}

torch::Tensor drop_labels(const torch::Tensor& labels, double p) {
  if (!labels.defined() || !(p > 0)) return labels;
  auto drop = torch::bernoulli(torch::full({labels.size(0)}, p)).to(labels.device()).to(torch::kBool);
  return torch::where(drop, torch::full_like(labels, -1), labels);
}

}  // namespace mosyn::nn
