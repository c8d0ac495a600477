#include "data/prepare.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cmath>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <thread>

#include "core/error.h"
#include "core/parallel.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "core/units.h"
#include "data/labels.h"
#include "io/bvh.h"
#include "io/json_file.h"
#include "io/atomic_file.h"

namespace mosyn::data {
namespace fs = std::filesystem;
namespace {

struct Item {
  std::string path;    // full path
  std::string source;  // name recorded in the dataset
  int content = -1;
  int style = -1;
};

int index_of(const std::vector<std::string>& v, const std::string& s) {
  const auto it = std::find(v.begin(), v.end(), s);
  return it == v.end() ? -1 : static_cast<int>(it - v.begin());
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

// Topology difference between two skeletons, "" when names, parents and end sites agree.
std::string topology_difference(const Skeleton& expected, const Skeleton& got) {
  if (expected.num_joints() != got.num_joints())
    return std::to_string(got.num_joints()) + " joints instead of " + std::to_string(expected.num_joints());
  for (int j = 0; j < got.num_joints(); ++j) {
    if (expected.joint_names[j] != got.joint_names[j])
      return "joint " + std::to_string(j) + " is '" + got.joint_names[j] + "' instead of '" + expected.joint_names[j] + "'";
    if (expected.parents[j] != got.parents[j])
      return "joint '" + got.joint_names[j] + "' has parent " +
             (got.parents[j] < 0 ? std::string("none") : "'" + got.joint_names[got.parents[j]] + "'") + " instead of " +
             (expected.parents[j] < 0 ? std::string("none") : "'" + expected.joint_names[expected.parents[j]] + "'");
  }
  if (expected.end_sites.size() != got.end_sites.size())
    return std::to_string(got.end_sites.size()) + " end sites instead of " + std::to_string(expected.end_sites.size());
  for (size_t e = 0; e < got.end_sites.size(); ++e)
    if (expected.end_sites[e].parent != got.end_sites[e].parent)
      return "end site " + std::to_string(e) + " hangs off another joint";
  return "";
}

// The per-file steps: placeholder root folded, joint subset, T-pose removal, resampling (fps 0 =
// keep). Errors are prefixed with name.
Clip clean_clip(const Clip& raw, const std::string& name, const std::vector<std::string>& drop_patterns,
                const std::vector<std::string>& keep_patterns, TposeMode tpose, double fps) {
  Clip clip = collapse_static_root(raw);
  try {
    clip = subset_by_patterns(clip, drop_patterns, keep_patterns);
  } catch (const Error& e) {
    throw Error(name + ": " + e.what());
  }
  clip.motion = remove_tpose(clip.motion, tpose);
  if (fps > 0) clip.motion = resample(clip.motion, fps);
  return clip;
}

// Error text when a bone of `got` is more than kMaxBoneLengthDeviation off `mean`, else "".
std::string bone_length_difference(const Skeleton& mean, const Skeleton& got) {
  double size = 0;
  for (const Eigen::Vector3d& v : mean.offsets) size += v.norm();
  for (int j = 1; j < mean.num_joints(); ++j) {
    const double expected = mean.offsets[j].norm(), len = got.offsets[j].norm();
    if (std::abs(len - expected) > kMaxBoneLengthDeviation * expected + 1e-6 * size)
      return "bone to '" + mean.joint_names[j] + "' is " + std::to_string(len) + " units long, the dataset mean is " +
             std::to_string(expected) + " (more than " + std::to_string(static_cast<int>(kMaxBoneLengthDeviation * 100)) +
             "% off: a different skeleton or unit?)";
  }
  return "";
}

void check_options(const PrepareOptions& o) {
  if (o.input_dirs.empty()) throw Error("prepare: no input folder given");
  if (o.output_dir.empty()) throw Error("prepare: no output folder given");
  if (!(o.fps >= 0) || !std::isfinite(o.fps)) throw Error("prepare: fps must be 0 (keep) or positive");
  if (o.window_frames <= 0) throw Error("prepare: window_frames must be positive");
  if (o.window_hop <= 0) throw Error("prepare: window_hop must be positive");
  if (!(o.val_fraction >= 0 && o.val_fraction < 1)) throw Error("prepare: val_fraction must be in [0, 1)");
  if (!(o.max_train_seconds >= 0)) throw Error("prepare: max_train_seconds must not be negative");
  if (o.threads < 1) throw Error("prepare: threads must be at least 1");
  if (!(o.meters_per_unit >= 0) || !std::isfinite(o.meters_per_unit))
    throw Error("prepare: meters_per_unit must be 0 (guess) or positive");
  if (!o.split_from.empty() && !fs::exists(fs::path(o.split_from) / "dataset.json") &&
      !fs::exists(fs::path(o.split_from) / "config.json"))
    throw Error(o.split_from + ": no dataset.json or config.json (split_from takes a dataset or run directory)");
  if (!o.stats_from.empty() && !fs::exists(fs::path(o.stats_from) / "stats.json"))
    throw Error(o.stats_from + ": no stats.json (stats_from takes a dataset or run directory)");
  for (double f : o.retime_factors)
    if (!(f > 0) || !std::isfinite(f) || std::abs(f - 1) < 1e-6)
      throw Error("prepare: retime factors must be positive and not 1 (got " + std::to_string(f) + ")");
  if (!(o.retime_min_speed_mps >= 0) || !std::isfinite(o.retime_min_speed_mps) || !(o.retime_max_speed_mps >= 0) ||
      !std::isfinite(o.retime_max_speed_mps))
    throw Error("prepare: retime_min_speed_mps and retime_max_speed_mps must be 0 (no bound) or positive");
  if (o.retime_max_speed_mps > 0 && o.retime_max_speed_mps < o.retime_min_speed_mps)
    throw Error("prepare: retime_max_speed_mps is below retime_min_speed_mps: no clip would be retimed");
  if (!(o.rest_hold_s >= 0) || !std::isfinite(o.rest_hold_s) || !(o.rest_ramp_s >= 0) || !std::isfinite(o.rest_ramp_s))
    throw Error("prepare: rest_hold_s and rest_ramp_s must be 0 or positive seconds");
  if (!(o.rest_fraction > 0 && o.rest_fraction <= 1))
    throw Error("prepare: rest_fraction must lie in (0, 1], got " + std::to_string(o.rest_fraction));
}

// Lists and filters every input; builds the shared vocabularies and the file items.
std::vector<Item> list_inputs(const PrepareOptions& o, DatasetInfo* info) {
  std::vector<SourceListing> listings;
  for (const std::string& dir : o.input_dirs) listings.push_back(list_source(dir));

  // A filter name must be known to some input; each input is filtered by the names it knows.
  auto known_somewhere = [&](const std::vector<std::string>& names, bool content) {
    for (const std::string& raw : names) {
      const std::string name = strip_dataset_prefix(raw);
      bool found = false;
      std::vector<std::string> all;
      for (const SourceListing& l : listings)
        for (const std::string& v : content ? l.content_labels : l.style_labels) {
          found = found || v == name;
          if (index_of(all, v) < 0) all.push_back(v);
        }
      if (!found)
        throw Error(std::string("prepare: unknown ") + (content ? "content" : "style") + " '" + name + "'" +
                    (all.empty() ? std::string(" (the inputs have no such labels)") : " (known: " + join(all, ", ") + ")"));
    }
  };
  known_somewhere(o.contents, true);
  known_somewhere(o.styles, false);
  for (SourceListing& l : listings) {
    auto known_here = [&](const std::vector<std::string>& names, const std::vector<std::string>& vocabulary) {
      std::vector<std::string> out;
      for (const std::string& n : names)
        if (index_of(vocabulary, strip_dataset_prefix(n)) >= 0) out.push_back(strip_dataset_prefix(n));
      return out;
    };
    const std::vector<std::string> c = known_here(o.contents, l.content_labels);
    const std::vector<std::string> s = known_here(o.styles, l.style_labels);
    if ((!o.contents.empty() && c.empty()) || (!o.styles.empty() && s.empty()))
      l.files.clear();  // this input has none of the wanted labels
    else
      filter_source(&l, c, s);
  }

  // Vocabularies: union over inputs in order, restricted to the filters when given.
  for (const SourceListing& l : listings) {
    for (const std::string& v : l.content_labels)
      if (index_of(info->content_labels, v) < 0 &&
          (o.contents.empty() || std::any_of(o.contents.begin(), o.contents.end(),
                                             [&](const std::string& n) { return strip_dataset_prefix(n) == v; })))
        info->content_labels.push_back(v);
    for (const std::string& v : l.style_labels)
      if (index_of(info->style_labels, v) < 0 &&
          (o.styles.empty() || std::any_of(o.styles.begin(), o.styles.end(),
                                           [&](const std::string& n) { return strip_dataset_prefix(n) == v; })))
        info->style_labels.push_back(v);
  }

  // Source names: relative paths, prefixed by the input folder's name when there are several.
  std::vector<std::string> prefixes;
  std::set<std::string> layouts;
  for (size_t k = 0; k < listings.size(); ++k) {
    std::string name = fs::path(listings[k].dir).lexically_normal().filename().string();
    if (name.empty() || name == ".") name = fs::path(listings[k].dir).lexically_normal().parent_path().filename().string();
    if (index_of(prefixes, name) >= 0 || name.empty()) name = std::to_string(k) + "_" + name;
    prefixes.push_back(name);
    layouts.insert(to_string(listings[k].layout));
  }
  info->source_layout = layouts.size() == 1 ? *layouts.begin() : "mixed";
  std::vector<Item> items;
  for (size_t k = 0; k < listings.size(); ++k)
    for (const SourceFile& f : listings[k].files) {
      Item item;
      item.path = f.path;
      item.source = listings.size() == 1 ? f.relative : prefixes[k] + "/" + f.relative;
      item.content = f.content.empty() ? -1 : index_of(info->content_labels, f.content);
      item.style = f.style.empty() ? -1 : index_of(info->style_labels, f.style);
      items.push_back(std::move(item));
    }
  if (items.empty()) throw Error("prepare: no BVH file left in " + join(o.input_dirs, ", ") + " after filtering");
  return items;
}

// Frames to keep of each file: all of a validation file; of training files, in order, what fits
// max_train_seconds (0 = no limit), a file cut to its first frames when the budget ends inside it
// and 0 (left out) after. A cut shorter than 2 frames leaves the file out.
std::vector<int> training_budget(const std::vector<Clip>& clips, const std::vector<bool>& is_val,
                                 double max_train_seconds) {
  std::vector<int> keep(clips.size());
  long budget = max_train_seconds > 0 ? std::lround(max_train_seconds * clips[0].motion.fps)
                                      : std::numeric_limits<long>::max();
  for (size_t i = 0; i < clips.size(); ++i) {
    keep[i] = clips[i].motion.num_frames;
    if (is_val[i]) continue;
    keep[i] = static_cast<int>(std::min<long>(keep[i], budget));
    if (keep[i] < 2) keep[i] = 0;
    budget -= keep[i];
  }
  return keep;
}

// Throws, naming the file, when a clip's hierarchy or frame rate differs from the first's.
void check_same_topology_and_rate(const std::vector<Clip>& clips, const std::vector<Item>& items) {
  const Skeleton& first = clips[0].skeleton;
  for (size_t i = 1; i < clips.size(); ++i) {
    const std::string diff = topology_difference(first, clips[i].skeleton);
    if (!diff.empty())
      throw Error(items[i].path + ": skeleton differs from " + items[0].path + ": " + diff +
                  " (all files of a dataset must share one hierarchy; drop differing joints with joint patterns)");
    if (std::abs(clips[i].motion.fps - clips[0].motion.fps) > 1e-3 * clips[0].motion.fps)
      throw Error(items[i].path + ": frame rate " + std::to_string(clips[i].motion.fps) + " differs from " +
                  std::to_string(clips[0].motion.fps) + " in " + items[0].path + "; set a target fps");
  }
}

// The dataset's skeleton: the clips' mean offsets (every bone length must stay near the mean)
// and the scale given or guessed, which every clip then takes.
Skeleton mean_skeleton(std::vector<Clip>* clips, const std::vector<Item>& items, double meters_per_unit) {
  const double n = static_cast<double>(clips->size());
  Skeleton skeleton = (*clips)[0].skeleton;
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Clip& c : *clips) sum += c.skeleton.offsets[j];
    skeleton.offsets[j] = sum / n;
  }
  for (size_t e = 0; e < skeleton.end_sites.size(); ++e) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Clip& c : *clips) sum += c.skeleton.end_sites[e].offset;
    skeleton.end_sites[e].offset = sum / n;
  }
  for (size_t i = 0; i < clips->size(); ++i) {
    const std::string diff = bone_length_difference(skeleton, (*clips)[i].skeleton);
    if (!diff.empty()) throw Error(items[i].path + ": " + diff);
  }
  skeleton.meters_per_unit = meters_per_unit > 0 ? meters_per_unit : guess_meters_per_unit(skeleton);
  for (Clip& c : *clips) c.skeleton.meters_per_unit = skeleton.meters_per_unit;
  return skeleton;
}

