#include "eval/protocol.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "nn/sample_job.h"
#include "core/foot_lock.h"
#include "data/prepare.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

using nn::translate_label;
using detail::rows_of;

Protocol::~Protocol() = default;

EvalContext::EvalContext(const nn::LoadedRun& run, const data::Dataset& dataset, const EvalOptions& options,
                         EvalProgressCallback progress)
    : run_(run), dataset_(dataset), options_(options), progress_(std::move(progress)) {
  const EvalOptions& o = options_;
  if (!run.model) throw Error("evaluate: the run has no model");
  if (o.num_samples < 1) throw Error("evaluate: the number of samples must be >= 1");
  if (o.max_clips < 0) throw Error("evaluate: max_clips must not be negative");
  const data::DatasetInfo& info = dataset.info();
  const int d = run.context.pose_dim, c = run.context.control_dim;
  if (info.layout.pose_dim != d || static_cast<int>(dataset.stats().control_mean.size()) != c ||
      info.skeleton.num_joints() != run.dataset.skeleton.num_joints())
    throw Error("evaluate: the dataset's features (pose_dim " + std::to_string(info.layout.pose_dim) +
                ") do not match the run's (pose_dim " + std::to_string(d) + ")");

  const auto& all = dataset.clips(o.split);
  std::vector<int> candidates;
  for (int i = 0; i < static_cast<int>(all.size()); ++i)
    if (all[i].num_frames >= 2 && (o.include_augmented || !all[i].augmented())) candidates.push_back(i);
  if (candidates.empty()) throw Error("evaluate: the '" + o.split + "' split has no clip to evaluate");
  const size_t n_clips = o.max_clips > 0 ? std::min<size_t>(o.max_clips, candidates.size()) : candidates.size();
  for (size_t i = 0; i < n_clips; ++i) chosen_.push_back(candidates[i * candidates.size() / n_clips]);

  warmup_frames_ = nn::warmup_frames(run, o.warmup_s);
  for (int i : chosen_) real_.push_back(motion_positions(data::decode_record(info, all[i]), 0.0, all[i].source));
}

const data::ClipRecord& EvalContext::clip(size_t i) const { return dataset_.clips(options_.split)[chosen_.at(i)]; }

void EvalContext::report(const std::string& stage, int done, int total) const {
  if (progress_) progress_(EvalProgress{stage, done, total});
}

const std::vector<MetricValue>& EvalContext::real_set_metrics() {
  if (!real_rows_) real_rows_ = set_metrics(real_, options_.metrics);
  return *real_rows_;
}

std::vector<size_t> EvalContext::clips_of_content(int content) const {
  std::vector<size_t> out;
  for (size_t i = 0; i < num_clips(); ++i)
    if (clip(i).content == content) out.push_back(i);
  return out;
}

const std::vector<MetricValue>& EvalContext::real_set_metrics(int content) {
  auto it = real_rows_by_content_.find(content);
  if (it == real_rows_by_content_.end()) {
    std::vector<MotionPositions> real;
    for (size_t i : clips_of_content(content)) real.push_back(real_[i]);
    it = real_rows_by_content_.emplace(content, set_metrics(real, options_.metrics)).first;
  }
  return it->second;
}

nn::SampleExtras EvalContext::clip_labels(size_t i) const {
  nn::SampleExtras extras;
  if (run_.traits.labels && options_.clip_labels) {  // the clip's own labels, for a label-conditioned model
    const data::ClipRecord& rec = clip(i);
    extras.content = translate_label(rec.content, info().content_labels, run_.dataset.content_labels);
    extras.style = translate_label(rec.style, info().style_labels, run_.dataset.style_labels);
  }
  return extras;
}

const std::vector<std::vector<nn::SampledMotion>>& EvalContext::sampled_motions() {
  if (motions_) return *motions_;
  const int n = options_.num_samples;
  const int total = static_cast<int>(chosen_.size());
  std::vector<std::vector<nn::SampledMotion>> motions;
  for (size_t i = 0; i < chosen_.size(); ++i) {
    report("sampling", static_cast<int>(i), total);
    const data::ClipRecord& rec = clip(i);
    nn::SampleExtras extras = clip_labels(i);
    extras.warmup_frames = warmup_frames_;
    motions.push_back(nn::sample_motions(run_, rec.control, n, options_.seed + i, options_.temperature, extras));
    std::vector<MotionPositions> mine;
    for (int k = 0; k < n; ++k)
      mine.push_back(motion_positions(nn::decode_motion(run_, motions.back()[k]), 0.0,
                                      rec.source + " sample " + std::to_string(k)));
    samples_.push_back(std::move(mine));
  }
  report("sampling", total, total);
  motions_ = std::move(motions);
  return *motions_;
}

