// Mini-batches of the trainer (internal to nn/training): which windows a run trains and validates
// on (data::Dataset::windows), and standardised batches cut from them.
#pragma once

#include <torch/types.h>

#include <map>
#include <string>
#include <vector>

#include "data/dataset.h"
#include "nn/label_pattern.h"
#include "nn/standardiser.h"
#include "nn/trainable.h"

namespace mosyn::nn::training {

// The windows of one split and the window length in frames.
struct SplitWindows {
  const std::vector<data::ClipRecord>* clips = nullptr;
  std::vector<data::WindowRef> windows;
  int window = 0;
  bool padded = false;  // short clips included as padded windows (batches carry Batch::frames)
  int control_after = 0;  // frames of control after each window that batches carry (Batch::control_after)
};

// Every window of `window` frames with hop 1 in the train split; with min_short_frames > 0 (the
// family's TrainableModel::short_window_min_frames) also one padded window per shorter clip of
// at least that many frames. Throws mosyn::Error when no training clip gives a window.
SplitWindows training_windows(const data::Dataset& dataset, int window, int min_short_frames = 0);

// Drawing weight of every window of split (same order) for TrainOptions::window_sampling
// "frames": each clip's weight is its number of frames, shared alike by its windows (a padded
// short clip's one window gets all of it). Sum = the frames of the clips that give a window.
std::vector<double> clip_frame_weights(const SplitWindows& split);

// One TrainOptions::label_weights entry resolved against a dataset's vocabularies
// (nn/label_pattern.h: content, style, key).
struct LabelWeight : LabelPattern {
  double factor = 1.0;
};

// Resolves "CONTENT:STYLE" keys ("*" = any) against the vocabularies. Throws mosyn::Error for a key
// without exactly one ':', a label the dataset does not know (naming the known ones), or a factor
// that is not finite and in (0, 1000].
std::vector<LabelWeight> resolve_label_weights(const std::map<std::string, double>& entries,
                                               const std::vector<std::string>& content_labels,
                                               const std::vector<std::string>& style_labels);

// The share (0..1) of the total weight held by the windows whose clips match entry.
double label_share(const SplitWindows& split, const std::vector<double>& weights, const LabelWeight& entry);

// weights (one per window of split, same order) times the factor of every entry each window's clip
// matches. Throws mosyn::Error unless one weight per window.
std::vector<double> label_weighted(const SplitWindows& split, const std::vector<double>& weights,
                                   const std::vector<LabelWeight>& entries);

// Width of the root-speed bins of speed_balanced, m/s.
constexpr double kSpeedBinMps = 0.5;

// Mean horizontal root speed of a clip, m/s: the mean length of its controls' (dx, dz) (the first
// two of control_dim values a frame, metres) times fps. 0 for a clip without frames.
double clip_root_speed_mps(const data::ClipRecord& clip, int control_dim, double fps);

// Drawing weights (same order as split.windows) that flatten how the draws share out over root
// speed (TrainOptions::speed_balance), and the share of the draws in each speed bin (index
// floor(speed / kSpeedBinMps)) before and after, for the log.
struct SpeedBalance {
  std::vector<double> weights;
  std::map<int, double> shares_before, shares_after;
};

// Every window's weight times s^-exponent, s the share of the total weight held by the windows of
// clips in its kSpeedBinMps-wide bin of mean root speed. With exponent 1 every occupied bin is drawn
// alike, with 0 nothing changes. Rare speeds (the Bandai-Namco fast runs: 3-3.7 m/s, 3% of the
// locomotion frames) are then drawn more often. Throws mosyn::Error unless one weight per window.
SpeedBalance speed_balanced(const SplitWindows& split, const std::vector<double>& weights, int control_dim,
                            double fps, double exponent);

// The fixed validation subset: at most max_windows windows (hop window / 2) spread evenly over
// the val split, in order. Empty when the split has no long-enough clip or max_windows <= 0.
SplitWindows validation_windows(const data::Dataset& dataset, int window, int max_windows, int min_short_frames = 0);

// "" when every training clip gives a window; otherwise a warning that says how many clips (and
// what share of the frames) are left out for being shorter than `window` frames, and which
// content and style labels get no window at all (with the shorter window that would keep them).
std::string left_out_warning(const data::Dataset& dataset, int window, int min_short_frames);

// Cuts batches from raw clips and standardises them with the dataset statistics. Near-constant
// pose dimensions (data::DatasetStats::pose_constant) carry unit Gaussian noise instead of their
// (constant) standardised value, so no model can fit them with unbounded likelihood; decoding
// restores their mean (nn/standardiser.h).
class BatchMaker {
 public:
  BatchMaker(const data::Dataset& dataset, int pose_dim, int control_dim, const torch::Device& device);

  // The windows split.windows[begin, begin + count) as one batch (pose [count, window, D], control
  // [count, window, C], content and style [count]; with split.control_after = K > 0 also
  // control_after [count, K, C]) on the device.
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
