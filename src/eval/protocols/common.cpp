#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "data/control.h"
#include "data/prepare.h"
#include "io/json_number.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval::detail {

namespace {

// The long-horizon meander (long_horizon_control).
constexpr double kSpeedMps = 1.3;      // walking speed along it
constexpr double kAmplitudeM = 2.0;    // lateral amplitude
constexpr double kWavelengthM = 16.0;  // wavelength

}  // namespace

double mean_finite(const std::vector<double>& values) {
  double sum = 0;
  int n = 0;
  for (double v : values)
    if (std::isfinite(v)) {
      sum += v;
      ++n;
    }
  return n > 0 ? sum / n : kNaN;
}

std::vector<float> rows_of(const std::vector<float>& a, int from, int to, int dim) {
  return std::vector<float>(a.begin() + static_cast<size_t>(from) * dim, a.begin() + static_cast<size_t>(to) * dim);
}

Eigen::MatrixXd to_matrix(const std::vector<float>& v, int rows, int cols) {
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = v[static_cast<size_t>(r) * cols + c];
  return m;
}

Eigen::MatrixXd root_relative(const Eigen::MatrixXd& sequence) {
  Eigen::MatrixXd out = sequence;
  for (Eigen::Index j = 0; j + 2 < out.cols(); j += 3) out.middleCols(j, 3) -= sequence.leftCols(3);
  return out;
}

MotionPositions slice(const MotionPositions& m, int from, int to) {
  MotionPositions out;  // the skeleton fields copied, the frames only once: [from, to)
  out.name = m.name;
  out.fps = m.fps;
  out.num_joints = m.num_joints;
  out.up_axis = m.up_axis;
  out.joint_names = m.joint_names;
  out.parents = m.parents;
  out.bone_lengths_m = m.bone_lengths_m;
  out.num_frames = to - from;
  out.positions_m.assign(m.positions_m.begin() + static_cast<size_t>(from) * m.num_joints,
                         m.positions_m.begin() + static_cast<size_t>(to) * m.num_joints);
  return out;
}

double body_speed_mps(const MotionPositions& m) {
  if (m.num_frames < 2 || m.num_joints < 2) return kNaN;
  double sum = 0;
  for (int t = 1; t < m.num_frames; ++t)
    for (int j = 1; j < m.num_joints; ++j)
      sum += ((m.position(t, j) - m.position(t, 0)) - (m.position(t - 1, j) - m.position(t - 1, 0))).norm();
  return sum * m.fps / ((m.num_frames - 1.0) * (m.num_joints - 1.0));
}

double largest_extent_m(const MotionPositions& m) {
  double extent = 0;
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < m.num_joints; ++j) {
      const Eigen::Vector3d d = m.position(t, j) - m.position(t, 0);
      if (!d.allFinite() || !m.position(t, 0).allFinite()) return std::numeric_limits<double>::infinity();
      extent = std::max(extent, d.norm());
    }
  return extent;
}

std::vector<float> long_horizon_control(const nn::LoadedRun& run, double seconds) {
  const int c = run.context.control_dim;
  const int frames = static_cast<int>(std::lround(seconds * run.dataset.fps));
  if (run.traits.control != nn::InputUse::kTakes) return std::vector<float>(static_cast<size_t>(frames) * c, 0.0f);
  std::vector<data::Waypoint> path;
  const double length = kSpeedMps * seconds + 10.0;
  for (double z = 0; z <= length; z += 1.0)
    path.push_back({kAmplitudeM * std::sin(2 * M_PI * z / kWavelengthM), z, 0.0});
  data::PathOptions po;
  po.speed_mps = kSpeedMps;
  po.fps = run.dataset.fps;
  po.seconds = seconds;
  std::vector<float> control =
      data::smooth_control(data::control_from_path(path, po), po.fps, run.dataset.layout.root_smoothing_s);
  control.resize(static_cast<size_t>(frames) * c, 0.0f);  // exactly `seconds` long
  return control;
}

nn::LoadedRun load_classifier(const EvalOptions& o) {
  nn::LoadOptions lo;
  lo.threads = o.threads;
  if (std::filesystem::exists(std::filesystem::path(o.classifier_dir) / "best.pt")) lo.checkpoint = "best.pt";
  nn::LoadedRun cls = nn::load_run(o.classifier_dir, lo);
  if (cls.kind != nn::FamilyKind::kClassifier || !cls.trainable)
    throw Error(o.classifier_dir + ": not a classifier run (family '" + cls.family + "')");
  return cls;
}

int training_window(const nn::LoadedRun& run) {
  const auto& train = run.config.contains("train") ? run.config["train"] : nlohmann::json::object();
  const int window = train.contains("window") ? io::json_get<int>(train["window"]) : 0;
  return window > 0 ? window : run.dataset.window_frames;
}

