// `mosyn data prepare`: BVH folders -> a dataset directory (data/dataset.h).
//
// Pipeline for every BVH file (parsed in parallel):
//   read_bvh -> to_clip -> collapse_static_root (Bandai-Namco's joint_Root: Hips becomes the
//   root) -> joint subset by glob patterns -> T-pose removal -> resample to fps
// then, over all files: same topology check (joint names and parents, after the steps above),
// dataset skeleton = mean offsets over files, bone-length check (each file's bones within
// kMaxBoneLengthDeviation of the mean), units guess (core/units.h) unless overridden, split by
// file, encode (every file on its own offsets, so positions form carries the subject's true
// joint positions; decode uses the mean skeleton), augmentation copies, training statistics,
// atomic writes.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/skeleton.h"
#include "data/augment.h"
#include "data/dataset.h"
#include "data/representation.h"

namespace mosyn::data {

// A file's bone may differ from the dataset's mean length by this fraction at most (CMU
// subjects differ by ~10%; more suggests a different skeleton or unit).
constexpr double kMaxBoneLengthDeviation = 0.25;

// Default PrepareOptions::root_smoothing_s. The MoGlow authors' preparation used 4 frames at 20
// fps (0.2 s); measured on Bandai-Namco locomotion (scripts/control_rhythm.py), 0.2 s leaves a third
// of the raw control's step-rate oscillation in dx and dtheta, 0.35 s a tenth, 0.5 s a twentieth.
constexpr double kDefaultRootSmoothingS = 0.35;

struct PrepareOptions {
  std::vector<std::string> input_dirs;  // source folders (data/labels.h layouts), at least one
  std::string output_dir;
  double fps = 0;                       // target frame rate, 0 = keep the files' own (must agree)
  PoseForm form = PoseForm::kRotations;
  // Gaussian filter (seconds, standard deviation) of the hip trajectory that becomes the
  // control (FeatureLayout::root_smoothing_s); 0 = the raw hip motion.
  double root_smoothing_s = kDefaultRootSmoothingS;
  std::vector<std::string> drop_joint_patterns;  // glob patterns of joints to drop (e.g. "*Thumb*")
  std::vector<std::string> keep_joint_patterns;  // if non-empty, only matching joints (+ the root)
  int window_frames = 120;              // training window length, frames at the target fps
  int window_hop = 30;                  // frames between window starts
  bool mirror = false;                  // add mirrored copies (labels with left/right swapped)
  bool reverse = false;                 // add time-reversed copies (and of mirrored ones)
  // Playback-speed factors of extra copies of every clip (and of its mirrored and reversed copies):
  // 1.2 adds the clip played 1.2 times as fast (data/augment.h retime). Widens the speeds a
  // model sees, e.g. walks up to 1.8 m/s where the takes stop at 1.6; but the cadence at a speed
  // becomes ambiguous (on Bandai-Namco it cost the recurrent VAE its held-out footsteps,
  // models/rvae-locomotion/README.md). Each factor positive, not 1.
  std::vector<double> retime_factors;
  // When > 0, only clips whose mean horizontal root speed (m/s, over the whole clip) is at least
  // retime_min_speed_mps (and, when retime_max_speed_mps > 0, at most that) get the retimed
  // copies: the fastest walks played faster fill the speeds the takes lack without putting a
  // second cadence beside the takes' own at the speeds they already cover.
  double retime_min_speed_mps = 0;
  double retime_max_speed_mps = 0;  // 0 = no upper bound
  // When > 0, two more copies of every clip (and of its mirrored, reversed and retimed copies):
  // one starting from rest, one coming to rest (data/augment.h come_to_rest at the clip's
  // double-support frame in its first or last half), the still pose held this many seconds and
  // the speed ramped over rest_ramp_s. No Bandai-Namco locomotion take starts or stops, so models
  // trained on them glide into the stop at a drawn path's end. A clip too short for the ramp on
  // its moving side, or slower than 0.3 m/s (standing), gets no such copy.
  double rest_hold_s = 0;
  double rest_ramp_s = 1.0;
  // The share of those copies kept, in (0, 1]: each (clip copy, end) pair is kept when a hash of its
  // source file, copy and end falls under it, so the choice is the same on every run. Fewer copies
  // teach the stop while changing less of what the model sees walking (the ramps are slowed
  // playback, the holds a still pose).
  double rest_fraction = 1.0;
  // When set, a dataset or run directory whose stats.json standardises this dataset instead of its
  // own training statistics (same pose and control dims), so that a model warm-started from that
  // run (`train --init-from`) reads the new data in the units its weights were trained on.
  std::string stats_from;
  // When set, a dataset directory (dataset.json) or run directory (config.json "dataset") whose
  // file split this dataset keeps: its held-out files stay held out and its training files stay in
  // training, so a model grown from that run is never validated on what it trained on; files it
  // does not list are split by val_fraction and seed as usual.
  std::string split_from;
  double val_fraction = 0.1;            // fraction of files held out, in [0, 1)
  std::uint64_t seed = 0;               // split seed
  std::vector<std::string> contents;    // keep only these content labels (empty: all)
  std::vector<std::string> styles;      // keep only these style labels (empty: all)
  int threads = 2;                      // parsing threads (>= 1)
  TposeMode tpose = TposeMode::kAuto;
  double meters_per_unit = 0;           // 0 = guess (core/units.h); e.g. 0.01 for centimetres
  bool overwrite = false;               // replace an existing dataset in output_dir
  // When > 0, keep at most this many seconds of original motion in the training split (Dynamic
  // Future Net's limited-data runs): training files in their sorted order until the budget is
  // spent, the last one cut at its end (with its augmented copies), later ones left out of the
  // dataset. Validation files are not cut.
  double max_train_seconds = 0;
};

struct PrepareProgress {
  std::string stage;        // "parse", "encode" or "write"
  int files_done = 0;
  int files_total = 0;
  std::string current_file;  // relative path of the file just finished ("" for "write")
};

using PrepareProgressCallback = std::function<void(const PrepareProgress&)>;

// Prepares the dataset and returns its description (as written to dataset.json). The callback,
// when given, is called once per file per stage and once for "write"; calls are serialised but
// may come from worker threads. Throws mosyn::Error / ParseError naming the file at fault: bad
// options, unreadable or malformed BVH, a topology mismatch (first mismatching file and what
// differs), bone lengths off the mean, frame rates that differ while fps = 0, no file left after
// filtering, an existing dataset without overwrite. Nothing is written when it throws.
DatasetInfo prepare_dataset(const PrepareOptions& options, const PrepareProgressCallback& progress = {});

// Features of one more motion for an existing dataset (e.g. a user's BVH to continue with a model
// trained on it): the clip goes through the same per-file steps as at prepare time (placeholder
// root folded, the dataset's joint patterns, T-pose removal in the dataset's mode, resampled to
// info.fps), takes the dataset's units and is encoded with info.layout on its own offsets. Writes
// raw pose [T, pose_dim] and control [T, control_dim] row-major. Throws mosyn::Error prefixed
// with `name` (e.g. the file path) when its hierarchy differs from the dataset skeleton's or a
// bone is more than kMaxBoneLengthDeviation off. start_position / start_heading_rad, when given,
// receive where the encoded motion starts (floor position of its root in skeleton units, and
// heading), the placement data::decode_features needs to put the motion back where it was.
void encode_clip_for_dataset(const DatasetInfo& info, const Clip& clip, const std::string& name,
                             std::vector<float>* pose, std::vector<float>* control,
                             Eigen::Vector3d* start_position = nullptr, double* start_heading_rad = nullptr);

// Writes a small Bandai-Namco-like source folder of synthetic walks (core/synthetic.h) for tests
// and demos: <dir>/cfg/content_label.txt ("dataset-9_walk", "dataset-9_walk-turn-left",
// "dataset-9_walk-turn-right", "dataset-9_run"), cfg/style_label.txt ("dataset-9_normal",
// "dataset-9_brisk"), and data/dataset-9_<content>_<style>_<take>.bvh plus .json labels.
// Skeletons carry a static joint_Root above Hips and six channels per joint, as Bandai-Namco's.
// takes_per_label files per (content, style) pair, num_frames frames at 30 fps each.
void write_synthetic_source(const std::string& dir, int takes_per_label = 2, int num_frames = 90,
                            std::uint64_t seed = 1);

}  // namespace mosyn::data
