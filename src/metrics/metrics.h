// Objective metrics of motion quality, diversity and accuracy, computed the same way for generated
// motions and for real held-out clips. Plain Eigen/C++: the metrics layer links no LibTorch, so
// commands that only measure files start at once; namespace mosyn::eval, whose protocols use it.
// Definitions and the choices made where the papers leave things open are in src/eval/README.md.
//
// Conventions:
// - Positions are world joint positions in METRES, row-major [T, J] (index t * J + j).
// - The floor is the plane orthogonal to the up axis (0 = X, 1 = Y, 2 = Z); "horizontal" means the
//   two other coordinates.
// - A pose vector is the J * 3 joint coordinates of one frame flattened (x0 y0 z0 x1 ...); a
//   sequence matrix is [T, J * 3], one pose per row. Distances between poses are the Euclidean
//   (L2) norm of the whole pose vector, in metres.
// - Functions throw mosyn::Error for inconsistent sizes or invalid options; never print.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::eval {

// World joint positions of one motion, in metres.
// (eval's detail::slice copies every field but positions_m by name: a new field goes there too.)
struct MotionPositions {
  std::string name;                     // e.g. the file it came from (for messages)
  double fps = 30.0;
  int num_frames = 0;
  int num_joints = 0;
  int up_axis = 1;
  std::vector<std::string> joint_names;  // [J]
  std::vector<int> parents;              // [J], -1 for the root
  std::vector<double> bone_lengths_m;    // [J] rest length of the bone to the parent (0 for the root)
  std::vector<Eigen::Vector3d> positions_m;  // [T, J]

  const Eigen::Vector3d& position(int t, int j) const {
    return positions_m[static_cast<size_t>(t) * num_joints + j];
  }
  // The motion as a sequence matrix [T, J * 3].
  Eigen::MatrixXd sequence() const;
};

// Forward kinematics of a clip scaled to metres: meters_per_unit > 0 is used as given, otherwise
// the skeleton's own when it is not 1, else guess_units(skeleton). Up axis from the skeleton. A
// placeholder root (data::has_static_root, e.g. Bandai-Namco's joint_Root) is collapsed first, so
// joint 0 is the pelvis and every bone is a body part.
MotionPositions motion_positions(const Clip& clip, double meters_per_unit = 0.0, const std::string& name = "");

// Joint index of the first joint whose name contains one of the patterns (case-insensitive), tried
// pattern by pattern, restricted to joints with side (joint_sides: +1 left, -1 right, 0 unpaired)
// equal to `side`; -1 when none.
int find_joint_by_patterns(const std::vector<std::string>& joint_names, const std::vector<int>& sides,
                           const std::vector<std::string>& patterns, int side);

// The joints whose horizontal speed marks ground contact.
struct FootJoints {
  int left_heel = -1, right_heel = -1;  // ankle / heel joints (Foot_L, LeftFoot, LHEE)
  int left_toe = -1, right_toe = -1;    // toe joints (Toes_L, LeftToeBase), -1 when absent
};

// Foot joints found by name: heel = first of "heel", "foot", "ankle" on each side; toe = first
// of "toe" on each side (sides from mirror_map). Names in `overrides` (exact joint names, may be
// empty) replace the search: {left_heel, right_heel, left_toe, right_toe}. Throws mosyn::Error when
// an override names no joint or no heel is found on either side.
FootJoints find_foot_joints(const MotionPositions& motion, const std::vector<std::string>& overrides = {});

// Side of every joint (+1 left, -1 right, 0 unpaired) from its name, as joint_sides (core/mirror.h).
std::vector<int> joint_sides_of(const MotionPositions& motion);

// ---------------------------------------------------------------------------------------------
// Locomotion quality: footstep analysis (MoGlow, Henter et al. 2020, section 5.3).

// Horizontal speed [T - 1] of joint j in m/s: speed[t] = |h(p[t+1] - p[t])| * fps (h drops the up
// coordinate). Empty for fewer than 2 frames.
std::vector<double> horizontal_speed_mps(const MotionPositions& motion, int joint);

// Ground speed of the pelvis (joint 0; motion_positions collapses a placeholder root) in m/s,
// measured over spans of span_s seconds: the horizontal distance it covers from frame t to t + n,
// n = round(span_s * fps) (at least 1), divided by n / fps, averaged over every t and over every
// motion's spans pooled (a motion shorter than the span counts once, over its whole length). The
// span averages the gait's sway out, so a body that keeps up with its path reads about the path's
// speed; a body that falls behind its root control reads slower than real motion along the same
// control. NaN when no motion has 2 frames. Throws mosyn::Error when span_s is not positive.
double pelvis_ground_speed_mps(const std::vector<MotionPositions>& motions, double span_s = 1.0);

