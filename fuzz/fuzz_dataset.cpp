// libFuzzer harness: dataset directories (data/dataset.h): dataset.json, stats.json, train.bin and
// val.bin from one input (fuzz_input.h), opened with data::Dataset::open. A dataset that opens
// must enumerate its windows, recompute statistics and decode its clips to motion.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/error.h"
#include "data/dataset.h"
#include "fuzz_check.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  static const std::vector<std::string> kNames = {"dataset.json", "stats.json", "train.bin", "val.bin"};
  const auto dir = fuzz::scratch_dir("dataset");
  fuzz::write_files(dir, kNames, fuzz::split_input(data, size, kNames.size()));
  data::Dataset dataset;
  try {
    dataset = data::Dataset::open(dir.string());
  } catch (const Error&) {
    return 0;
  }
  const data::DatasetInfo& info = dataset.info();
  const int pose_dim = info.layout.pose_dim, control_dim = info.layout.control_dim;
  for (const char* split : {"train", "val"}) {
    const auto& clips = dataset.clips(split);
    const auto windows = dataset.windows(split);
    for (const data::WindowRef& w : windows) FUZZ_CHECK(w.start + info.window_frames <= clips[w.clip].num_frames);
    const data::DatasetStats stats = data::compute_stats(clips, pose_dim, control_dim);
    FUZZ_CHECK(stats.pose_mean.size() == static_cast<size_t>(pose_dim));
    if (!clips.empty() && clips.front().num_frames <= 1000) {
      try {
        const Clip clip = data::decode_record(info, clips.front());
        FUZZ_CHECK(clip.motion.num_frames == clips.front().num_frames);
      } catch (const Error&) {
      }
    }
  }
  return 0;
}
