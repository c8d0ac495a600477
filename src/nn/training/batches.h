// Mini-batches of the trainer (internal to nn/training): which windows a run trains and validates
// on (data::Dataset::windows), and standardised batches cut from them.
#pragma once

#include <torch/types.h>

#include <vector>

#include "data/dataset.h"
#include "nn/standardiser.h"
#include "nn/trainable.h"

namespace mosyn::nn::training {

// The windows of one split and the window length in frames.
struct SplitWindows {
  const std::vector<data::ClipRecord>* clips = nullptr;
  std::vector<data::WindowRef> windows;
  int window = 0;
};

// Every window of `window` frames with hop 1 in the train split. Throws mosyn::Error when no
// training clip is long enough.
SplitWindows training_windows(const data::Dataset& dataset, int window);

// The fixed validation subset: at most max_windows windows (hop window / 2) spread evenly over
// the val split, in order. Empty when the split has no long-enough clip or max_windows <= 0.
SplitWindows validation_windows(const data::Dataset& dataset, int window, int max_windows);

// Cuts batches from raw clips and standardises them with the dataset statistics. Near-constant
// pose dimensions (data::DatasetStats::pose_constant) carry unit Gaussian noise instead of their
// (constant) standardised value, so no model can fit them with unbounded likelihood; decoding
// restores their mean (nn/standardiser.h).
class BatchMaker {
 public:
  BatchMaker(const data::Dataset& dataset, int pose_dim, int control_dim, const torch::Device& device);

  // The windows split.windows[begin, begin + count) as one batch (pose [count, window, D], control
  // [count, window, C], content and style [count]) on the device.
  Batch make(const SplitWindows& split, size_t begin, size_t count) const;
  // The given windows of split's clips as one batch.
  Batch make(const SplitWindows& split, const std::vector<data::WindowRef>& windows) const;

 private:
  // pose [B, T, D] with fresh N(0, 1) values at the near-constant dimensions, one fixed draw per
  // window (seeded by clip and start).
  torch::Tensor with_constant_noise(torch::Tensor pose, const std::vector<data::WindowRef>& windows) const;

  int d_, c_;
  torch::Device device_;
  Standardiser standardiser_;
};

}  // namespace mosyn::nn::training