// Footsteps of one speed track: maximal runs of consecutive samples with speed < v_tol_mps. A run
// of n samples spans n + 1 frames and lasts n / fps seconds. Runs touching the ends count. (No
// minimum duration here; analyse_footsteps applies FootstepOptions::min_step_duration_s.)
// Returns the durations in seconds, in time order.
std::vector<double> footstep_durations_s(const std::vector<double>& speed_mps, double fps, double v_tol_mps);

struct FootstepOptions {
  double v_tol_step_mps = 0.01;  // tolerance increment (the paper: 1 cm/s for humans)
  double v_tol_max_mps = 1.0;    // last tolerance tried
  bool use_toes = false;         // toe joints instead of heels (quadrupeds), when found
  // Shortest run counted as a footstep. Mocap jitter splits a contact into brief still runs at low
  // tolerances; without a minimum those fragments inflate f_est beyond the true plateau.
  double min_step_duration_s = 0.1;
  // One tolerance for every set, for the contact rate and length below. v_tol95 adapts to each set,
  // so a model whose feet stay slow for long around each contact (few, long steps) can match real
  // walks there; at a fixed tolerance its contacts come out longer and rarer. 15 cm/s: above the
  // planted heel's jitter on Bandai-Namco walks, below its swing.
  double fixed_tol_mps = 0.15;
};

struct FootstepAnalysis {
  std::vector<double> v_tol_mps;   // [K] tolerances: (k + 1) * v_tol_step_mps
  std::vector<int> f_est;          // [K] footsteps over all feet and motions at each tolerance
  int max_steps = 0;               // max of f_est (the plateau: the paper's f_est)
  double v_tol95_mps = 0;          // first tolerance with f_est >= 0.95 * max_steps (0 if none)
  int steps_at_v_tol95 = 0;        // f_est at v_tol95
  double step_duration_mean_s = 0;  // over the footsteps at v_tol95 (NaN when none)
  double step_duration_std_s = 0;   // population std of the same (NaN when none)
  // At FootstepOptions::fixed_tol_mps (runs shorter than min_step_duration_s not counted):
  double contacts_per_foot_s = 0;         // footsteps per second per foot (cadence of one foot)
  double contact_mean_at_fixed_tol_s = 0; // their mean duration (NaN when none)
};