const std::vector<std::vector<MotionPositions>>& EvalContext::samples() {
  sampled_motions();
  return samples_;
}

const std::vector<std::vector<MotionPositions>>& EvalContext::foot_locked_samples() {
  if (locked_) return *locked_;
  const auto& motions = sampled_motions();
  std::vector<std::vector<MotionPositions>> locked;
  for (size_t i = 0; i < motions.size(); ++i) {
    std::vector<MotionPositions> mine;
    for (size_t k = 0; k < motions[i].size(); ++k) {
      Clip pinned = nn::decode_motion(run_, motions[i][k]);
      pinned.motion = foot_lock(pinned.skeleton, pinned.motion);
      mine.push_back(motion_positions(pinned, 0.0, clip(i).source + " sample " + std::to_string(k) + " foot-locked"));
    }
    locked.push_back(std::move(mine));
  }
  locked_ = std::move(locked);
  return *locked_;
}

const std::vector<nn::SampledMotion>& EvalContext::raw_continuations(size_t i, int p, int end,
                                                                    std::uint64_t seed) const {
  const auto key = std::make_tuple(i, p, end, seed);
  auto found = continued_.find(key);
  if (found != continued_.end()) return found->second;
  const data::ClipRecord& rec = clip(i);
  const int d = run_.context.pose_dim, c = run_.context.control_dim;
  nn::SampleExtras extras = clip_labels(i);
  extras.prefix_pose = rows_of(rec.pose, 0, p, d);
  extras.prefix_control = rows_of(rec.control, 0, p, c);
  std::vector<nn::SampledMotion> out;
  for (const auto& future :
       nn::sample_motions(run_, rows_of(rec.control, p, end, c), options_.num_samples, seed, options_.temperature, extras)) {
    nn::SampledMotion whole{extras.prefix_pose, extras.prefix_control};
    whole.pose.insert(whole.pose.end(), future.pose.begin(), future.pose.end());
    whole.control.insert(whole.control.end(), future.control.begin(), future.control.end());
    out.push_back(std::move(whole));
  }
  return continued_.emplace(key, std::move(out)).first->second;
}

const std::vector<Eigen::MatrixXd>& EvalContext::continuations(size_t i, int p, int end, std::uint64_t seed) const {
  const auto key = std::make_tuple(i, p, end, seed);
  auto found = decoded_.find(key);
  if (found != decoded_.end()) return found->second;
  std::vector<Eigen::MatrixXd> out;
  for (const auto& whole : raw_continuations(i, p, end, seed))
    out.push_back(motion_positions(nn::decode_motion(run_, whole)).sequence());
  return decoded_.emplace(key, std::move(out)).first->second;
}

const std::vector<std::unique_ptr<Protocol>>& all_protocols() {
  static const std::vector<std::unique_ptr<Protocol>> kAll = [] {
    std::vector<std::unique_ptr<Protocol>> v;
    v.push_back(make_locomotion_protocol());
    v.push_back(make_paths_protocol());
    v.push_back(make_diversity_protocol());
    v.push_back(make_joint_errors_protocol());
    v.push_back(make_prediction_protocol());
    v.push_back(make_body_validity_protocol());
    v.push_back(make_recognition_protocol());
    v.push_back(make_label_generation_protocol());
    v.push_back(make_long_horizon_protocol());
    v.push_back(make_prefix_generation_protocol());
    return v;
  }();
  return kAll;
}

std::vector<std::string> protocols_for(const nn::ModelTraits& traits, const EvalOptions& options) {
  std::string known;
  for (const auto& p : all_protocols()) known += (known.empty() ? "" : ", ") + p->name();
  for (const std::string& name : options.only_protocols)
    if (std::none_of(all_protocols().begin(), all_protocols().end(), [&](const auto& p) { return p->name() == name; }))
      throw Error("evaluate: unknown protocol '" + name + "' (" + known + ")");
  const auto& only = options.only_protocols;
  std::vector<std::string> names;
  for (const auto& p : all_protocols())
    if (p->enabled(options) && p->applies_to(traits) &&
        (only.empty() || std::find(only.begin(), only.end(), p->name()) != only.end()))
      names.push_back(p->name());
  return names;
}

}  // namespace mosyn::eval
