// A prepared motion dataset: what `mosyn data prepare` writes and every model trains on.
//
// A dataset directory holds
//   dataset.json   self-description: version, fps, skeleton, pose form and feature layout,
//                  window length and hop, label vocabularies, the file split, augmentation,
//                  and the source folder it was made from
//   stats.json     per-dimension mean and standard deviation of pose and control features
//                  (computed on the training split, after augmentation; std floored at
//                  kStdFloor, see DatasetStats)
//   train.bin, val.bin   compact binary caches of whole clips (layout below)
// dataset.json is written last, so a directory with it is complete.
//
// Cache layout (little-endian throughout):
//   char[8]  "MOSYNCLP"           magic
//   u32      version (1)
//   u32      pose_dim, control_dim
//   u32      num_clips
//   u64      total frames
//   num_clips times:
//     u32 source length, bytes (UTF-8, no terminator)
//     i32 content, i32 style     (-1 = unlabelled)
//     u8  flags                  (bit 0 mirrored, bit 1 reversed, bit 2 retimed, bit 3 at rest)
//     u32 num_frames
//     f32 pose[num_frames * pose_dim], f32 control[num_frames * control_dim]
//   u64      FNV-1a 64 hash of every byte before it
//   char[8]  "MOSYNEND"
// A truncated, extended or corrupted file fails the size, hash or end-marker check with an
// error naming it.
// Training never re-parses BVH: windows are enumerated on the fly from whole clips.
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
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
  bool retimed = false;     // played faster or slower (PrepareOptions::retime_factors)
  bool at_rest = false;     // starts or stops at rest (PrepareOptions::rest_hold_s)
  int num_frames = 0;
  std::vector<float> pose;     // [T, pose_dim]
  std::vector<float> control;  // [T, control_dim]

  // A copy made by augmentation rather than a take as recorded.
  bool augmented() const { return mirrored || reversed || retimed || at_rest; }
};

// Smallest standard deviation stored (feature units: metres, radians, 6D components). Constant
// dimensions (e.g. the root's own x and z in positions form, always 0) would otherwise blow up
// standardisation; with the floor they standardise to (x - mean) / 1e-3.
constexpr float kStdFloor = 1e-3f;

// Per-dimension standardisation statistics: x_std = (x - mean) / std, std = max(sample std,
// kStdFloor) over every frame of the training split (population std, augmented clips included).
//
// pose_constant lists the near-constant pose dimensions (sample std below kStdFloor, e.g. the
// rotation of a joint the capture never moves: 32 of 153 on the CMU subset), in increasing
// order. Standardised, such a dimension is (almost) the same number in every frame, and a density
// model can make its likelihood unbounded (a flow's ActNorm starts at a log-determinant of
// hundreds of nats per frame and training diverges). Models therefore never see their values:
// training batches carry unit Gaussian noise there, conditioning inputs zero, and decoding
// restores the dimension's mean (nn/standardiser.h). Recorded by compute_stats since this field
// exists; absent in older stats.json files, which keep their old behaviour (no dimension treated
// as constant).
struct DatasetStats {
  std::vector<float> pose_mean, pose_std;        // [pose_dim]
  std::vector<float> control_mean, control_std;  // [control_dim]
  std::vector<int> pose_constant;                // near-constant pose dimensions, increasing
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
  std::string source_dir;       // the source folder; several joined by ';' (see source_dirs)
  // Added by the data layer (optional in dataset.json, defaults below):
  std::vector<std::string> source_dirs;   // every input folder, in order
  std::string source_layout;              // "bandai-namco", "cmu", "plain" or "mixed"
  bool augment_mirror = false;            // mirrored copies of every clip are in the caches
  bool augment_reverse = false;           // time-reversed copies are in the caches
  std::vector<double> augment_retime;     // playback-speed factors of the retimed copies (empty: none)
  // Only clips whose mean root speed lies in [min, max] were retimed (0: no bound).
  double augment_retime_min_speed_mps = 0, augment_retime_max_speed_mps = 0;
  // Copies starting from and coming to rest (PrepareOptions::rest_hold_s; 0: none) and their ramp.
  double augment_rest_hold_s = 0, augment_rest_ramp_s = 0;
  double augment_rest_fraction = 1.0;  // the share of those copies kept (PrepareOptions::rest_fraction)
  // Where stats.json came from when not computed on this dataset's training split
  // (PrepareOptions::stats_from); empty otherwise.
  std::string stats_from;
  // The dataset or run directory whose file split this one kept (PrepareOptions::split_from);
  // empty otherwise.
  std::string split_from;
  std::string tpose = "auto";             // T-pose removal mode used (data/augment.h)
  std::vector<std::string> drop_joint_patterns, keep_joint_patterns;
  std::vector<std::string> source_joint_names;  // joints of the BVH files before any reduction
  // When > 0, the training split was cut to this many seconds of original motion (DFN's
  // limited-data runs; PrepareOptions::max_train_seconds). Written only when > 0.
  double max_train_seconds = 0;
};