ClassifierInputs::ClassifierInputs(const nn::LoadedRun& classifier, const data::DatasetInfo& info)
    : classifier_(classifier),
      info_(info),
      same_features_(data::layout_to_json(classifier.dataset.layout) == data::layout_to_json(info.layout)),
      window_(training_window(classifier)) {}

void ClassifierInputs::to_classifier_features(const std::vector<float>& pose, const std::vector<float>& control,
                                              const std::string& name, std::vector<float>* p,
                                              std::vector<float>* c) const {
  if (same_features_) {
    *p = pose;
    *c = control;
    return;
  }
  const int frames = static_cast<int>(control.size()) / info_.layout.control_dim;
  data::encode_clip_for_dataset(classifier_.dataset, data::decode_features(info_, pose.data(), control.data(), frames),
                                name, p, c);
}

void ClassifierInputs::push(std::vector<float> p, std::vector<float> c, int content_id, int style_id) {
  poses.push_back(std::move(p));
  controls.push_back(std::move(c));
  content.push_back(content_id);
  style.push_back(style_id);
}

void ClassifierInputs::add(const std::vector<float>& pose, const std::vector<float>& control, const std::string& name,
                           int content_id, int style_id) {
  std::vector<float> p, c;
  to_classifier_features(pose, control, name, &p, &c);
  push(std::move(p), std::move(c), content_id, style_id);
}

int ClassifierInputs::add_in_windows(const std::vector<float>& pose, const std::vector<float>& control,
                                     const std::string& name, int content_id, int style_id) {
  std::vector<float> p, c;
  to_classifier_features(pose, control, name, &p, &c);
  const int d = classifier_.context.pose_dim, cd = classifier_.context.control_dim;
  const int frames = static_cast<int>(p.size()) / d;
  if (window_ <= 0 || frames <= window_) {
    push(std::move(p), std::move(c), content_id, style_id);
    return 1;
  }
  const int hop = std::max(1, window_ / 2);  // as the trainer's validation windows
  std::vector<int> starts;
  for (int from = 0; from + window_ <= frames; from += hop) starts.push_back(from);
  if (starts.back() + window_ < frames) starts.push_back(frames - window_);
  for (int from : starts)
    push(rows_of(p, from, from + window_, d), c.empty() ? std::vector<float>{} : rows_of(c, from, from + window_, cd),
         content_id, style_id);
  return static_cast<int>(starts.size());
}

nn::ClassifierOutputs ClassifierInputs::classify() const { return nn::classify_windows(classifier_, poses, controls); }

int arg_max(const std::vector<float>& probabilities, int k, int row) {
  const float* p = probabilities.data() + static_cast<size_t>(row) * k;
  return static_cast<int>(std::max_element(p, p + k) - p);
}

double recognised_percent(const std::vector<float>& probabilities, int k, const std::vector<int>& labels) {
  int right = 0, total = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] < 0) continue;
    right += arg_max(probabilities, k, static_cast<int>(i)) == labels[i];
    ++total;
  }
  return total > 0 ? 100.0 * right / total : kNaN;
}

double fid_or_nan(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() >= 2 && b.rows() >= 2 ? frechet_inception_distance(a, b) : kNaN;
}

double split_half_fid(const Eigen::MatrixXd& fr) {
  if (fr.rows() < 4) return kNaN;
  Eigen::MatrixXd even((fr.rows() + 1) / 2, fr.cols()), odd(fr.rows() / 2, fr.cols());
  for (Eigen::Index r = 0; r < fr.rows(); ++r) {
    if (r % 2 == 0)
      even.row(r / 2) = fr.row(r);
    else
      odd.row(r / 2) = fr.row(r);
  }
  return frechet_inception_distance(even, odd);
}

nn::SampleExtras walk_extras(const nn::LoadedRun& run, int warmup_frames) {
  nn::SampleExtras extras;
  extras.warmup_frames = warmup_frames;
  const int walk = label_index(run.dataset.content_labels, "walk");
  if (run.traits.labels && walk >= 0) extras.content = walk;
  return extras;
}

int label_index(const std::vector<std::string>& labels, const std::string& name) {
  const auto it = std::find(labels.begin(), labels.end(), name);
  return it == labels.end() ? -1 : static_cast<int>(it - labels.begin());
}

bool is_gait_row(const std::string& key) {
  return key.rfind("footsteps.", 0) == 0 || key == "foot_skating_ratio" || key == "toe_slide_ratio" ||
         key == "pelvis_ground_speed_mps";
}

}  // namespace mosyn::eval::detail