// What dataset.json says of the options and the first pass (everything but the file split).
DatasetInfo describe_dataset(const PrepareOptions& o, DatasetInfo info, const Skeleton& skeleton, double fps,
                             const std::vector<std::string>& raw_joint_names) {
  info.version = 1;
  info.fps = fps;
  info.skeleton = skeleton;
  info.layout = make_layout(skeleton, o.form, 0, estimate_forward_in_root(skeleton), o.root_smoothing_s);
  info.window_frames = o.window_frames;
  info.window_hop = o.window_hop;
  info.source_dirs = o.input_dirs;
  info.source_dir = join(o.input_dirs, ";");
  info.augment_mirror = o.mirror;
  info.augment_reverse = o.reverse;
  info.augment_retime = o.retime_factors;
  if (!o.retime_factors.empty()) {
    info.augment_retime_min_speed_mps = o.retime_min_speed_mps;
    info.augment_retime_max_speed_mps = o.retime_max_speed_mps;
  }
  if (o.rest_hold_s > 0) {
    info.augment_rest_hold_s = o.rest_hold_s;
    info.augment_rest_ramp_s = o.rest_ramp_s;
    info.augment_rest_fraction = o.rest_fraction;
  }
  info.tpose = to_string(o.tpose);
  info.drop_joint_patterns = o.drop_joint_patterns;
  info.keep_joint_patterns = o.keep_joint_patterns;
  info.source_joint_names = raw_joint_names;
  info.max_train_seconds = o.max_train_seconds;
  return info;
}