// One training window: clip index within a split, first frame, and for a clip shorter than the
// window its own length (frames > 0; the window is then padded by whoever cuts it).
struct WindowRef {
  int clip = 0;
  int start = 0;
  int frames = 0;  // 0: a full window
};

class Dataset {
 public:
  // Reads dataset.json, stats.json and both caches. Throws mosyn::Error / ParseError naming the
  // file when something is missing, truncated or inconsistent.
  static Dataset open(const std::string& dir);

  // Frames and windows of a split's clips are enumerated in cache order.
  const DatasetInfo& info() const { return info_; }
  const DatasetStats& stats() const { return stats_; }
  // split is "train" or "val"; throws mosyn::Error otherwise.
  const std::vector<ClipRecord>& clips(const std::string& split) const;
  // Every window of window_frames frames with the given hop (0 = the dataset's own) in a split:
  // for each clip, starts 0, hop, 2 hop, ... while start + window_frames <= num_frames. A clip
  // shorter than a window gives none, unless min_short_frames > 0 and it has at least that many
  // frames: then one window at frame 0 of its own length (WindowRef::frames), for models that mask
  // padding (the hierarchical VRNN's sequences "up to 200 frames"). Throws mosyn::Error for a bad
  // split or non-positive sizes.
  std::vector<WindowRef> windows(const std::string& split, int window_frames = 0, int hop = 0,
                                 int min_short_frames = 0) const;

  DatasetInfo info_;
  DatasetStats stats_;
  std::vector<ClipRecord> train_, val_;
};

// ---- Serialisation (used by Dataset::open and prepare_dataset; run directories may reuse) ----

nlohmann::json skeleton_to_json(const Skeleton& skeleton);
// Throws ParseError(file, 0, ...) naming the missing or malformed key.
Skeleton skeleton_from_json(const nlohmann::json& j, const std::string& file);
nlohmann::json layout_to_json(const FeatureLayout& layout);
FeatureLayout layout_from_json(const nlohmann::json& j, const std::string& file);
nlohmann::json info_to_json(const DatasetInfo& info);
// Also checks that the layout fits the skeleton (pose_dim, root joint).
DatasetInfo info_from_json(const nlohmann::json& j, const std::string& file);
nlohmann::json stats_to_json(const DatasetStats& stats);
DatasetStats stats_from_json(const nlohmann::json& j, const std::string& file);

// The cache bytes of clips (layout above). Throws mosyn::Error when a clip's arrays do not hold
// num_frames rows of the given dims.
std::string format_clip_cache(const std::vector<ClipRecord>& clips, int pose_dim, int control_dim);
// Parses cache bytes, checking magic, version, dims against the expected ones, sizes, hash and
// end marker. Throws ParseError(file, 0, ...) saying what is wrong.
std::vector<ClipRecord> parse_clip_cache(const std::string& bytes, int pose_dim, int control_dim,
                                         const std::string& file);

// Statistics of clips (see DatasetStats), near-constant pose dimensions included. Zero clips give
// mean 0, std 1 and no constant dimension.
DatasetStats compute_stats(const std::vector<ClipRecord>& clips, int pose_dim, int control_dim);

// Writes dataset.json, stats.json, train.bin and val.bin atomically into dir (created if
// missing). Throws mosyn::Error when dir already holds a dataset.json and overwrite is false.
void write_dataset(const std::string& dir, const DatasetInfo& info, const DatasetStats& stats,
                   const std::vector<ClipRecord>& train, const std::vector<ClipRecord>& val, bool overwrite);

// ---- Back to motion ----

// Raw (not standardised) features [num_frames, pose_dim] / [num_frames, control_dim] decoded to
// a clip on the dataset skeleton at the dataset's fps, starting at start_position (skeleton
// units) and start_heading_rad; ready for io::from_clip / write_bvh.
Clip decode_features(const DatasetInfo& info, const float* pose, const float* control, int num_frames,
                     const Eigen::Vector3d& start_position = Eigen::Vector3d::Zero(), double start_heading_rad = 0.0);
Clip decode_record(const DatasetInfo& info, const ClipRecord& record);

// Multi-line text for `mosyn data info`: source, fps, skeleton, form and dims, window, per split
// clips / frames / hours / windows, and label counts (clips) per split.
std::string dataset_summary(const Dataset& dataset);

}  // namespace mosyn::data
