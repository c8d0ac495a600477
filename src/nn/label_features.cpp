#include "nn/label_features.h"

#include <cmath>
#include <functional>
#include <string>
#include <utility>

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

// [num_content + 1, num_style + 1] filled with `initial`, then each (key, value) applied by
// apply(entry, value) to the entries its pattern matches.
torch::Tensor label_table(const std::vector<std::pair<std::string, double>>& entries, double initial,
                          const std::function<float(float, double)>& apply, const std::vector<std::string>& content_labels,
                          const std::vector<std::string>& style_labels, int num_content, int num_style,
                          const std::string& what) {
  if (static_cast<int>(content_labels.size()) != num_content || static_cast<int>(style_labels.size()) != num_style)
    throw Error(what + ": needs the dataset's label vocabularies (" + std::to_string(num_content) + " content and " +
                std::to_string(num_style) + " style labels; this context has " +
                std::to_string(content_labels.size()) + " and " + std::to_string(style_labels.size()) + ")");
  auto table = torch::full({num_content + 1, num_style + 1}, initial);
  auto acc = table.accessor<float, 2>();
  for (const auto& [key, value] : entries) {
    const LabelPattern p = resolve_label_pattern(key, content_labels, style_labels, what);
    for (int c = -1; c < num_content; ++c)
      for (int s = -1; s < num_style; ++s)
        if (label_pattern_matches(p, c, s)) acc[c + 1][s + 1] = apply(acc[c + 1][s + 1], value);
  }
  return table;
}

}  // namespace

torch::Tensor label_pattern_table(const std::vector<std::string>& patterns, const std::vector<std::string>& content_labels,
                                  const std::vector<std::string>& style_labels, int num_content, int num_style,
                                  const std::string& what) {
  std::vector<std::pair<std::string, double>> entries;
  for (const std::string& key : patterns) entries.emplace_back(key, 1.0);
  return label_table(entries, 0.0, [](float, double) { return 1.0f; }, content_labels, style_labels, num_content,
                     num_style, what);
}

torch::Tensor label_weight_table(const std::map<std::string, double>& factors,
                                 const std::vector<std::string>& content_labels,
                                 const std::vector<std::string>& style_labels, int num_content, int num_style,
                                 const std::string& what) {
  for (const auto& [key, factor] : factors)
    if (!(std::isfinite(factor) && factor >= 0))
      throw Error(what + ": '" + key + "': the factor must be finite and >= 0, got " + std::to_string(factor));
  return label_table({factors.begin(), factors.end()}, 1.0,
                     [](float entry, double factor) { return static_cast<float>(entry * factor); }, content_labels,
                     style_labels, num_content, num_style, what);
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