// Held-out files by a seeded Fisher-Yates shuffle (own index mapping, so the split is the same on
// every standard library): the first round(val_fraction n) shuffled files, at least one when the
// fraction is positive, never all.
std::vector<bool> validation_files(int n, double val_fraction, uint64_t seed) {
  std::vector<int> order(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order[i] = i;
  std::mt19937_64 rng(seed);
  for (int i = n - 1; i > 0; --i) std::swap(order[i], order[static_cast<size_t>(rng() % static_cast<uint64_t>(i + 1))]);
  int num_val = static_cast<int>(std::lround(val_fraction * n));
  if (val_fraction > 0 && num_val == 0 && n >= 2) num_val = 1;
  num_val = std::min(num_val, n - 1);
  std::vector<bool> is_val(static_cast<size_t>(n), false);
  for (int k = 0; k < num_val; ++k) is_val[order[k]] = true;
  return is_val;
}

// The split of dir's dataset (PrepareOptions::split_from) applied to items: its val_files held out,
// its train_files kept for training, the files it does not list split by fresh_split.
std::vector<bool> borrowed_split(const std::string& dir, const std::vector<Item>& items,
                                 const std::vector<bool>& fresh_split) {
  const fs::path dataset_json = fs::path(dir) / "dataset.json";
  const std::string path = fs::exists(dataset_json) ? dataset_json.string() : (fs::path(dir) / "config.json").string();
  const nlohmann::json j = io::read_json(path);
  const nlohmann::json& info = j.contains("dataset") ? j.at("dataset") : j;
  std::set<std::string> val, train;
  try {
    for (const auto& f : info.at("val_files")) val.insert(f.get<std::string>());
    for (const auto& f : info.at("train_files")) train.insert(f.get<std::string>());
  } catch (const std::exception& e) {
    throw Error(path + ": no file split to keep (train_files and val_files lists of names expected: " + e.what() + ")");
  }
  std::vector<bool> is_val = fresh_split;
  bool any_known = false;
  for (size_t i = 0; i < items.size(); ++i) {
    if (val.count(items[i].source)) is_val[i] = true;
    else if (train.count(items[i].source)) is_val[i] = false;
    else continue;
    any_known = true;
  }
  if (!any_known)
    throw Error(path + ": none of its files is among the inputs (file names are recorded relative to the input folder)");
  return is_val;
}

// Mean horizontal speed of the root over a motion, m/s (0 for fewer than 2 frames).
double mean_root_speed_mps(const Skeleton& skeleton, const Motion& motion, int root_joint) {
  if (motion.num_frames < 2) return 0;
  double distance = 0;
  for (int t = 1; t < motion.num_frames; ++t) {
    Eigen::Vector3d step = motion.translation(t, root_joint) - motion.translation(t - 1, root_joint);
    step[skeleton.up_axis] = 0;
    distance += step.norm();
  }
  return distance * skeleton.meters_per_unit * motion.fps / (motion.num_frames - 1);
}

// Clips slower than this (m/s, mean root speed) get no copies at rest: they stand already.
constexpr double kRestMinSpeedMps = 0.3;

// Whether the copy at rest of one clip copy and end is kept (PrepareOptions::rest_fraction): its
// FNV-1a hash (source file, flags, the retime factor of a retimed copy, end), mapped to [0, 1),
// under the fraction. retime_factor 0: a copy at the take's own speed. The same on every machine
// and run.
bool rest_copy_kept(double fraction, const std::string& source, bool mirrored, bool reversed, double retime_factor,
                    RestEnd end) {
  const bool retimed = retime_factor > 0;
  if (fraction >= 1) return true;
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](unsigned char byte) { h = (h ^ byte) * 1099511628211ull; };
  for (const char c : source) mix(static_cast<unsigned char>(c));
  for (const bool flag : {mirrored, reversed, retimed, end == RestEnd::kEnd}) mix(flag ? 1 : 0);
  if (retimed)  // each factor's copies chosen apart (the factor in thousandths, little-endian)
    for (std::uint64_t f = static_cast<std::uint64_t>(std::llround(retime_factor * 1000)), k = 0; k < 8; ++k, f >>= 8)
      mix(static_cast<unsigned char>(f & 0xff));
  return static_cast<double>(h >> 11) / static_cast<double>(1ull << 53) < fraction;
}

