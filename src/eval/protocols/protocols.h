// The protocols of `mosyn eval` (eval/protocol.h), one source each, and the small helpers they
// share. Internal to the eval layer: callers use all_protocols() and evaluate().
#pragma once

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "eval/protocol.h"
#include "nn/classifier/classify.h"

namespace mosyn::eval {

// Set metrics of the samples along the held-out controls beside the real clips' (and, with
// foot_lock, of the foot-locked samples). Every motion model.
std::unique_ptr<Protocol> make_locomotion_protocol();
// Set metrics of N samples along each synthetic path (eval/path_protocol.h). Families that take
// control; on with synthetic_paths.
std::unique_ptr<Protocol> make_paths_protocol();
// APD and distance to the per-frame mean pose across the N samples of one control, and FSE.
// Every motion model.
std::unique_ptr<Protocol> make_diversity_protocol();
// Joint-position errors against the clip itself (Habibie et al. 2017). Families that take control
// and continue a prefix; on with joint_errors.
std::unique_ptr<Protocol> make_joint_errors_protocol();
// Stochastic prediction from a real prefix (DLow's ADE/FDE/MMADE/MMFDE). Families that continue a
// prefix; on with prediction.
std::unique_ptr<Protocol> make_prediction_protocol();
// MOJO's body validity on the raw predicted features of the prediction windows: rigid-part
// deformation and heel skating (marker form), limb bone deformation (every form). Families that
// continue a prefix; on with prediction.
std::unique_ptr<Protocol> make_body_validity_protocol();
// Content / style accuracy, IS and FID by a classifier run. Every motion model; on with
// classifier_dir.
std::unique_ptr<Protocol> make_recognition_protocol();
// Generation by label alone (Ghorbani et al. 2020, Table 2): samples of every content x style
// combination scored by an evaluation classifier (IS of content and style, FID overall and per
// label, recognition of the request). Families conditioned on labels; on with label_samples > 0
// and classifier_dir.
std::unique_ptr<Protocol> make_label_generation_protocol();
// Long-horizon stability over time windows. Every motion model; on with long_horizon_s > 0.
std::unique_ptr<Protocol> make_long_horizon_protocol();
// Long generation from held-out prefixes: stability against real clips of the prefix's content,
// DFN's Fig. 9 (distance to the per-frame mean pose over time, beside the training data's) and,
// with a classifier, content transitions. Families that continue a prefix (those that take control
// follow the long-horizon meander after it); on with prefix_generation_s > 0.
std::unique_ptr<Protocol> make_prefix_generation_protocol();

namespace detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Stability verdicts of the long-generation protocols (long_horizon, prefix_generation).
constexpr double kFrozenFraction = 0.2;  // frozen: a window's body speed under this share of real
constexpr double kExplodedExtent = 2.0;  // exploded: a joint this many times farther from the pelvis
                                         // than the farthest in the real clips

// Mean of the finite values; NaN when there is none.
double mean_finite(const std::vector<double>& values);

// Rows [from, to) of a row-major matrix with `dim` columns.
std::vector<float> rows_of(const std::vector<float>& a, int from, int to, int dim);

// A row-major float matrix [rows, cols] as Eigen.
Eigen::MatrixXd to_matrix(const std::vector<float>& v, int rows, int cols);

// Joint positions relative to joint 0 (the pelvis) per frame: sequence [T, J * 3].
Eigen::MatrixXd root_relative(const Eigen::MatrixXd& sequence);

// Control [T, C] of a meandering walk at 1.3 m/s (S-curves of 2 m every 8 m) at the run's rate,
// cut to `seconds`, shaped by its root smoothing; zeros for families that do not take control
// (only T is read).
std::vector<float> long_horizon_control(const nn::LoadedRun& run, double seconds);

// Frames [from, to) of a motion.
MotionPositions slice(const MotionPositions& m, int from, int to);

// Mean speed (m/s) of the non-root joints relative to the pelvis (joint 0): the body's own motion,
// whatever the root does. NaN for fewer than 2 frames or joints.
double body_speed_mps(const MotionPositions& m);

// The largest distance of a joint from the pelvis over the motion (m); infinity when a coordinate
// is not finite.
double largest_extent_m(const MotionPositions& m);

// FID between two feature sets [N, F]; NaN when either has fewer than 2 rows.
double fid_or_nan(const Eigen::MatrixXd& features1, const Eigen::MatrixXd& features2);

// FID between the even- and odd-indexed rows of features [N, F] (the floor of a set against
// itself); NaN under 4 rows.
double split_half_fid(const Eigen::MatrixXd& features);

// A classifier run (family "classifier") from options.classifier_dir, best.pt when present.
nn::LoadedRun load_classifier(const EvalOptions& options);

// Motions of the evaluated dataset as a classifier's inputs, with the classifier's label ids.
// Raw features pass unchanged when the classifier was trained on the same feature layout (decided
// once); otherwise each motion is decoded to a clip and encoded as the classifier's data (e.g. a
// joint-position model scored by a joint-rotation classifier), so one classifier scores every
// family. The classifier and info must outlive this.
class ClassifierInputs {
 public:
  ClassifierInputs(const nn::LoadedRun& classifier, const data::DatasetInfo& info);
  // Adds a raw motion (pose [T, D], control [T, C] of info's layout) with label ids in the
  // classifier's vocabularies (-1 = none). name is for messages.
  void add(const std::vector<float>& pose, const std::vector<float>& control, const std::string& name, int content = -1,
           int style = -1);
  // Adds a motion as the classifier was trained: cut into windows of its training length
  // (training_window) with half a window's hop (starts 0, hop, 2 hop, ... while the window fits,
  // plus one window ending at the last frame when those miss the tail), each one entry with the
  // motion's labels; a motion no longer than one window is one entry. Returns the entries added.
  int add_in_windows(const std::vector<float>& pose, const std::vector<float>& control, const std::string& name,
                     int content = -1, int style = -1);
  // The classifier's outputs for every entry added, in order.
  nn::ClassifierOutputs classify() const;

