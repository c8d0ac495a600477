#include "data/dataset.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/json_file.h"
#include "io/json_number.h"

namespace mosyn::data {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr char kMagic[8] = {'M', 'O', 'S', 'Y', 'N', 'C', 'L', 'P'};
constexpr char kEnd[8] = {'M', 'O', 'S', 'Y', 'N', 'E', 'N', 'D'};
constexpr uint32_t kCacheVersion = 1;
constexpr int kInfoVersion = 1;

bool little_endian() {
  const uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

uint64_t fnv1a(const char* data, size_t n) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

template <typename T>
void put(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

// Bounds-checked reader over cache bytes.
class Reader {
 public:
  Reader(const std::string& bytes, size_t end, const std::string& file) : bytes_(bytes), end_(end), file_(file) {}
  template <typename T>
  T get(const char* what) {
    need(sizeof(T), what);
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string get_string(size_t n, const char* what) {
    need(n, what);
    std::string s = bytes_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  void get_floats(std::vector<float>* out, uint64_t count, const char* what) {
    if (count > (end_ - pos_) / sizeof(float)) need(end_ - pos_ + 1, what);
    out->resize(static_cast<size_t>(count));
    if (count == 0) return;  // an empty vector's data() may be null, which memcpy must not get
    std::memcpy(out->data(), bytes_.data() + pos_, static_cast<size_t>(count) * sizeof(float));
    pos_ += static_cast<size_t>(count) * sizeof(float);
  }
  size_t pos() const { return pos_; }

 private:
  void need(size_t n, const char* what) const {
    if (n > end_ - pos_)
      throw ParseError(file_, 0, std::string("truncated cache: ") + what + " runs past the end of the clip data");
  }
  const std::string& bytes_;
  size_t end_;
  size_t pos_ = 0;
  const std::string& file_;
};

template <typename T>
T get_key(const json& j, const char* key, const std::string& file) {
  if (!j.is_object() || !j.contains(key)) throw ParseError(file, 0, std::string("missing key \"") + key + "\"");
  try {
    return io::json_get<T>(j.at(key));
  } catch (const json::exception& e) {
    throw ParseError(file, 0, std::string("key \"") + key + "\" has the wrong type: " + e.what());
  }
}

// get_key when the key is present, else the fallback.
template <typename T>
T optional_key(const json& j, const char* key, T fallback, const std::string& file) {
  return j.is_object() && j.contains(key) ? get_key<T>(j, key, file) : fallback;
}

json vec3(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

Eigen::Vector3d vec3_from(const json& j, const std::string& file, const char* what) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    throw ParseError(file, 0, std::string(what) + " must be an array of 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

void check_record(const ClipRecord& c, int pose_dim, int control_dim) {
  if (c.num_frames < 0 || c.pose.size() != static_cast<size_t>(c.num_frames) * pose_dim ||
      c.control.size() != static_cast<size_t>(c.num_frames) * control_dim)
    throw Error("clip '" + c.source + "': feature arrays do not hold " + std::to_string(c.num_frames) + " frames of " +
                std::to_string(pose_dim) + " + " + std::to_string(control_dim) + " values");
}

// Throws ParseError naming the file, clip, frame and dimension of the first NaN or infinity.
void check_finite(const ClipRecord& c, uint32_t index, int pose_dim, int control_dim, const std::string& file) {
  for (const bool pose : {true, false}) {
    const std::vector<float>& v = pose ? c.pose : c.control;
    const int dim = pose ? pose_dim : control_dim;
    for (size_t i = 0; i < v.size(); ++i)
      if (!std::isfinite(v[i]))
        throw ParseError(file, 0, "clip " + std::to_string(index) + " ('" + c.source + "') holds a non-finite " +
                                      (pose ? "pose" : "control") + " value at frame " + std::to_string(i / dim) +
                                      ", dimension " + std::to_string(i % dim));
  }
}

std::vector<float> floats_from(const json& j, const char* key, size_t expected, const std::string& file) {
  const std::vector<float> v = get_key<std::vector<float>>(j, key, file);
  if (v.size() != expected)
    throw ParseError(file, 0,
                     std::string(key) + " has " + std::to_string(v.size()) + " entries, expected " + std::to_string(expected));
  for (float x : v)
    if (!std::isfinite(x)) throw ParseError(file, 0, std::string(key) + " holds a non-finite value");
  return v;
}

}  // namespace

// ---- JSON ----

json skeleton_to_json(const Skeleton& s) {
  json j;
  j["joint_names"] = s.joint_names;
  j["parents"] = s.parents;
  json offsets = json::array();
  for (const Eigen::Vector3d& o : s.offsets) offsets.push_back(vec3(o));
  j["offsets"] = offsets;
  json sites = json::array();
  for (const EndSite& e : s.end_sites) sites.push_back({{"parent", e.parent}, {"offset", vec3(e.offset)}});
  j["end_sites"] = sites;
  j["meters_per_unit"] = s.meters_per_unit;
  j["up_axis"] = s.up_axis;
  return j;
}

Skeleton skeleton_from_json(const json& j, const std::string& file) {
  Skeleton s;
  s.joint_names = get_key<std::vector<std::string>>(j, "joint_names", file);
  s.parents = get_key<std::vector<int>>(j, "parents", file);
  const json offsets = get_key<json>(j, "offsets", file);
  if (!offsets.is_array()) throw ParseError(file, 0, "skeleton offsets must be an array");
  for (const json& o : offsets) s.offsets.push_back(vec3_from(o, file, "a skeleton offset"));
  if (j.contains("end_sites")) {
    for (const json& e : j["end_sites"])
      s.end_sites.push_back({get_key<int>(e, "parent", file), vec3_from(get_key<json>(e, "offset", file), file, "an end-site offset")});
  }
  s.meters_per_unit = get_key<double>(j, "meters_per_unit", file);
  s.up_axis = get_key<int>(j, "up_axis", file);
  try {
    s.validate();
  } catch (const Error& e) {
    throw ParseError(file, 0, e.what());
  }
  return s;
}

json layout_to_json(const FeatureLayout& l) {
  return {{"form", to_string(l.form)},        {"root_joint", l.root_joint},
          {"forward_in_root", vec3(l.forward_in_root)}, {"pose_dim", l.pose_dim},
          {"control_dim", l.control_dim},     {"pose_names", l.pose_names},
          {"control_names", l.control_names}, {"root_smoothing_s", l.root_smoothing_s}};
}

FeatureLayout layout_from_json(const json& j, const std::string& file) {
  FeatureLayout l;
  try {
    l.form = parse_pose_form(get_key<std::string>(j, "form", file));
  } catch (const ParseError&) {
    throw;
  } catch (const Error& e) {
    throw ParseError(file, 0, e.what());
  }
  l.root_joint = get_key<int>(j, "root_joint", file);
  l.forward_in_root = vec3_from(get_key<json>(j, "forward_in_root", file), file, "forward_in_root");
  l.pose_dim = get_key<int>(j, "pose_dim", file);
  l.control_dim = get_key<int>(j, "control_dim", file);
  l.pose_names = get_key<std::vector<std::string>>(j, "pose_names", file);
  l.control_names = get_key<std::vector<std::string>>(j, "control_names", file);
  // Absent in datasets made before the smoothed control: the raw hip trajectory.
  l.root_smoothing_s = j.contains("root_smoothing_s") ? get_key<double>(j, "root_smoothing_s", file) : 0.0;
  if (!(l.root_smoothing_s >= 0 && l.root_smoothing_s <= 10))
    throw ParseError(file, 0, "layout root_smoothing_s must be between 0 and 10 seconds");
  if (static_cast<int>(l.pose_names.size()) != l.pose_dim || static_cast<int>(l.control_names.size()) != l.control_dim)
    throw ParseError(file, 0, "layout names do not match pose_dim / control_dim");
  return l;
}

json info_to_json(const DatasetInfo& info) {
  json j;
  j["version"] = info.version;
  j["fps"] = info.fps;
  j["skeleton"] = skeleton_to_json(info.skeleton);
  j["layout"] = layout_to_json(info.layout);
  j["window_frames"] = info.window_frames;
  j["window_hop"] = info.window_hop;
  j["content_labels"] = info.content_labels;
  j["style_labels"] = info.style_labels;
  j["train_files"] = info.train_files;
  j["val_files"] = info.val_files;
  j["source_dir"] = info.source_dir;
  j["source_dirs"] = info.source_dirs;
  j["source_layout"] = info.source_layout;
  j["augmentation"] = {{"mirror", info.augment_mirror}, {"reverse", info.augment_reverse}};
  if (!info.augment_retime.empty()) j["augmentation"]["retime"] = info.augment_retime;
  if (info.augment_retime_min_speed_mps > 0)
    j["augmentation"]["retime_min_speed_mps"] = info.augment_retime_min_speed_mps;
  if (info.augment_retime_max_speed_mps > 0)
    j["augmentation"]["retime_max_speed_mps"] = info.augment_retime_max_speed_mps;
  if (info.augment_rest_hold_s > 0) {
    j["augmentation"]["rest_hold_s"] = info.augment_rest_hold_s;
    j["augmentation"]["rest_ramp_s"] = info.augment_rest_ramp_s;
    if (info.augment_rest_fraction < 1) j["augmentation"]["rest_fraction"] = info.augment_rest_fraction;
  }
  if (!info.stats_from.empty()) j["stats_from"] = info.stats_from;
  if (!info.split_from.empty()) j["split_from"] = info.split_from;
  j["tpose"] = info.tpose;
  j["drop_joint_patterns"] = info.drop_joint_patterns;
  j["keep_joint_patterns"] = info.keep_joint_patterns;
  j["source_joint_names"] = info.source_joint_names;
  if (info.max_train_seconds > 0) j["max_train_seconds"] = info.max_train_seconds;
  return j;
}

DatasetInfo info_from_json(const json& j, const std::string& file) {
  if (!j.is_object()) throw ParseError(file, 0, "expected a JSON object");
  DatasetInfo info;
  info.version = get_key<int>(j, "version", file);
  if (info.version != kInfoVersion)
    throw ParseError(file, 0, "dataset version " + std::to_string(info.version) + " is not supported (expected " +
                                  std::to_string(kInfoVersion) + "); prepare the dataset again");
  info.fps = get_key<double>(j, "fps", file);
  if (!(info.fps > 0)) throw ParseError(file, 0, "fps must be positive");
  info.skeleton = skeleton_from_json(get_key<json>(j, "skeleton", file), file);
  info.layout = layout_from_json(get_key<json>(j, "layout", file), file);
  try {
    const FeatureLayout expected =
        make_layout(info.skeleton, info.layout.form, info.layout.root_joint, info.layout.forward_in_root,
                    info.layout.root_smoothing_s);
    if (expected.pose_dim != info.layout.pose_dim || expected.control_dim != info.layout.control_dim)
      throw Error("layout dims (" + std::to_string(info.layout.pose_dim) + ", " + std::to_string(info.layout.control_dim) +
                  ") do not match the skeleton (" + std::to_string(expected.pose_dim) + ", " +
                  std::to_string(expected.control_dim) + ")");
  } catch (const ParseError&) {
    throw;
  } catch (const Error& e) {
    throw ParseError(file, 0, e.what());
  }
  info.window_frames = get_key<int>(j, "window_frames", file);
  info.window_hop = get_key<int>(j, "window_hop", file);
  if (info.window_frames <= 0 || info.window_hop <= 0)
    throw ParseError(file, 0, "window_frames and window_hop must be positive");
  info.content_labels = get_key<std::vector<std::string>>(j, "content_labels", file);
  info.style_labels = get_key<std::vector<std::string>>(j, "style_labels", file);
  info.train_files = get_key<std::vector<std::string>>(j, "train_files", file);
  info.val_files = get_key<std::vector<std::string>>(j, "val_files", file);
  info.source_dir = get_key<std::string>(j, "source_dir", file);
  // Keys added after version 1: optional, with the old behaviour as their default.
  info.source_dirs = optional_key(j, "source_dirs", std::vector<std::string>{info.source_dir}, file);
  info.source_layout = optional_key(j, "source_layout", std::string(), file);
  if (j.contains("augmentation")) {
    const json& a = j.at("augmentation");
    if (!a.is_object()) throw ParseError(file, 0, "key \"augmentation\" must be an object");
    info.augment_mirror = optional_key(a, "mirror", false, file);
    info.augment_reverse = optional_key(a, "reverse", false, file);
    info.augment_retime = optional_key(a, "retime", std::vector<double>{}, file);
    for (double f : info.augment_retime)
      if (!(f > 0) || !std::isfinite(f)) throw ParseError(file, 0, "augmentation.retime factors must be positive");
    info.augment_retime_min_speed_mps = optional_key(a, "retime_min_speed_mps", 0.0, file);
    info.augment_retime_max_speed_mps = optional_key(a, "retime_max_speed_mps", 0.0, file);
    for (double v : {info.augment_retime_min_speed_mps, info.augment_retime_max_speed_mps})
      if (!(v >= 0) || !std::isfinite(v))
        throw ParseError(file, 0, "augmentation.retime_min_speed_mps / retime_max_speed_mps must be 0 or positive");
    info.augment_rest_hold_s = optional_key(a, "rest_hold_s", 0.0, file);
    info.augment_rest_ramp_s = optional_key(a, "rest_ramp_s", 0.0, file);
    for (double v : {info.augment_rest_hold_s, info.augment_rest_ramp_s})
      if (!(v >= 0) || !std::isfinite(v))
        throw ParseError(file, 0, "augmentation.rest_hold_s / rest_ramp_s must be 0 or positive seconds");
    info.augment_rest_fraction = optional_key(a, "rest_fraction", 1.0, file);
    if (!(info.augment_rest_fraction > 0 && info.augment_rest_fraction <= 1))
      throw ParseError(file, 0, "augmentation.rest_fraction must lie in (0, 1]");
  }
  info.tpose = optional_key(j, "tpose", std::string("auto"), file);
  info.stats_from = optional_key(j, "stats_from", std::string(), file);
  info.split_from = optional_key(j, "split_from", std::string(), file);
  info.drop_joint_patterns = optional_key(j, "drop_joint_patterns", std::vector<std::string>{}, file);
  info.keep_joint_patterns = optional_key(j, "keep_joint_patterns", std::vector<std::string>{}, file);
  info.max_train_seconds = optional_key(j, "max_train_seconds", 0.0, file);
  if (!(info.max_train_seconds >= 0)) throw ParseError(file, 0, "max_train_seconds must not be negative");
  info.source_joint_names = optional_key(j, "source_joint_names", std::vector<std::string>{}, file);
  return info;
}

json stats_to_json(const DatasetStats& s) {
  return {{"pose_mean", s.pose_mean},
          {"pose_std", s.pose_std},
          {"control_mean", s.control_mean},
          {"control_std", s.control_std},
          {"pose_constant", s.pose_constant},
          {"std_floor", kStdFloor}};
}

DatasetStats stats_from_json(const json& j, const std::string& file) {
  DatasetStats s;
  const size_t pose_dim = get_key<std::vector<float>>(j, "pose_mean", file).size();
  const size_t control_dim = get_key<std::vector<float>>(j, "control_mean", file).size();
  s.pose_mean = floats_from(j, "pose_mean", pose_dim, file);
  s.pose_std = floats_from(j, "pose_std", pose_dim, file);
  s.control_mean = floats_from(j, "control_mean", control_dim, file);
  s.control_std = floats_from(j, "control_std", control_dim, file);
  for (float x : s.pose_std)
    if (!(x > 0)) throw ParseError(file, 0, "pose_std must be positive");
  for (float x : s.control_std)
    if (!(x > 0)) throw ParseError(file, 0, "control_std must be positive");
  if (j.contains("pose_constant")) {  // absent before near-constant dimensions were recorded
    s.pose_constant = get_key<std::vector<int>>(j, "pose_constant", file);
    for (size_t i = 0; i < s.pose_constant.size(); ++i)
      if (s.pose_constant[i] < 0 || static_cast<size_t>(s.pose_constant[i]) >= pose_dim ||
          (i > 0 && s.pose_constant[i] <= s.pose_constant[i - 1]))
        throw ParseError(file, 0, "pose_constant must list pose dimensions below " + std::to_string(pose_dim) +
                                      " in increasing order");
  }
  return s;
}

// ---- Cache ----

std::string format_clip_cache(const std::vector<ClipRecord>& clips, int pose_dim, int control_dim) {
  if (!little_endian()) throw Error("dataset caches are little-endian; this machine is not");
  uint64_t total_frames = 0;
  for (const ClipRecord& c : clips) {
    check_record(c, pose_dim, control_dim);
    total_frames += static_cast<uint64_t>(c.num_frames);
  }
  std::string out;
  out.append(kMagic, 8);
  put<uint32_t>(&out, kCacheVersion);
  put<uint32_t>(&out, static_cast<uint32_t>(pose_dim));
  put<uint32_t>(&out, static_cast<uint32_t>(control_dim));
  put<uint32_t>(&out, static_cast<uint32_t>(clips.size()));
  put<uint64_t>(&out, total_frames);
  for (const ClipRecord& c : clips) {
    put<uint32_t>(&out, static_cast<uint32_t>(c.source.size()));
    out += c.source;
    put<int32_t>(&out, c.content);
    put<int32_t>(&out, c.style);
    put<uint8_t>(&out, static_cast<uint8_t>((c.mirrored ? 1 : 0) | (c.reversed ? 2 : 0) | (c.retimed ? 4 : 0) | (c.at_rest ? 8 : 0)));
    put<uint32_t>(&out, static_cast<uint32_t>(c.num_frames));
    out.append(reinterpret_cast<const char*>(c.pose.data()), c.pose.size() * sizeof(float));
    out.append(reinterpret_cast<const char*>(c.control.data()), c.control.size() * sizeof(float));
  }
  put<uint64_t>(&out, fnv1a(out.data(), out.size()));
  out.append(kEnd, 8);
  return out;
}

std::vector<ClipRecord> parse_clip_cache(const std::string& bytes, int pose_dim, int control_dim, const std::string& file) {
  if (!little_endian()) throw Error("dataset caches are little-endian; this machine is not");
  constexpr size_t kHeader = 8 + 4 * 4 + 8, kTrailer = 8 + 8;
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    throw ParseError(file, 0, "not a mosyn clip cache (bad magic)");
  if (bytes.size() < kHeader + kTrailer)
    throw ParseError(file, 0, "truncated cache (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data() + bytes.size() - 8, kEnd, 8) != 0)
    throw ParseError(file, 0, "truncated or extended cache: end marker missing");
  const size_t data_end = bytes.size() - kTrailer;
  uint64_t stored_hash;
  std::memcpy(&stored_hash, bytes.data() + data_end, 8);
  Reader r(bytes, data_end, file);
  r.get_string(8, "magic");
  const uint32_t version = r.get<uint32_t>("version");
  if (version != kCacheVersion)
    throw ParseError(file, 0, "cache version " + std::to_string(version) + " is not supported (expected " +
                                  std::to_string(kCacheVersion) + ")");
  const uint32_t file_pose_dim = r.get<uint32_t>("pose_dim"), file_control_dim = r.get<uint32_t>("control_dim");
  if (static_cast<int>(file_pose_dim) != pose_dim || static_cast<int>(file_control_dim) != control_dim)
    throw ParseError(file, 0, "cache holds features of dims (" + std::to_string(file_pose_dim) + ", " +
                                  std::to_string(file_control_dim) + ") but dataset.json says (" +
                                  std::to_string(pose_dim) + ", " + std::to_string(control_dim) + ")");
  if (fnv1a(bytes.data(), data_end) != stored_hash) throw ParseError(file, 0, "cache is corrupted (hash mismatch)");
  const uint32_t num_clips = r.get<uint32_t>("clip count");
  const uint64_t total_frames = r.get<uint64_t>("frame count");
  std::vector<ClipRecord> clips;
  uint64_t frames = 0;
  for (uint32_t i = 0; i < num_clips; ++i) {
    ClipRecord c;
    const uint32_t n = r.get<uint32_t>("source length");
    c.source = r.get_string(n, "source name");
    c.content = r.get<int32_t>("content");
    c.style = r.get<int32_t>("style");
    const uint8_t flags = r.get<uint8_t>("flags");
    c.mirrored = flags & 1;
    c.reversed = flags & 2;
    c.retimed = flags & 4;
    c.at_rest = flags & 8;
    c.num_frames = static_cast<int>(r.get<uint32_t>("frame count"));
    if (c.num_frames < 0) throw ParseError(file, 0, "clip " + std::to_string(i) + " has a bad frame count");
    r.get_floats(&c.pose, static_cast<uint64_t>(c.num_frames) * pose_dim, "pose data");
    r.get_floats(&c.control, static_cast<uint64_t>(c.num_frames) * control_dim, "control data");
    check_finite(c, i, pose_dim, control_dim, file);
    frames += static_cast<uint64_t>(c.num_frames);
    clips.push_back(std::move(c));
  }
  if (r.pos() != data_end) throw ParseError(file, 0, "cache has unexpected bytes after its last clip");
  if (frames != total_frames) throw ParseError(file, 0, "cache frame count disagrees with its clips");
  return clips;
}

DatasetStats compute_stats(const std::vector<ClipRecord>& clips, int pose_dim, int control_dim) {
  std::vector<int> constant;  // near-constant pose dimensions
  auto stats = [&](bool pose, int dim, std::vector<float>* mean_out, std::vector<float>* std_out) {
    std::vector<double> sum(dim, 0.0), sum_sq(dim, 0.0);
    double count = 0;
    // Two passes (mean, then squared deviations) for accuracy.
    for (const ClipRecord& c : clips) {
      const std::vector<float>& v = pose ? c.pose : c.control;
      for (int t = 0; t < c.num_frames; ++t)
        for (int k = 0; k < dim; ++k) sum[k] += v[static_cast<size_t>(t) * dim + k];
      count += c.num_frames;
    }
    mean_out->assign(dim, 0.0f);
    std_out->assign(dim, 1.0f);
    if (count == 0) return;
    std::vector<double> mean(dim);
    for (int k = 0; k < dim; ++k) mean[k] = sum[k] / count;
    for (const ClipRecord& c : clips) {
      const std::vector<float>& v = pose ? c.pose : c.control;
      for (int t = 0; t < c.num_frames; ++t)
        for (int k = 0; k < dim; ++k) {
          const double d = v[static_cast<size_t>(t) * dim + k] - mean[k];
          sum_sq[k] += d * d;
        }
    }
    for (int k = 0; k < dim; ++k) {
      const double sample_std = std::sqrt(sum_sq[k] / count);
      (*mean_out)[k] = static_cast<float>(mean[k]);
      (*std_out)[k] = std::max(static_cast<float>(sample_std), kStdFloor);
      if (pose && sample_std < kStdFloor) constant.push_back(k);
    }
  };
  DatasetStats s;
  stats(true, pose_dim, &s.pose_mean, &s.pose_std);
  stats(false, control_dim, &s.control_mean, &s.control_std);
  s.pose_constant = std::move(constant);
  return s;
}

void write_dataset(const std::string& dir, const DatasetInfo& info, const DatasetStats& stats,
                   const std::vector<ClipRecord>& train, const std::vector<ClipRecord>& val, bool overwrite) {
  const fs::path root(dir);
  if (fs::exists(root / "dataset.json") && !overwrite)
    throw Error(dir + ": already holds a dataset (dataset.json); pass overwrite to replace it");
  std::error_code ec;
  fs::create_directories(root, ec);
  if (ec) throw Error(dir + ": cannot create the directory: " + ec.message());
  const int pose_dim = info.layout.pose_dim, control_dim = info.layout.control_dim;
  {
    io::AtomicFileWriter out((root / "train.bin").string());
    out.write(format_clip_cache(train, pose_dim, control_dim));
    out.commit();
  }
  {
    io::AtomicFileWriter out((root / "val.bin").string());
    out.write(format_clip_cache(val, pose_dim, control_dim));
    out.commit();
  }
  io::write_json((root / "stats.json").string(), stats_to_json(stats));
  io::write_json((root / "dataset.json").string(), info_to_json(info));  // last: marks completion
}

// ---- Dataset ----

Dataset Dataset::open(const std::string& dir) {
  const fs::path root(dir);
  if (!fs::is_directory(root)) throw Error(dir + ": dataset directory not found (make one from BVH files with `mosyn data prepare`)");
  const std::string info_path = (root / "dataset.json").string();
  const std::string stats_path = (root / "stats.json").string();
  for (const std::string& p : {info_path, stats_path, (root / "train.bin").string(), (root / "val.bin").string()})
    if (!fs::is_regular_file(p)) throw Error(p + ": missing (prepare the dataset with `mosyn data prepare`)");
  Dataset d;
  d.info_ = info_from_json(io::read_json(info_path), info_path);
  d.stats_ = stats_from_json(io::read_json(stats_path), stats_path);
  const int pose_dim = d.info_.layout.pose_dim, control_dim = d.info_.layout.control_dim;
  if (static_cast<int>(d.stats_.pose_mean.size()) != pose_dim ||
      static_cast<int>(d.stats_.control_mean.size()) != control_dim)
    throw ParseError(stats_path, 0, "statistics have dims (" + std::to_string(d.stats_.pose_mean.size()) + ", " +
                                        std::to_string(d.stats_.control_mean.size()) + ") but dataset.json says (" +
                                        std::to_string(pose_dim) + ", " + std::to_string(control_dim) + ")");
  for (const char* split : {"train", "val"}) {
    const std::string path = (root / (std::string(split) + ".bin")).string();
    std::vector<ClipRecord> clips = parse_clip_cache(io::read_file(path), pose_dim, control_dim, path);
    for (const ClipRecord& c : clips) {
      if (c.content < -1 || c.content >= static_cast<int>(d.info_.content_labels.size()) || c.style < -1 ||
          c.style >= static_cast<int>(d.info_.style_labels.size()))
        throw ParseError(path, 0, "clip '" + c.source + "' has a label id outside dataset.json's vocabulary");
    }
    (std::string(split) == "train" ? d.train_ : d.val_) = std::move(clips);
  }
  return d;
}

const std::vector<ClipRecord>& Dataset::clips(const std::string& split) const {
  if (split == "train") return train_;
  if (split == "val") return val_;
  throw Error("unknown dataset split '" + split + "' (expected train or val)");
}

std::vector<WindowRef> Dataset::windows(const std::string& split, int window_frames, int hop,
                                        int min_short_frames) const {
  const std::vector<ClipRecord>& list = clips(split);
  if (window_frames == 0) window_frames = info_.window_frames;
  if (hop == 0) hop = info_.window_hop;
  if (window_frames <= 0 || hop <= 0) throw Error("windows: window length and hop must be positive");
  std::vector<WindowRef> out;
  for (int c = 0; c < static_cast<int>(list.size()); ++c) {
    const int frames = list[c].num_frames;
    if (frames < window_frames && min_short_frames > 0 && frames >= min_short_frames) out.push_back({c, 0, frames});
    for (int start = 0; start + window_frames <= frames; start += hop) out.push_back({c, start});
  }
  return out;
}

// ---- Back to motion ----

Clip decode_features(const DatasetInfo& info, const float* pose, const float* control, int num_frames,
                     const Eigen::Vector3d& start_position, double start_heading_rad) {
  Clip clip;
  clip.skeleton = info.skeleton;
  clip.motion = decode(info.skeleton, info.layout, pose, control, num_frames, info.fps, start_position, start_heading_rad);
  return clip;
}

Clip decode_record(const DatasetInfo& info, const ClipRecord& record) {
  check_record(record, info.layout.pose_dim, info.layout.control_dim);
  return decode_features(info, record.pose.data(), record.control.data(), record.num_frames);
}

namespace {
std::string format_seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g s", s);
  return buf;
}
std::string format_speed(double mps) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g m/s", mps);
  return buf;
}
}  // namespace

std::string dataset_summary(const Dataset& dataset) {
  const DatasetInfo& info = dataset.info();
  std::ostringstream out;
  out << std::fixed;
  out << "source:      " << info.source_dir << (info.source_layout.empty() ? "" : " (" + info.source_layout + ")") << "\n";
  out << "fps:         " << std::setprecision(3) << info.fps << "\n";
  out << "skeleton:    " << info.skeleton.num_joints() << " joints, root " << info.skeleton.joint_names[0]
      << ", " << std::setprecision(6) << info.skeleton.meters_per_unit << " m/unit\n";
  out << "features:    " << to_string(info.layout.form) << ", pose " << info.layout.pose_dim << " + control "
      << info.layout.control_dim << "\n";
  if (!dataset.stats().pose_constant.empty())
    out << "constant:    " << dataset.stats().pose_constant.size() << " of " << info.layout.pose_dim
        << " pose dimensions (kept out of the models, restored on decoding)\n";
  out << "control:     "
      << (info.layout.smoothed_root() ? "Gaussian-filtered hip trajectory, sigma " + format_seconds(info.layout.root_smoothing_s)
                                      : std::string("raw hip trajectory"))
      << "\n";
  out << "window:      " << info.window_frames << " frames, hop " << info.window_hop << "\n";
  out << "augment:     mirror " << (info.augment_mirror ? "yes" : "no") << ", reverse "
      << (info.augment_reverse ? "yes" : "no");
  if (!info.augment_retime.empty()) {
    out << ", retimed x";
    for (size_t i = 0; i < info.augment_retime.size(); ++i) {
      char factor[32];
      std::snprintf(factor, sizeof(factor), "%g", info.augment_retime[i]);
      out << (i ? ", x" : "") << factor;
    }
    const double lo = info.augment_retime_min_speed_mps, hi = info.augment_retime_max_speed_mps;
    if (lo > 0 || hi > 0)
      out << " (clips " << (lo > 0 ? "from " + format_speed(lo) : std::string()) << (lo > 0 && hi > 0 ? " " : "")
          << (hi > 0 ? "up to " + format_speed(hi) : std::string()) << ")";
  }
  if (info.augment_rest_hold_s > 0)
    out << ", starts and stops at rest (" << format_seconds(info.augment_rest_ramp_s) << " ramp, "
        << format_seconds(info.augment_rest_hold_s) << " held"
        << (info.augment_rest_fraction < 1
                ? ", " + std::to_string(static_cast<int>(std::lround(100 * info.augment_rest_fraction))) + "% of them"
                : std::string())
        << ")";
  out << "\n";
  if (!info.stats_from.empty()) out << "stats:       from " << info.stats_from << "\n";
  if (!info.split_from.empty()) out << "split:       kept from " << info.split_from << "\n";
  for (const char* split : {"train", "val"}) {
    const std::vector<ClipRecord>& clips = dataset.clips(split);
    long long frames = 0;
    for (const ClipRecord& c : clips) frames += c.num_frames;
    const size_t files = std::string(split) == "train" ? info.train_files.size() : info.val_files.size();
    out << split << ":" << std::string(std::string(split) == "train" ? 7 : 9, ' ') << files << " files, "
        << clips.size() << " clips, " << frames << " frames, " << std::setprecision(2)
        << frames / info.fps / 3600.0 << " h, " << dataset.windows(split).size() << " windows\n";
  }
  auto label_counts = [&](const char* what, const std::vector<std::string>& vocabulary, bool content) {
    if (vocabulary.empty()) return;
    out << what << " (clips train / val):\n";
    for (int k = 0; k < static_cast<int>(vocabulary.size()); ++k) {
      int n_train = 0, n_val = 0;
      for (const ClipRecord& c : dataset.clips("train")) n_train += (content ? c.content : c.style) == k;
      for (const ClipRecord& c : dataset.clips("val")) n_val += (content ? c.content : c.style) == k;
      out << "  " << std::left << std::setw(24) << vocabulary[k] << std::right << std::setw(6) << n_train << " / "
          << n_val << "\n";
    }
  };
  label_counts("contents", info.content_labels, true);
  label_counts("styles", info.style_labels, false);
  return out.str();
}

}  // namespace mosyn::data