// Whether a clip gets the dataset's retimed copies: its mean root speed lies in the band of
// DatasetInfo::augment_retime_min/max_speed_mps (0: no bound).
bool retime_band_holds(const DatasetInfo& info, const Clip& clip) {
  const double lo = info.augment_retime_min_speed_mps, hi = info.augment_retime_max_speed_mps;
  if (lo <= 0 && hi <= 0) return true;
  const double speed_mps = mean_root_speed_mps(clip.skeleton, clip.motion, info.layout.root_joint);
  return speed_mps >= lo && (hi <= 0 || speed_mps <= hi);
}

// The feature records of one file's clip cut to keep_frames: the original, then the augmented
// copies info.augment_* asks for (mirrored with mirrored labels, reversed, then each of those
// retimed) next to it. Errors name the file.
std::vector<ClipRecord> encode_with_augmentation(const DatasetInfo& info, const MirrorPlan& plan,
                                                 const Item& item, Clip clip, int keep_frames) {
  if (keep_frames < clip.motion.num_frames) clip.motion = slice_frames(clip.motion, 0, keep_frames);
  auto mirrored_id = [](int id, const std::vector<std::string>& vocabulary) {
    if (id < 0) return id;
    const int other = index_of(vocabulary, mirrored_label(vocabulary[id]));
    return other >= 0 ? other : id;
  };
  std::vector<ClipRecord> records;
  auto add = [&](const Motion& motion, bool mirrored, bool reversed, bool retimed, bool at_rest = false) {
    ClipRecord r;
    r.source = item.source;
    r.content = mirrored ? mirrored_id(item.content, info.content_labels) : item.content;
    r.style = mirrored ? mirrored_id(item.style, info.style_labels) : item.style;
    r.mirrored = mirrored;
    r.reversed = reversed;
    r.retimed = retimed;
    r.at_rest = at_rest;
    r.num_frames = motion.num_frames;
    encode(clip.skeleton, motion, info.layout, &r.pose, &r.control);
    records.push_back(std::move(r));
  };
  try {
    struct Copy {
      Motion motion;
      bool mirrored, reversed;
    };
    std::vector<Copy> copies = {{clip.motion, false, false}};
    if (info.augment_mirror) copies.push_back({mirror(clip.skeleton, clip.motion, plan), true, false});
    if (info.augment_reverse) {
      const size_t base = copies.size();
      for (size_t k = 0; k < base; ++k) copies.push_back({reverse_frames(copies[k].motion), copies[k].mirrored, true});
    }
    // The copies starting from and coming to rest (PrepareOptions::rest_hold_s), where the clip
    // moves (a standing take needs none) and has two legs and a double-support frame with room for
    // the ramp.
    // retime_factor 0: a copy at the take's own speed.
    const auto add_at_rest = [&](const Skeleton& skeleton, const Motion& motion, bool mirrored, bool reversed,
                                 double retime_factor) {
      if (mean_root_speed_mps(skeleton, motion, info.layout.root_joint) < kRestMinSpeedMps) return;
      for (const RestEnd end : {RestEnd::kStart, RestEnd::kEnd}) {
        if (!rest_copy_kept(info.augment_rest_fraction, item.source, mirrored, reversed, retime_factor, end)) continue;
        const int rest_frame = double_support_frame(skeleton, motion, end, info.augment_rest_ramp_s / 2);
        if (rest_frame < 0) continue;
        add(come_to_rest(motion, rest_frame, end, info.augment_rest_ramp_s, info.augment_rest_hold_s), mirrored,
            reversed, retime_factor > 0, true);
      }
    };
    for (const Copy& c : copies) add(c.motion, c.mirrored, c.reversed, false);
    if (info.augment_rest_hold_s > 0)
      for (const Copy& c : copies) add_at_rest(clip.skeleton, c.motion, c.mirrored, c.reversed, 0.0);
    const std::vector<double> factors = retime_band_holds(info, clip) ? info.augment_retime : std::vector<double>{};
    for (double factor : factors)
      for (const Copy& c : copies) {
        const Motion retimed = retime(c.motion, factor);
        if (retimed.num_frames >= 2) add(retimed, c.mirrored, c.reversed, true);
        if (info.augment_rest_hold_s > 0) add_at_rest(clip.skeleton, retimed, c.mirrored, c.reversed, factor);
      }
  } catch (const Error& e) {
    throw Error(item.path + ": " + e.what());
  }
  return records;
}