  std::vector<std::vector<float>> poses, controls;  // the classifier's raw inputs
  std::vector<int> content, style;                  // the classifier's label ids, -1 = none

 private:
  // A motion of info's layout in the classifier's features (unchanged when they are the same).
  void to_classifier_features(const std::vector<float>& pose, const std::vector<float>& control,
                              const std::string& name, std::vector<float>* p, std::vector<float>* c) const;
  void push(std::vector<float> p, std::vector<float> c, int content_id, int style_id);

  const nn::LoadedRun& classifier_;
  const data::DatasetInfo& info_;
  bool same_features_;
  int window_;  // training_window(classifier_), read once
};

// Frames of the windows a run was trained on: its config's "train"."window", else its dataset's.
int training_window(const nn::LoadedRun& run);

// Index of the largest entry of row `row` of probabilities [N, k].
int arg_max(const std::vector<float>& probabilities, int k, int row);

// Percentage of rows of probabilities [N, k] whose arg-max is their label (label -1 skipped);
// NaN when none.
double recognised_percent(const std::vector<float>& probabilities, int k, const std::vector<int>& labels);

// Extras with the run's "walk" content label (when it takes labels and knows "walk") and the
// given warm-up: what the drawn-path protocols sample with.
nn::SampleExtras walk_extras(const nn::LoadedRun& run, int warmup_frames);

// Index of `name` in a label vocabulary, -1 when absent.
int label_index(const std::vector<std::string>& labels, const std::string& name);

// Whether a set-metrics row is one of the gait rows (footsteps, skating, the pelvis' ground speed)
// repeated per path / content.
bool is_gait_row(const std::string& key);

}  // namespace detail

}  // namespace mosyn::eval
