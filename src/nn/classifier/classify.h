// Running a trained classifier run (nn/classifier/classifier.h) on raw feature windows, for the
// recognisability metrics (Inception score, FID) of eval. No LibTorch in this header.
#pragma once

#include <vector>

#include "nn/run.h"

namespace mosyn::nn {

// What a trained classifier run says about a set of windows.
struct ClassifierOutputs {
  int num_windows = 0;
  int num_features = 0;                       // F
  int num_content = 0;                        // K_content
  int num_style = 0;                          // K_style, 0 without a style head
  std::vector<float> features;                // [N, F] row-major, penultimate layer (after ReLU)
  std::vector<float> content_probabilities;   // [N, K_content], rows sum to 1 (softmax)
  std::vector<float> style_probabilities;     // [N, K_style], empty without styles
};

// Runs a loaded classifier run (load_run of a "classifier" run) on windows of RAW features:
// poses[i] is [T_i, D] row-major (any T_i >= 1: the network pools over time), controls[i] is
// [T_i, C] (controls may be empty, or an entry empty: the mean control is used). The run's stats
// standardise them. Throws mosyn::Error when the run is not a classifier or sizes mismatch.
ClassifierOutputs classify_windows(const LoadedRun& run, const std::vector<std::vector<float>>& poses,
                                   const std::vector<std::vector<float>>& controls);

}  // namespace mosyn::nn
