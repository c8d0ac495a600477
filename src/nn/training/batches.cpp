#include "nn/training/batches.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <string>

#include <ATen/CPUGeneratorImpl.h>

#include "core/error.h"

namespace mosyn::nn::training {

SplitWindows training_windows(const data::Dataset& dataset, int window, int min_short_frames) {
  SplitWindows s;
  s.clips = &dataset.clips("train");
  s.windows = dataset.windows("train", window, 1, min_short_frames);
  s.window = window;
  s.padded = min_short_frames > 0;
  if (s.windows.empty()) {
    int longest = 0;
    for (const data::ClipRecord& c : *s.clips) longest = std::max(longest, c.num_frames);
    throw Error("train: the dataset is too small for a window of " + std::to_string(window) + " frames: its longest of " +
                std::to_string(s.clips->size()) + " training clips has " + std::to_string(longest) +
                " frames (shorten the window or add longer clips)");
  }
  return s;
}

std::vector<double> clip_frame_weights(const SplitWindows& split) {
  std::map<int, int> windows_of_clip;
  for (const data::WindowRef& w : split.windows) ++windows_of_clip[w.clip];
  std::vector<double> weights;
  weights.reserve(split.windows.size());
  for (const data::WindowRef& w : split.windows)
    weights.push_back(static_cast<double>((*split.clips)[static_cast<size_t>(w.clip)].num_frames) /
                      windows_of_clip[w.clip]);
  return weights;
}

namespace {

bool matches(const data::ClipRecord& clip, const LabelWeight& entry) {
  return label_pattern_matches(entry, clip.content, clip.style);
}

}  // namespace

std::vector<LabelWeight> resolve_label_weights(const std::map<std::string, double>& entries,
                                               const std::vector<std::string>& content_labels,
                                               const std::vector<std::string>& style_labels) {
  std::vector<LabelWeight> out;
  for (const auto& [key, factor] : entries) {
    const std::string problem = label_factor_problem(key, factor, "label_weights", /*zero_allowed=*/false);
    if (!problem.empty()) throw Error(problem);
    out.push_back({resolve_label_pattern(key, content_labels, style_labels, "label_weights"), factor});
  }
  return out;
}

double label_share(const SplitWindows& split, const std::vector<double>& weights, const LabelWeight& entry) {
  if (weights.size() != split.windows.size()) throw Error("label_share: one weight per window expected");
  double matched = 0, total = 0;
  for (size_t i = 0; i < weights.size(); ++i) {
    total += weights[i];
    if (matches((*split.clips)[static_cast<size_t>(split.windows[i].clip)], entry)) matched += weights[i];
  }
  return total > 0 ? matched / total : 0;
}

std::vector<double> label_weighted(const SplitWindows& split, const std::vector<double>& weights,
                                   const std::vector<LabelWeight>& entries) {
  if (weights.size() != split.windows.size()) throw Error("label_weighted: one weight per window expected");
  std::vector<double> out = weights;
  for (size_t i = 0; i < out.size(); ++i) {
    const data::ClipRecord& clip = (*split.clips)[static_cast<size_t>(split.windows[i].clip)];
    for (const LabelWeight& e : entries)
      if (matches(clip, e)) out[i] *= e.factor;
  }
  return out;
}

double clip_root_speed_mps(const data::ClipRecord& clip, int control_dim, double fps) {
  if (clip.num_frames < 1 || control_dim < 2) return 0;
  double metres = 0;
  for (int t = 0; t < clip.num_frames; ++t) {
    const float* c = clip.control.data() + static_cast<size_t>(t) * control_dim;
    metres += std::hypot(static_cast<double>(c[0]), static_cast<double>(c[1]));
  }
  return metres * fps / clip.num_frames;
}

namespace {

// The speed bin of every window of split.
std::vector<int> window_speed_bins(const SplitWindows& split, int control_dim, double fps) {
  std::map<int, int> bin_of_clip;
  std::vector<int> bins;
  bins.reserve(split.windows.size());
  for (const data::WindowRef& w : split.windows) {
    auto it = bin_of_clip.find(w.clip);
    if (it == bin_of_clip.end()) {
      const double speed = clip_root_speed_mps((*split.clips)[static_cast<size_t>(w.clip)], control_dim, fps);
      it = bin_of_clip.emplace(w.clip, static_cast<int>(std::floor(speed / kSpeedBinMps))).first;
    }
    bins.push_back(it->second);
  }
  return bins;
}

std::map<int, double> bin_shares(const std::vector<int>& bins, const std::vector<double>& weights) {
  std::map<int, double> share;
  double total = 0;
  for (size_t i = 0; i < bins.size(); ++i) {
    share[bins[i]] += weights[i];
    total += weights[i];
  }
  for (auto& [bin, s] : share) s = total > 0 ? s / total : 0;
  return share;
}

}  // namespace

SpeedBalance speed_balanced(const SplitWindows& split, const std::vector<double>& weights, int control_dim,
                            double fps, double exponent) {
  if (weights.size() != split.windows.size()) throw Error("speed_balanced: one weight per window expected");
  const std::vector<int> bins = window_speed_bins(split, control_dim, fps);
  SpeedBalance out;
  out.shares_before = bin_shares(bins, weights);
  out.weights.resize(weights.size());
  for (size_t i = 0; i < weights.size(); ++i) {
    const double s = out.shares_before.at(bins[i]);
    out.weights[i] = s > 0 ? weights[i] * std::pow(s, -exponent) : 0.0;
  }
  out.shares_after = bin_shares(bins, out.weights);
  return out;
}

SplitWindows validation_windows(const data::Dataset& dataset, int window, int max_windows, int min_short_frames) {
  SplitWindows s;
  s.clips = &dataset.clips("val");
  s.window = window;
  s.padded = min_short_frames > 0;
  const auto all = dataset.windows("val", window, std::max(1, window / 2), min_short_frames);
  const size_t n = std::min<size_t>(all.size(), std::max(0, max_windows));
  for (size_t i = 0; i < n; ++i) s.windows.push_back(all[i * all.size() / n]);
  return s;
}

BatchMaker::BatchMaker(const data::Dataset& dataset, int pose_dim, int control_dim, const torch::Device& device)
    : d_(pose_dim), c_(control_dim), device_(device), standardiser_(dataset.stats()) {}

Batch BatchMaker::make(const SplitWindows& split, size_t begin, size_t count) const {
  return make(split, std::vector<data::WindowRef>(split.windows.begin() + begin, split.windows.begin() + begin + count));
}

torch::Tensor BatchMaker::with_constant_noise(torch::Tensor pose, const std::vector<data::WindowRef>& windows) const {
  const torch::Tensor& constant = standardiser_.pose_constant();
  if (!constant.defined()) return pose;
  for (size_t i = 0; i < windows.size(); ++i) {
    // Seeded by the window, not the run's generator: the same window always gets the same noise,
    // so validation losses are comparable and the training random stream is unchanged.
    auto generator = at::make_generator<at::CPUGeneratorImpl>(
        0x9E3779B97F4A7C15ull ^ (static_cast<uint64_t>(windows[i].clip) << 32) ^ static_cast<uint64_t>(windows[i].start));
    const torch::Tensor noise = torch::randn({pose.size(1), constant.size(0)}, generator);
    pose[static_cast<int64_t>(i)].index_copy_(1, constant, noise);
  }
  return pose;
}

Batch BatchMaker::make(const SplitWindows& split, const std::vector<data::WindowRef>& windows) const {
  const auto count = static_cast<int64_t>(windows.size());
  const int window = split.window;
  auto pose = torch::empty({count, window, d_});
  auto ctrl = torch::empty({count, window, c_});
  auto content = torch::empty({count}, torch::kInt64);
  auto style = torch::empty({count}, torch::kInt64);
  auto frames = torch::empty({count}, torch::kInt64);
  const int after = std::max(0, split.control_after);
  auto ctrl_after = torch::empty({count, after, c_});
  for (int64_t i = 0; i < count; ++i) {
    const data::WindowRef& w = windows[i];
    const auto& clip = (*split.clips)[w.clip];
    const int valid = w.frames > 0 ? std::min(w.frames, window) : window;
    std::memcpy(pose[i].data_ptr<float>(), clip.pose.data() + static_cast<size_t>(w.start) * d_,
                sizeof(float) * valid * d_);
    std::memcpy(ctrl[i].data_ptr<float>(), clip.control.data() + static_cast<size_t>(w.start) * c_,
                sizeof(float) * valid * c_);
    if (valid < window) {  // padding repeats the last frame
      pose[i].narrow(0, valid, window - valid).copy_(pose[i][valid - 1].expand({window - valid, d_}));
      ctrl[i].narrow(0, valid, window - valid).copy_(ctrl[i][valid - 1].expand({window - valid, c_}));
    }
    for (int k = 0; k < after; ++k) {  // past the clip's end its last frame repeats, as along a path that ends
      const int f = std::min(w.start + valid + k, clip.num_frames - 1);
      std::memcpy(ctrl_after[i][k].data_ptr<float>(), clip.control.data() + static_cast<size_t>(f) * c_, sizeof(float) * c_);
    }
    content[i] = clip.content;
    style[i] = clip.style;
    frames[i] = valid;
  }
  Batch b;
  if (split.padded) b.frames = frames.to(device_);
  b.pose = with_constant_noise(standardiser_.pose(pose), windows).to(device_);
  b.control = standardiser_.control(ctrl).to(device_);
  if (after > 0) b.control_after = standardiser_.control(ctrl_after).to(device_);
  b.content = content.to(device_);
  b.style = style.to(device_);
  return b;
}

namespace {

// How a label's training clips fare against the window: clips kept, and its longest clip.
struct LabelCoverage {
  int kept_clips = 0;
  int longest_frames = 0;
};

void count_label(int label, int num_frames, bool kept, std::vector<LabelCoverage>* coverage) {
  if (label < 0 || label >= static_cast<int>(coverage->size())) return;
  LabelCoverage& c = (*coverage)[static_cast<size_t>(label)];
  c.kept_clips += kept;
  c.longest_frames = std::max(c.longest_frames, num_frames);
}

}  // namespace

std::string left_out_warning(const data::Dataset& dataset, int window, int min_short_frames) {
  const data::DatasetInfo& info = dataset.info();
  const auto& clips = dataset.clips("train");
  std::vector<LabelCoverage> contents(info.content_labels.size()), styles(info.style_labels.size());
  int left_out = 0;
  int64_t frames_left_out = 0, frames_total = 0;
  for (const data::ClipRecord& c : clips) {
    frames_total += c.num_frames;
    const bool kept = c.num_frames >= window || (min_short_frames > 0 && c.num_frames >= min_short_frames);
    if (!kept) {
      ++left_out;
      frames_left_out += c.num_frames;
    }
    count_label(c.content, c.num_frames, kept, &contents);
    count_label(c.style, c.num_frames, kept, &styles);
  }
  if (left_out == 0) return "";
  std::ostringstream m;
  m << "warning: " << left_out << " of " << clips.size() << " training clips ("
    << std::lround(100.0 * frames_left_out / std::max<int64_t>(1, frames_total))
    << "% of the frames) are shorter than the " << window << "-frame window and are left out";
  auto unseen = [&](const char* kind, const std::vector<std::string>& names, const std::vector<LabelCoverage>& coverage) {
    std::string list;
    for (size_t k = 0; k < names.size(); ++k)
      if (coverage[k].kept_clips == 0 && coverage[k].longest_frames > 0)
        list += (list.empty() ? "" : ", ") + names[k] + " (longest clip " + std::to_string(coverage[k].longest_frames) +
                " frames)";
    if (!list.empty()) m << "; " << kind << " never seen: " << list;
  };
  unseen("contents", info.content_labels, contents);
  unseen("styles", info.style_labels, styles);
  m << " (a shorter --window keeps them)";
  return m.str();
}

}  // namespace mosyn::nn::training
