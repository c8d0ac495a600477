#include "nn/training/batches.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <ATen/CPUGeneratorImpl.h>

#include "core/error.h"

namespace mosyn::nn::training {

SplitWindows training_windows(const data::Dataset& dataset, int window) {
  SplitWindows s;
  s.clips = &dataset.clips("train");
  s.windows = dataset.windows("train", window, 1);
  s.window = window;
  if (s.windows.empty()) {
    int longest = 0;
    for (const data::ClipRecord& c : *s.clips) longest = std::max(longest, c.num_frames);
    throw Error("train: the dataset is too small for a window of " + std::to_string(window) + " frames: its longest of " +
                std::to_string(s.clips->size()) + " training clips has " + std::to_string(longest) +
                " frames (shorten the window or add longer clips)");
  }
  return s;
}

SplitWindows validation_windows(const data::Dataset& dataset, int window, int max_windows) {
  SplitWindows s;
  s.clips = &dataset.clips("val");
  s.window = window;
  const auto all = dataset.windows("val", window, std::max(1, window / 2));
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
  for (int64_t i = 0; i < count; ++i) {
    const data::WindowRef& w = windows[i];
    const auto& clip = (*split.clips)[w.clip];
    std::memcpy(pose[i].data_ptr<float>(), clip.pose.data() + static_cast<size_t>(w.start) * d_,
                sizeof(float) * window * d_);
    std::memcpy(ctrl[i].data_ptr<float>(), clip.control.data() + static_cast<size_t>(w.start) * c_,
                sizeof(float) * window * c_);
    content[i] = clip.content;
    style[i] = clip.style;
  }
  Batch b;
  b.pose = with_constant_noise(standardiser_.pose(pose), windows).to(device_);
  b.control = standardiser_.control(ctrl).to(device_);
  b.content = content.to(device_);
  b.style = style.to(device_);
  return b;
}

}  // namespace mosyn::nn::training
