#include "nn/label_features.h"

#include <string>

#include "core/error.h"

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

torch::Tensor drop_labels(const torch::Tensor& labels, double p) {
  if (!labels.defined() || !(p > 0)) return labels;
  auto drop = torch::bernoulli(torch::full({labels.size(0)}, p)).to(labels.device()).to(torch::kBool);
  return torch::where(drop, torch::full_like(labels, -1), labels);
}

}  // namespace mosyn::nn
