// `mosyn eval`: a trained run scored on held-out data beside the held-out data itself. For each
// held-out clip, its control (and labels) drive N random samples; every metric is computed with
// the same code on the samples and on the real clips (see src/eval/README.md, "Eval protocol").
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "data/dataset.h"
#include "metrics/set_metrics.h"
#include "nn/run.h"

namespace mosyn::eval {

struct EvalOptions {
  std::string split = "val";     // dataset split of the held-out clips ("val" or "train")
  int num_samples = 10;          // N samples per control
  std::uint64_t seed = 1;        // clip i is sampled with seed + i (prediction: seed + 1000003 + i)
  int max_clips = 0;             // at most this many clips (evenly spread over the split); 0 = all
  double temperature = 1.0;      // latent standard-deviation multiplier
  double warmup_s = -1.0;        // synthesis: a lead-in generated first and dropped (nn SampleExtras);
                                 // < 0 = the family's default_warmup_s() (MoGlow 1 s, rvae 0)
  bool include_augmented = false;  // also evaluate mirrored / reversed / retimed copies in the split
  // Give a label-conditioned model each held-out clip's own content and style (true), or no label
  // (-1: what the model does on its own, e.g. a Dynamic Future Net's transitions between contents).
  // The label-generation protocol asks for every label either way.
  bool clip_labels = true;
  // Joint-position errors against the held-out clip itself (Habibie et al. 2017, Tables 1-2),
  // at the times of `error_frames` counted at `error_frames_fps` (the paper: frames 70..210 of
  // 4-s clips at 60 Hz, i.e. 1.17..3.5 s), from a prior sample and from `initial_frames` real
  // frames, given the clip's true control:
  bool joint_errors = true;
  std::vector<int> error_frames = {70, 90, 120, 160, 210};
  double error_frames_fps = 60.0;
  int initial_frames = 4;        // the paper's "4 initial frames" (R = 4 for its two poolings)
  // Stochastic prediction (every family that continues a given motion, i.e. honours
  // SampleRequest::prefix_pose):
  bool prediction = true;
  double prefix_s = 1.0;         // observed real motion before the prediction
  double horizon_s = 2.0;        // predicted motion, given the true control
  double multimodal_threshold_m = 0.5;  // MMADE/MMFDE ground-truth grouping (root-relative whole-pose L2, m)
  std::string classifier_dir;    // a "classifier" run: adds IS, FID and accuracies ("" = none)
  SetMetricsOptions metrics;     // footstep, skating and foot-joint options
  // Also score the samples after the foot-lock post-process (core/foot_lock.h): rows
  // "foot_locked.<key>" beside the raw ones, which stay what the model makes.
  bool foot_lock = false;
  // Sample a run whose config plants its root (nn/root_planting.h) with the model's own root steps
  // instead (nn::LoadOptions::raw_root; the overloads that load the run).
  bool raw_root = false;
  // Also sample every synthetic path of eval/path_protocol.h (num_samples each) and score them
  // against the held-out walk clips (every held-out clip when none walks): rows "paths.<key>".
  bool synthetic_paths = false;
  // Long-horizon stability (eval/protocol.h, "long_horizon"): N samples of this many seconds (a
  // meandering walk at 1.3 m/s for families that take control, free generation otherwise), scored
  // per window of long_horizon_window_s seconds: rows "long_horizon.*". 0 = off.
  double long_horizon_s = 0;
  double long_horizon_window_s = 10.0;
  // Generation from held-out prefixes (Dynamic Future Net, Chen et al. 2020, sections 6.2-6.4),
  // for families that continue a prefix and make their own root motion: N samples of
  // prefix_generation_s seconds after the first prefix_generation_frames real frames of
  // prefix_generation_clips held-out clips (evenly spread over the chosen ones), scored over
  // windows of long_horizon_window_s against the real clips of the prefix's content: rows
  // "prefix_generation.*" and the curves "prefix_generation.mean_pose_distance.c<k>" (Fig. 9).
  // With a classifier, each sample's content is also recognised in windows of transition_window_s
  // seconds (0 = the classifier's training window) and the changes counted. 0 = off.
  // Generation by label alone (Ghorbani et al. 2020, Table 2), for families conditioned on labels
  // and with classifier_dir: label_samples samples of label_seconds (0 = the dataset's window) for
  // every content x style combination of the run, no prefix: rows "label_generation.*". 0 = off.
  int label_samples = 0;
  double label_seconds = 0;
  double prefix_generation_s = 0;
  int prefix_generation_frames = 20;
  int prefix_generation_clips = 4;
  double transition_window_s = 0;  // 0 = the classifier's training window
  int reference_clips = 200;     // training clips (evenly spread) behind Fig. 9's training band
  // When not empty, only these protocols run (of those the options enable and the run's traits
  // allow; names as Protocol::name(), eval/protocol.h), e.g. {"prediction", "body_validity"} for
  // the prediction tables alone. An unknown name is an error.
  std::vector<std::string> only_protocols;
  int threads = 0;               // LibTorch CPU threads for loading runs (0 = all, < 0 = leave)
  std::string checkpoint = "checkpoint.pt";  // file of the run to evaluate (e.g. "best.pt"), run_dir overload
};

struct EvalProgress {
  std::string stage;  // "sampling", "paths", "joint errors", "prediction", "classifier", "long horizon"
  int done = 0;
  int total = 0;
};
using EvalProgressCallback = std::function<void(const EvalProgress&)>;

// A statistic over time (e.g. DFN's Fig. 9): per frame the mean and spread over samples, and the
// reference's (real or training data) level as a constant band.
struct EvalCurve {
  std::string key;            // stable identifier, e.g. "prefix_generation.mean_pose_distance.c0"
  std::string label;          // human-readable with unit
  double fps = 0;             // frames per second of the series
  std::vector<double> mean;   // [T]
  std::vector<double> spread; // [T] population standard deviation around mean
  double reference_mean = 0;  // NaN = none
  double reference_spread = 0;
};

// One row of the table. NaN = does not apply (e.g. ADE of the real data).
struct EvalRow {
  std::string key;    // stable identifier, e.g. "footsteps.v_tol95_cmps", "prediction.ade_m"
  std::string label;  // human-readable with unit
  double model = 0;
  double real = 0;
};

struct EvalResult {
  std::string run_dir;
  std::string family;
  std::string split;
  int num_samples = 0;
  std::uint64_t seed = 0;
  std::vector<std::string> clips;      // sources of the evaluated clips, in order
  std::vector<int> clip_indices;       // their indices in dataset.clips(split)
  int prediction_windows = 0;          // 0 when prediction did not run
  int joint_error_clips = 0;           // clips long enough for the joint errors (0: not run)
  std::vector<EvalRow> rows;
  std::vector<EvalCurve> curves;       // statistics over time, written under "curves"
  // Names of the protocols that ran (eval/protocol.h), in order. Not written by to_json (the file
  // format stays as it was); empty after from_json.
  std::vector<std::string> protocols;

