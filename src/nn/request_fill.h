// Internal to nn: a SampleRequest's inputs from raw vectors, shared by offline sampling
// (sampling.cpp) and the real-time Generator (generator.cpp).
#pragma once

#include <torch/types.h>

#include <vector>

#include "nn/model.h"
#include "nn/run.h"
#include "nn/standardiser.h"

namespace mosyn::nn {

// A copy of raw row-major v as a float tensor [rows, cols].
torch::Tensor from_vector(const std::vector<float>& v, int64_t rows, int64_t cols);
// The device of the model's parameters (CPU for a model without any).
torch::Device model_device(MotionModel& m);
// Fills the prefix and label fields of a request for batch size b: prefix raw [P, D] / [P, C]
// (shared by every row), labels none, one for all or one per row; checked against the run.
void fill_request(SampleRequest& req, const LoadedRun& run, const Standardiser& st, int64_t b,
                  const std::vector<float>& prefix_pose, const std::vector<float>& prefix_control,
                  const std::vector<int>& content, const std::vector<int>& style);

}  // namespace mosyn::nn