// Footstep analysis over a set of motions (their footsteps pooled, all tolerances; runs shorter than
// min_step_duration_s not counted), on the heels (or toes with use_toes) of feet[i] for motions[i];
// the contact rate divides the footsteps at fixed_tol_mps by the summed duration of every foot's
// speed track. Throws when the sizes differ or options are not positive.
FootstepAnalysis analyse_footsteps(const std::vector<MotionPositions>& motions, const std::vector<FootJoints>& feet,
                                   const FootstepOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Foot skating (MOJO, Zhang et al. 2021, section 4.4).

struct FootSkatingOptions {
  double height_threshold_m = 0.05;   // "near the ground": within this of the marker's lowest point
  double speed_threshold_mps = 0.075;  // 5 mm per frame at 15 fps (the paper's setting)
  // MOJO: skating "when both foot markers are close enough to the ground and simultaneously exceed
  // a speed limit". With false, one foot suffices (much higher on natural walking: a foot rolling
  // off the ground near toe-off already counts).
  bool both_feet = true;
};

// Fraction (0..1) of frame transitions t-1 -> t (t = 1..T-1) in which a foot marker (the heels of
// `feet`) lies within height_threshold_m of its own lowest height over the motion at both frames
// and moves horizontally faster than speed_threshold_mps. With both_feet, both markers must. The
// lowest point stands for the ground, because joints sit above the sole by an unknown amount. 0 for
// fewer than 2 frames.
double foot_skating_ratio(const MotionPositions& motion, const FootJoints& feet, const FootSkatingOptions& options = {});

// Toe sliding, the rule of the independent check (../shared/checks/natural_motion.py, its "foot
// skating"): each toe's floor is a low percentile of its height over the motion (robust to a
// stray low frame, where the lowest point is not); a transition t-1 -> t slides when a toe within
// height_threshold_m of its floor at t-1 moves horizontally faster than speed_threshold_mps. One
// toe suffices. Stricter than MOJO's measure above: a toe dragging while the other foot stands,
// or shuffling at a stop, counts (docs/experiments.md, MoGlow).
struct ToeSlideOptions {
  double height_threshold_m = 0.01;
  double speed_threshold_mps = 0.10;
  double floor_percentile = 5.0;  // in [0, 100], linear between order statistics
};

// Fraction (0..1) of frame transitions t-1 -> t (t = 1..T-1) in which a toe of `feet` slides (above).
// NaN when the motion has no toe joint; 0 for fewer than 2 frames. Throws mosyn::Error when
// floor_percentile is outside [0, 100] or a threshold is not positive.
double toe_slide_ratio(const MotionPositions& motion, const FootJoints& feet, const ToeSlideOptions& options = {});

// Horizontal speed (m/s) of the slower heel at every frame transition t-1 -> t (t = 1..T-1): near
// zero while a foot is planted, so its median tells a walk (a foot down at almost every instant:
// a few cm/s on Bandai-Namco walks) from a glide (both feet moving) and shows whether a body that
// stands has its feet still. Empty for fewer than 2 frames; throws mosyn::Error without heels.
std::vector<double> slower_foot_speed_mps(const MotionPositions& motion, const FootJoints& feet);

// ---------------------------------------------------------------------------------------------
// Body validity.

// The points a raw pose row of the marker or joint-position form holds (data/representation.h:
// dim / 3 points, each its heading-frame offset from the floor trajectory, metres, Y-up) placed in
// the world of frames [from, to): each offset rotated by the heading and added to the floor
// position, both integrated from the control (dx, dz, dtheta per frame) from the origin at heading
// 0. pose [T, dim], control [T, 3] row-major; names [dim / 3] become joint_names (no parents).
// Throws mosyn::Error when the sizes disagree or [from, to) is not inside [0, T).
MotionPositions feature_points_world(const std::vector<float>& pose, const std::vector<float>& control, int dim,
                                     int from, int to, const std::vector<std::string>& names, double fps);

// Root mean square over frames and non-root joints of (|p_j - p_parent(j)| - bone_lengths_m[j]),
// metres. 0 for a motion without bones or frames.
double bone_length_rmse_m(const MotionPositions& motion);

// A set of joints that a real body keeps at fixed mutual distances.
struct RigidPart {
  std::string name;          // "head", "upper torso", "lower torso"
  std::vector<int> joints;   // at least 2
};

// The head (neck and head joints), upper torso (the neck's parent, the neck, and the first joint of
// each shoulder chain) and lower torso (the pelvis, its first unpaired child, and the first joint of
// each leg) found by name; parts with fewer than 2 joints found are left out.
std::vector<RigidPart> default_rigid_parts(const MotionPositions& motion);

// MOJO's deformation score of one part (Eq. 3): the standard deviation over time (population) of
// each pairwise distance between the part's joints, averaged over pairs; metres.
double rigid_part_deformation_m(const MotionPositions& motion, const RigidPart& part);

// ---------------------------------------------------------------------------------------------
// Stochastic prediction (DLow, Yuan and Kitani 2020; MOJO section 4.3). Samples and ground truths
// are sequence matrices [T, D] of equal shape.

// Average pairwise distance: mean over ordered pairs i != j of ||X_i - X_j|| (Frobenius norm of the
// whole flattened sequence). 0 for fewer than 2 samples.
double average_pairwise_distance(const std::vector<Eigen::MatrixXd>& samples);

// min over samples k of mean over frames t of ||X_k[t] - Y[t]||.
double average_displacement_error(const std::vector<Eigen::MatrixXd>& samples, const Eigen::MatrixXd& ground_truth);

// min over samples k of ||X_k[T-1] - Y[T-1]||.
double final_displacement_error(const std::vector<Eigen::MatrixXd>& samples, const Eigen::MatrixXd& ground_truth);

// Joint-position error at given frames (Habibie et al. 2017, Tables 1-2): for each frame f in
// `frames`, the mean over joints j of the Euclidean distance |X[f, j] - Y[f, j]| in metres, where
// X and Y are sequence matrices [T, J * 3] of equal width (row counts may differ; every frame must
// be a row of both). Returns one value per requested frame, in order. Throws mosyn::Error on a
// width mismatch, a width not a multiple of 3 or a frame out of range.
std::vector<double> joint_position_errors_m(const Eigen::MatrixXd& sample, const Eigen::MatrixXd& ground_truth,
                                            const std::vector<int>& frames);

// Multi-modal ground truth: for each window i, the indices j (i included, ascending) of windows
// whose last context pose lies within threshold_m of window i's: ||c_j - c_i|| <= threshold_m.
// last_context_poses is [N, D], one row per window.
std::vector<std::vector<int>> multimodal_ground_truth(const Eigen::MatrixXd& last_context_poses, double threshold_m);

// Mean over the ground truths g of ADE(samples, g) (MMADE), and of FDE (MMFDE).
double multimodal_ade(const std::vector<Eigen::MatrixXd>& samples, const std::vector<Eigen::MatrixXd>& ground_truths);
double multimodal_fde(const std::vector<Eigen::MatrixXd>& samples, const std::vector<Eigen::MatrixXd>& ground_truths);

// Power-spectrum entropy of a sequence [T, D] (nats): for each column, the mean is removed, the
// one-sided power spectrum P_k = |DFT_k|^2 for k = 1..floor(T/2) is normalised to sum 1 and its
// entropy -sum P_k log P_k taken; the result is the mean over columns with non-zero power (0 when
// none).
double spectral_entropy(const Eigen::MatrixXd& sequence);

// FSE: mean spectral_entropy of the samples minus mean spectral_entropy of the ground truths.
double spectral_entropy_difference(const std::vector<Eigen::MatrixXd>& samples,
                                   const std::vector<Eigen::MatrixXd>& ground_truths);

// One test window of a stochastic-prediction evaluation.
struct PredictionWindow {
  std::vector<Eigen::MatrixXd> samples;  // K predicted futures [T, D]
  Eigen::MatrixXd ground_truth;          // the real future [T, D]
  Eigen::VectorXd last_context_pose;     // [D] the last observed pose (for the multi-modal GT)
};

// The DLow / MOJO protocol over test windows, each value the mean over windows.
struct PredictionMetrics {
  int num_windows = 0;
  double apd_m = 0, ade_m = 0, fde_m = 0, mmade_m = 0, mmfde_m = 0;
  double fse = 0;  // mean spectral entropy of all samples minus that of all ground truths
};

// APD of each window's samples; ADE/FDE against its ground truth; MMADE/MMFDE against the ground
// truths of every window whose last context pose lies within multimodal_threshold_m of its own
// (multimodal_ground_truth); FSE over all samples and ground truths. Throws for no windows or
// shapes that disagree.
PredictionMetrics evaluate_predictions(const std::vector<PredictionWindow>& windows, double multimodal_threshold_m);

// ---------------------------------------------------------------------------------------------
// Distribution over time (DFN, Chen et al. 2020, section 6.3).

struct MeanPoseDistance {
  Eigen::VectorXd mean_m;  // [T] mean over samples of ||X_k[t] - mean_k X_k[t]||
  Eigen::VectorXd std_m;   // [T] population std of the same distances
};

// For each frame, the distance of every sample's pose to the mean pose of all samples at that
// frame. Samples must share their shape; at least one.
MeanPoseDistance mean_pose_distance(const std::vector<Eigen::MatrixXd>& samples);

// ---------------------------------------------------------------------------------------------
// Recognisability (Ghorbani et al. 2020, section 5.2), on a classifier's outputs.

// Inception score from class probabilities [N, C] (rows sum to 1): exp(mean_i KL(p_i || p_hat))
// with p_hat the mean row. Terms with p_i(c) = 0 contribute 0.
double inception_score(const Eigen::MatrixXd& probabilities);

// Frechet distance between Gaussians: ||mu1 - mu2||^2 + Tr(S1 + S2 - 2 (S1 S2)^(1/2)), with the
// trace of the square root computed as sum sqrt(eig(S1^(1/2) S2 S1^(1/2))) (symmetric, stable).
double frechet_distance(const Eigen::VectorXd& mean1, const Eigen::MatrixXd& cov1, const Eigen::VectorXd& mean2,
                        const Eigen::MatrixXd& cov2);

// FID between two feature sets [N, F] and [M, F] (rows are samples): Frechet distance of their
// means and unbiased (N - 1) covariances. Each set needs at least 2 rows.
double frechet_inception_distance(const Eigen::MatrixXd& features1, const Eigen::MatrixXd& features2);

}  // namespace mosyn::eval