  // The row with this key; throws mosyn::Error when absent.
  const EvalRow& row(const std::string& key) const;
  // {"run", "family", "split", "n", "seed", "clips", "prediction_windows",
  //  "joint_error_clips", "rows": [{"key", "label", "model", "real"}], "metrics": {key: {"model",
  //  "real"}}, "curves": [{"key", "label", "fps", "mean", "spread", "reference_mean",
  //  "reference_spread"}]}, NaN as null ("curves" only when there is one).
  nlohmann::json to_json() const;
  // Reads what to_json wrote (for `mosyn report`). Throws mosyn::Error when malformed.
  static EvalResult from_json(const nlohmann::json& j);
};

// Runs every protocol of all_protocols() (eval/protocol.h) that the options enable and that applies
// to the run's traits, in this order, so the rows are, in order:
// - set metrics (set_metrics.h) of the real clips and, for the model, the mean over k = 1..N of
//   the set of every clip's k-th sample (same size and controls as the real set, so counts such
//   as footsteps compare directly);
// - with foot_lock, the same set metrics of the foot-locked samples, keys "foot_locked.<key>";
// - with synthetic_paths, the set metrics of all samples along the drawn paths, "paths.<key>";
// - "diversity.apd_m" APD across the N samples of one control, and
//   "diversity.mean_pose_distance_m" DFN's distance to the per-frame mean pose across them, each
//   averaged over clips (real: n/a, one motion per control);
// - "fse" spectral entropy of all samples minus that of the real clips (real: 0);
// - with joint_errors, for each error frame f (key suffix "f<f>", label with the time in s):
//   "joint_error.motion_prior.f<f>" mean joint-position error (cm) of the samples above against
//   the clip's own motion at that time (world positions: the root follows the same control, so
//   this includes the root's height and offsets); "joint_error.pose_prior.f<f>" the same with
//   positions relative to the pelvis (translation and rotation removed); and "motion_initial" /
//   "pose_initial" for samples that continue the clip's first initial_frames frames. Averaged
//   over the N samples and the clips covering the latest time (real: n/a);
// - with prediction: "prediction.apd_m", ".ade_m", ".fde_m", ".mmade_m", ".mmfde_m", ".fse", the constant-velocity
//   baseline (last pose carried at the root's velocity) ".cv_ade_m", ".cv_fde_m" and ".ade_over_cv"
//   (evaluate_predictions on joint positions relative to the pelvis, joint 0; real: n/a) over
//   clips with prefix + horizon frames; then, on the raw predicted features of the same windows
//   (MOJO's Tables 3, 4, 6; src/eval/protocols/body_validity.cpp): for marker-form runs
//   "validity.rigid_head_mm", "validity.rigid_upper_torso_mm", "validity.rigid_lower_torso_mm"
//   (Eq. 3 deformation, mm) and "validity.heel_skating" (LHEE/RHEE, MOJO's thresholds; real: the
//   windows' real frames), and for every run "validity.bdf_m" (limb bone deformation, m; raw
//   joints of the positions form, decoded joints otherwise; real: 0);
// - with a classifier: "classifier.content_acc" (and "style_acc") in percent, "classifier.is"
//   (content Inception score), "classifier.fid" (model: samples vs real clips; real: the real
//   clips split into two halves by index parity);
// - with label_samples > 0 and a classifier (families conditioned on labels): the rows
//   "label_generation.*" of src/eval/protocols/label_generation.cpp;
// - with prefix_generation_s > 0 (families that continue a prefix and generate their root motion):
//   see src/eval/protocols/prefix_generation.cpp for the rows "prefix_generation.*" and curves;
// - with long_horizon_s > 0, for each window w<k>: "long_horizon.bone_length_rmse_cm.w<k>" (cm),
//   "long_horizon.foot_skating_ratio.w<k>", "long_horizon.body_speed_mps.w<k>" (mean speed of the
//   joints relative to the pelvis, m/s), each the mean over the N samples, real: the real clips
//   whole; then "long_horizon.body_speed_ratio" (last window over first), ".frozen_fraction" and
//   ".exploded_fraction" (real: n/a).
// Families that generate their root motion are placed on the root motion they return; the
// protocols that need a given control (paths, joint errors) or a prefix (joint errors,
// prediction) are skipped for families without it.
// Throws mosyn::Error when the split has no clip, the dataset does not match the run's features,
// or the classifier's skeleton does not match the dataset's. A classifier trained on another
// feature form of the same skeleton is fine: samples and real clips are decoded and re-encoded
// as its data (data::encode_clip_for_dataset), so one classifier scores every family.
// A classifier run is scored by evaluate_classifier instead.
EvalResult evaluate(const nn::LoadedRun& run, const data::Dataset& dataset, const EvalOptions& options,
                    const EvalProgressCallback& progress = {});

// A classifier run (nn::FamilyKind::kClassifier) scored on the held-out clips of options.split
// (chosen as for a motion model: max_clips evenly spread, no augmented copies), each cut into
// windows as the recognition protocol cuts them. Rows (model: the classifier; real: n/a):
// "classifier.windows", "classifier.content_acc" / "style_acc" (% of windows recognised),
// "classifier.is" / "style_is" (Inception scores of the held-out clips), "classifier.fid_floor"
// (FID between the windows' two halves by index parity: what a perfect model would score), and
// per label "classifier.content_acc.<content>" / "classifier.style_acc.<style>". Throws
// mosyn::Error when the split has no clip or the dataset's skeleton is not the classifier's.
EvalResult evaluate_classifier(const nn::LoadedRun& classifier, const data::Dataset& dataset,
                               const EvalOptions& options, const EvalProgressCallback& progress = {});

// Loads run_dir (options.checkpoint) and evaluates: evaluate, or evaluate_classifier for a
// classifier run.
EvalResult evaluate(const std::string& run_dir, const data::Dataset& dataset, const EvalOptions& options,
                    const EvalProgressCallback& progress = {});

// The table as Markdown: | metric | model | real data |, n/a for NaN.
std::string format_markdown(const EvalResult& result);

}  // namespace mosyn::eval
