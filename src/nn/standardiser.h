// Raw <-> standardised features with a dataset's statistics (nn/model.h conventions:
// x_std = (x_raw - mean) / std per dimension), shared by training, sampling and classification.
//
// Near-constant pose dimensions (data::DatasetStats::pose_constant) are kept out of the models:
// pose() gives 0 there (the mean of the noise training batches carry there, see
// nn/training/batches.h), and unpose() gives the dimension's mean whatever the model produced.
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
        control_std_(torch::tensor(stats.control_std)),
        pose_decode_std_(pose_std_) {
    if (!stats.pose_constant.empty()) {
      pose_constant_ = torch::tensor(std::vector<int64_t>(stats.pose_constant.begin(), stats.pose_constant.end()));
      pose_keep_ = torch::ones_like(pose_std_).index_fill_(0, pose_constant_, 0.0);
      pose_decode_std_ = pose_std_ * pose_keep_;
    }
  }

  int64_t pose_dim() const { return pose_mean_.size(0); }
  int64_t control_dim() const { return control_mean_.size(0); }
  // Indices of the near-constant pose dimensions (int64 [K]); undefined when there are none.
  const torch::Tensor& pose_constant() const { return pose_constant_; }
  // Raw CPU float tensors [..., D] / [..., C] to standardised, and back for poses.
  torch::Tensor pose(const torch::Tensor& raw) const {
    const torch::Tensor x = (raw - pose_mean_) / pose_std_;
    return pose_keep_.defined() ? x * pose_keep_ : x;
  }
  torch::Tensor control(const torch::Tensor& raw) const { return (raw - control_mean_) / control_std_; }
  torch::Tensor unpose(const torch::Tensor& standardised) const { return standardised * pose_decode_std_ + pose_mean_; }
  torch::Tensor uncontrol(const torch::Tensor& standardised) const { return standardised * control_std_ + control_mean_; }

 private:
  torch::Tensor pose_mean_, pose_std_, control_mean_, control_std_;
  torch::Tensor pose_keep_;        // 1, 0 at near-constant dimensions; undefined when there are none
  torch::Tensor pose_decode_std_;  // std, 0 at near-constant dimensions
  torch::Tensor pose_constant_;
};

}  // namespace mosyn::nn
