// The units of `mosyn eval`: each protocol scores one aspect of a run (locomotion along held-out
// controls, drawn paths, joint errors, prediction, recognition, long-horizon stability) and adds
// its rows to the result. Which protocols apply to a run follows from its traits (nn/traits.h),
// never from its family name; which ones run also depends on the options (e.g. --paths).
// The protocols share one EvalContext: the held-out clips, their decoded real motions and the
// samples along their controls, computed once, when a protocol first asks for them.
// See src/eval/README.md, "Protocols".
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <tuple>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "data/dataset.h"
#include "eval/evaluate.h"
#include "metrics/metrics.h"
#include "metrics/set_metrics.h"
#include "nn/run.h"
#include "nn/sampling.h"
#include "nn/traits.h"

namespace mosyn::eval {

// What the protocols of one evaluation share. Not thread-safe; lives for one evaluate() call.
class EvalContext {
 public:
  // Chooses the held-out clips: those of options.split with >= 2 frames (without mirrored,
  // reversed or retimed copies unless include_augmented), at most max_clips evenly spread;
  // decodes them.
  // Throws mosyn::Error when the run has no motion model, the options are invalid, the dataset's
  // features do not match the run's, or the split has no clip.
  EvalContext(const nn::LoadedRun& run, const data::Dataset& dataset, const EvalOptions& options,
              EvalProgressCallback progress = {});

  const nn::LoadedRun& run() const { return run_; }
  const data::Dataset& dataset() const { return dataset_; }
  const data::DatasetInfo& info() const { return dataset_.info(); }
  const EvalOptions& options() const { return options_; }
  int num_samples() const { return options_.num_samples; }  // N per control
  // Number of chosen clips, their indices in dataset.clips(split), and clip i's record.
  size_t num_clips() const { return chosen_.size(); }
  const std::vector<int>& clip_indices() const { return chosen_; }
  const data::ClipRecord& clip(size_t i) const;
  // Warm-up frames for synthesis at the run's rate (nn::SampleExtras::warmup_frames).
  int warmup_frames() const { return warmup_frames_; }

  // World joint positions (metres) of the real clips [clips], decoded with data::decode_record.
  const std::vector<MotionPositions>& real() const { return real_; }
  // set_metrics(real(), options.metrics), computed once.
  const std::vector<MetricValue>& real_set_metrics();
  // The chosen clips (indices into real(), clip()) whose content label is `content` (the
  // dataset's id), and set_metrics of their real motions alone, computed once per content.
  std::vector<size_t> clips_of_content(int content) const;
  const std::vector<MetricValue>& real_set_metrics(int content);
  // N samples along each clip's own control (and labels), seed options.seed + clip index: raw
  // [clips][N] and decoded world positions [clips][N] (on the root motion the model returned:
  // the given control, or the one it generated). Sampled once, on the first call of either.
  const std::vector<std::vector<nn::SampledMotion>>& sampled_motions();
  const std::vector<std::vector<MotionPositions>>& samples();
  // The samples after the foot-lock post-process (core/foot_lock.h) [clips][N], computed once.
  const std::vector<std::vector<MotionPositions>>& foot_locked_samples();

  // Extras carrying clip i's own content / style labels when the model is conditioned on labels
  // (matched to the run's vocabulary by name), none otherwise.
  nn::SampleExtras clip_labels(size_t i) const;
  // N continuations of clip i's first p real frames up to frame `end` (p < end <= its frames),
  // given its true control and labels: world joint-position sequences [end, J * 3] (metres) of
  // the real prefix followed by the generated frames. Needs traits.prefix. Decoded once per window.
  const std::vector<Eigen::MatrixXd>& continuations(size_t i, int p, int end, std::uint64_t seed) const;
  // The same continuations as raw features, before decoding: N motions of `end` frames (the real
  // prefix's pose [end, D] and control [end, C] followed by the generated ones). Sampled once per
  // (i, p, end, seed) and kept, so protocols scoring the same windows share the samples.
  const std::vector<nn::SampledMotion>& raw_continuations(size_t i, int p, int end, std::uint64_t seed) const;

  // Calls the progress callback, if any.
  void report(const std::string& stage, int done, int total) const;

 private:
  const nn::LoadedRun& run_;
  const data::Dataset& dataset_;
  EvalOptions options_;
  EvalProgressCallback progress_;
  std::vector<int> chosen_;
  int warmup_frames_ = 0;
  std::vector<MotionPositions> real_;
  std::optional<std::vector<MetricValue>> real_rows_;
  std::map<int, std::vector<MetricValue>> real_rows_by_content_;
  std::optional<std::vector<std::vector<nn::SampledMotion>>> motions_;
  std::vector<std::vector<MotionPositions>> samples_;
  std::optional<std::vector<std::vector<MotionPositions>>> locked_;
  mutable std::map<std::tuple<size_t, int, int, std::uint64_t>, std::vector<nn::SampledMotion>> continued_;
  mutable std::map<std::tuple<size_t, int, int, std::uint64_t>, std::vector<Eigen::MatrixXd>> decoded_;
};

// One unit of evaluation.
class Protocol {
 public:
  virtual ~Protocol();
  // Stable short name, e.g. "locomotion", "prediction".
  virtual std::string name() const = 0;
  // Whether the options ask for it (e.g. synthetic_paths for "paths", a classifier for
  // "recognition"); most protocols are on by default.
  virtual bool enabled(const EvalOptions& options) const = 0;
  // Whether it can score a model with these traits (control taken / generated, labels, prefix,
  // streaming).
  virtual bool applies_to(const nn::ModelTraits& traits) const = 0;
  // Adds its rows (and counters such as prediction_windows) to result. Throws mosyn::Error for
  // invalid options or inputs.
  virtual void run(EvalContext& context, EvalResult& result) const = 0;
};

// Every protocol, in the order of their rows: locomotion (set metrics, foot-locked), paths,
// diversity (per-control APD, mean-pose distance, FSE), joint_errors, prediction, body_validity,
// recognition, label_generation, long_horizon, prefix_generation.
const std::vector<std::unique_ptr<Protocol>>& all_protocols();

// Names of the protocols of all_protocols() that are enabled by options, apply to traits and are
// among options.only_protocols when that is given, in order (what evaluate runs). Throws
// mosyn::Error for an unknown name in only_protocols.
std::vector<std::string> protocols_for(const nn::ModelTraits& traits, const EvalOptions& options);

}  // namespace mosyn::eval
