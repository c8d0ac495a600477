// A prepared motion dataset: what `mosyn data prepare` writes and every model trains on.
//
// A dataset directory holds
//   dataset.json   self-description: version, fps, skeleton, pose form and feature layout,
//                  window length and hop, label vocabularies, the file split, augmentation,
//                  and the source folder it was made from
//   stats.json     per-dimension mean and standard deviation of pose and control features
//                  (computed on the training split, after augmentation; std floored at 1e-4 ... see
//                  DatasetStats)
//   train.bin, val.bin   compact binary caches of whole clips (see dataset.cpp for the layout)
// Training never re-parses BVH: windows are enumerated on the fly from whole clips.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "data/representation.h"

namespace mosyn::data {

// One clip of the cache, in features. Features are raw (not standardised).
struct ClipRecord {
  std::string source;       // the BVH file it came from, relative to the source folder
  int content = -1;         // index into DatasetInfo::content_labels, -1 if unlabelled
  int style = -1;           // index into DatasetInfo::style_labels, -1 if unlabelled
  bool mirrored = false;    // augmentation flags
  bool reversed = false;
  int num_frames = 0;
  std::vector<float> pose;     // [T, pose_dim]
  std::vector<float> control;  // [T, control_dim]
};

// Per-dimension standardisation statistics: x_std = (x - mean) / std.
struct DatasetStats {
  std::vector<float> pose_mean, pose_std;        // [pose_dim]
  std::vector<float> control_mean, control_std;  // [control_dim]
};

struct DatasetInfo {
  int version = 1;
  double fps = 30.0;
  Skeleton skeleton;            // the (possibly reduced) training skeleton
  FeatureLayout layout;         // pose form, dims and how to decode features to motion
  int window_frames = 0;        // training window length
  int window_hop = 0;           // frames between window starts (overlap = window - hop)
  std::vector<std::string> content_labels;  // vocabulary, index = label id
  std::vector<std::string> style_labels;
  std::vector<std::string> train_files, val_files;  // split by source file
  std::string source_dir;
};

// One training window: clip index within a split and first frame.
struct WindowRef {
  int clip = 0;
  int start = 0;
};

class Dataset {
 public:
  // Reads dataset.json, stats.json and both caches. Throws mosyn::Error / ParseError naming the
  // file when something is missing, truncated or inconsistent.
  static Dataset open(const std::string& dir);

  const DatasetInfo& info() const { return info_; }
  const DatasetStats& stats() const { return stats_; }
  // split is "train" or "val"; throws mosyn::Error otherwise.
  const std::vector<ClipRecord>& clips(const std::string& split) const;
  // Every window of window_frames frames with the given hop (0 = the dataset's own) in a split.
  std::vector<WindowRef> windows(const std::string& split, int window_frames = 0, int hop = 0) const;

  DatasetInfo info_;
  DatasetStats stats_;
  std::vector<ClipRecord> train_, val_;
};

}  // namespace mosyn::data