// The statistics in dir/stats.json (a dataset or a run directory; check_options saw the file),
// checked against the layout.
DatasetStats borrowed_stats(const std::string& dir, const FeatureLayout& layout) {
  const std::string path = (fs::path(dir) / "stats.json").string();
  DatasetStats stats = stats_from_json(io::read_json(path), path);
  if (static_cast<int>(stats.pose_mean.size()) != layout.pose_dim ||
      static_cast<int>(stats.control_mean.size()) != layout.control_dim)
    throw Error(path + ": statistics of dims (" + std::to_string(stats.pose_mean.size()) + ", " +
                std::to_string(stats.control_mean.size()) + ") do not fit this dataset's features (" +
                std::to_string(layout.pose_dim) + ", " + std::to_string(layout.control_dim) + ")");
  return stats;
}

}  // namespace

DatasetInfo prepare_dataset(const PrepareOptions& o, const PrepareProgressCallback& progress) {
  check_options(o);
  if (fs::exists(fs::path(o.output_dir) / "dataset.json") && !o.overwrite)
    throw Error(o.output_dir + ": already holds a dataset (dataset.json); pass overwrite to replace it");

  DatasetInfo info;
  const std::vector<Item> items = list_inputs(o, &info);
  const int n = static_cast<int>(items.size());
  std::mutex progress_mutex;
  int done = 0;
  auto report = [&](const char* stage, const std::string& file) {
    if (!progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    PrepareProgress p;
    p.stage = stage;
    p.files_done = ++done;
    p.files_total = n;
    p.current_file = file;
    progress(p);
  };

  // 1. Parse and clean every file; 2. one hierarchy and frame rate; 3. the mean skeleton.
  std::vector<Clip> clips(static_cast<size_t>(n));
  std::vector<std::string> raw_joint_names;
  parallel_for(n, o.threads, [&](int i) {
    const io::BvhFile bvh = io::read_bvh(items[i].path);
    Clip clip = io::to_clip(bvh);
    if (i == 0) raw_joint_names = clip.skeleton.joint_names;
    clips[i] = clean_clip(clip, items[i].path, o.drop_joint_patterns, o.keep_joint_patterns, o.tpose, o.fps);
    report("parse", items[i].source);
  });
  check_same_topology_and_rate(clips, items);
  const Skeleton skeleton = mean_skeleton(&clips, items, o.meters_per_unit);
  info = describe_dataset(o, std::move(info), skeleton, clips[0].motion.fps, raw_joint_names);

  // 4. Split by file, then the training budget.
  std::vector<bool> is_val = validation_files(n, o.val_fraction, o.seed);
  if (!o.split_from.empty()) is_val = borrowed_split(o.split_from, items, is_val);
  const std::vector<int> keep_frames = training_budget(clips, is_val, o.max_train_seconds);
  for (int i = 0; i < n; ++i)
    if (keep_frames[i] > 0) (is_val[i] ? info.val_files : info.train_files).push_back(items[i].source);
  if (info.train_files.empty())
    throw Error("prepare: max_train_seconds " + std::to_string(o.max_train_seconds) +
                " keeps no training clip of at least 2 frames");

  // 5. Features, with augmentation copies next to their original.
  const MirrorPlan plan = plan_mirror(skeleton);
  std::vector<std::vector<ClipRecord>> records(static_cast<size_t>(n));
  done = 0;
  parallel_for(n, o.threads, [&](int i) {
    if (keep_frames[i] == 0) return;
    records[i] = encode_with_augmentation(info, plan, items[i], std::move(clips[i]), keep_frames[i]);
    report("encode", items[i].source);
  });

  std::vector<ClipRecord> train, val;
  for (int i = 0; i < n; ++i)
    for (ClipRecord& r : records[i]) (is_val[i] ? val : train).push_back(std::move(r));
  const DatasetStats stats = o.stats_from.empty()
                                 ? compute_stats(train, info.layout.pose_dim, info.layout.control_dim)
                                 : borrowed_stats(o.stats_from, info.layout);
  info.stats_from = o.stats_from;
  info.split_from = o.split_from;
  write_dataset(o.output_dir, info, stats, train, val, o.overwrite);
  if (progress) {
    PrepareProgress p;
    p.stage = "write";
    p.files_done = p.files_total = n;
    progress(p);
  }
  return info;
}

void encode_clip_for_dataset(const DatasetInfo& info, const Clip& raw, const std::string& name,
                             std::vector<float>* pose, std::vector<float>* control, Eigen::Vector3d* start_position,
                             double* start_heading_rad) {
  Clip clip = clean_clip(raw, name, info.drop_joint_patterns, info.keep_joint_patterns, parse_tpose_mode(info.tpose),
                         info.fps);
  std::string diff = topology_difference(info.skeleton, clip.skeleton);
  if (diff.empty()) diff = bone_length_difference(info.skeleton, clip.skeleton);
  if (!diff.empty())
    throw Error(name + ": skeleton differs from the model's dataset: " + diff +
                " (the motion must use the skeleton the model was trained on)");
  if (clip.motion.num_frames < 1) throw Error(name + ": no frames");
  clip.skeleton.meters_per_unit = info.skeleton.meters_per_unit;
  encode(clip.skeleton, clip.motion, info.layout, pose, control);
  if (start_position || start_heading_rad) {
    const GroundTrajectory ground = control_trajectory(clip.skeleton, clip.motion, info.layout);
    if (start_position) *start_position = ground.positions.front();
    if (start_heading_rad) *start_heading_rad = ground.headings_rad.front();
  }
}

void write_synthetic_source(const std::string& dir, int takes_per_label, int num_frames, std::uint64_t seed) {
  if (takes_per_label < 1 || num_frames < 3) throw Error("write_synthetic_source: need at least 1 take and 3 frames");
  const std::vector<std::string> contents = {"walk", "walk-turn-left", "walk-turn-right", "run"};
  const std::vector<std::string> styles = {"normal", "brisk"};
  const fs::path root(dir);
  std::error_code ec;
  fs::create_directories(root / "cfg", ec);
  fs::create_directories(root / "data", ec);
  if (ec) throw Error(dir + ": cannot create the directory: " + ec.message());
  std::string content_text, style_text;
  for (const std::string& c : contents) content_text += "dataset-9_" + c + "\n";
  for (const std::string& s : styles) style_text += "dataset-9_" + s + "\n";
  io::write_file_atomically((root / "cfg" / "content_label.txt").string(), content_text);
  io::write_file_atomically((root / "cfg" / "style_label.txt").string(), style_text);

  // Bandai-like skeleton: a static joint_Root above the biped's Hips.
  const Skeleton biped = make_synthetic_biped();
  Skeleton skeleton;
  skeleton.joint_names.push_back("joint_Root");
  skeleton.parents.push_back(-1);
  skeleton.offsets.push_back(Eigen::Vector3d::Zero());
  for (int j = 0; j < biped.num_joints(); ++j) {
    skeleton.joint_names.push_back(biped.joint_names[j]);
    skeleton.parents.push_back(biped.parents[j] + 1);
    skeleton.offsets.push_back(biped.offsets[j]);
  }
  for (const EndSite& e : biped.end_sites) skeleton.end_sites.push_back({e.parent + 1, e.offset});
  skeleton.meters_per_unit = biped.meters_per_unit;
  io::BvhFile layout_template;
  layout_template.skeleton = skeleton;
  const io::BvhChannelLayout six = {io::BvhChannel::kXposition, io::BvhChannel::kYposition, io::BvhChannel::kZposition,
                                    io::BvhChannel::kZrotation, io::BvhChannel::kXrotation, io::BvhChannel::kYrotation};
  layout_template.channels.assign(skeleton.num_joints(), six);

  for (size_t c = 0; c < contents.size(); ++c)
    for (size_t s = 0; s < styles.size(); ++s)
      for (int take = 1; take <= takes_per_label; ++take) {
        SyntheticWalkOptions w;
        const bool run = contents[c] == "run";
        const bool brisk = styles[s] == "brisk";
        w.speed_mps = (run ? 3.0 : 1.2) * (brisk ? 1.25 : 1.0) + 0.05 * take;
        w.cycle_hz = (run ? 1.4 : 0.9) * (brisk ? 1.15 : 1.0);
        w.leg_swing_rad = run ? 0.7 : 0.45;
        w.turn_rate_rad_s = contents[c] == "walk-turn-left" ? 0.6 : contents[c] == "walk-turn-right" ? -0.6 : 0.0;
        w.start_heading_rad = 0.3 * take + static_cast<double>(c);
        w.noise_rad = 0.01;
        w.seed = seed * 1000 + c * 100 + s * 10 + take;
        const Motion walk = make_synthetic_walk(biped, num_frames, 30.0, w);
        Clip clip;
        clip.skeleton = skeleton;
        clip.motion = Motion::rest(skeleton, num_frames, 30.0);
        for (int t = 0; t < num_frames; ++t)
          for (int j = 0; j < biped.num_joints(); ++j) {
            clip.motion.rotation(t, j + 1) = walk.rotation(t, j);
            clip.motion.translation(t, j + 1) = walk.translation(t, j);
          }
        char name[128];
        std::snprintf(name, sizeof(name), "dataset-9_%s_%s_%03d", contents[c].c_str(), styles[s].c_str(), take);
        io::write_bvh((root / "data" / (std::string(name) + ".bvh")).string(), io::from_clip(clip, &layout_template));
        io::write_json((root / "data" / (std::string(name) + ".json")).string(),
                       nlohmann::json{{"content", static_cast<int>(c)}, {"style", static_cast<int>(s)}});
      }
}

}  // namespace mosyn::data
