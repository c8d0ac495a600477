// Raw <-> standardised features with a dataset's statistics (nn/model.h conventions:
// x_std = (x_raw - mean) / std per dimension), shared by training, sampling and classification.
#pragma once

#include <torch/types.h>

#include "data/dataset.h"

namespace mosyn::nn {

class Standardiser {
 public:
  explicit Standardiser(const data::DatasetStats& stats)
      : pose_mean_(torch::tensor(stats.pose_mean)),
        pose_std_(torch::tensor(stats.pose_std)),
        control_mean_(torch::tensor(stats.control_mean)),
        control_std_(torch::tensor(stats.control_std)) {}

  int64_t pose_dim() const { return pose_mean_.size(0); }
  int64_t control_dim() const { return control_mean_.size(0); }
  // Raw CPU float tensors [..., D] / [..., C] to standardised, and back for poses.
  torch::Tensor pose(const torch::Tensor& raw) const { return (raw - pose_mean_) / pose_std_; }
  torch::Tensor control(const torch::Tensor& raw) const { return (raw - control_mean_) / control_std_; }
  torch::Tensor unpose(const torch::Tensor& standardised) const { return standardised * pose_std_ + pose_mean_; }
  torch::Tensor uncontrol(const torch::Tensor& standardised) const { return standardised * control_std_ + control_mean_; }

 private:
  torch::Tensor pose_mean_, pose_std_, control_mean_, control_std_;
};

}  // namespace mosyn::nn
