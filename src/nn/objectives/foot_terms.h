// The foot terms the shared objectives add to a family's training loss (foot_objectives.h): how
// fast the heels a model makes move over the ground on the frames where the data's heels are
// planted, and their relatives (speed error, lift-off, stance, speed distribution, toe slide,
// pelvis offset, bone lengths). Motion capture of walking holds a planted heel within a few cm/s;
// a model that lets it glide there skates, which a likelihood (or ELBO) per feature barely
// notices, as the glide is a few millimetres per frame spread over a few features.
// The terms read the body's points through BodyPoints (body_points.h), so any pose form that
// gives joint positions serves: positions, markers, rotations after forward kinematics.
#pragma once

#include <torch/types.h>

#include <string>
#include <utility>
#include <vector>

#include "nn/context.h"
#include "nn/objectives/body_points.h"

namespace mosyn::nn {

// The heel terms' default planted threshold (m/s): walks' planted heels move a few cm/s, swinging
// feet metres per second.
constexpr double kDefaultPlantedMps = 0.15;

// What the heel terms read and when a data heel counts as planted.
struct FootTermOptions {
  // A data heel slower than this (m/s) is planted (walks: a few cm/s; a swinging foot, metres per
  // second). Real heels roll at 0.1-0.15 m/s at the ends of a stance, so at 0.15 the terms hold a
  // drawn heel still over those frames too (MoGlow's drawn contacts outlasted the takes').
  double planted_mps = kDefaultPlantedMps;
  // With f > 0 a data heel is planted below max(planted_mps, f x the root's ground speed into the
  // frame) instead: a running heel at 20 fps seldom falls under 0.15 m/s for more than one frame
  // (Bandai-Namco runs at 2.5 m/s and faster: 22% of the stances never), so at the fixed threshold
  // the runs barely reach the terms.
  double planted_speed_fraction = 0.0;
  // The terms also read the toes (BodyPoints::toe_points) beside the heels, [.., 4] instead of
  // [.., 2] below: the independent check's skating reads the toes, which slide while a heel stands.
  bool with_toes = false;
  // Each toe's weight against a heel (1) in the terms' means: with the toes at full weight MoGlow's
  // drawn feet planted harder than real ones.
  double toe_weight = 1.0;
  // The terms that need more than the heels and the pelvis, checked when the term is built: the
  // toe-slide term (toes), the bone-length term (rigid pairs: positions or markers form).
  bool toe_slide = false, bone_lengths = false;
};

class FootTerms {
 public:
  FootTerms() = default;
  // From a context with the dataset's skeleton, layout and statistics (a model built by mosyn
  // train or load_run; BodyPoints). family names the caller in errors. Throws mosyn::Error when the
  // context cannot give the heels (or toes, or pairs, as options ask), planted_mps is not in
  // (0, 1], planted_speed_fraction is negative or toe_weight is not in (0, 1].
  FootTerms(const ModelContext& context, const std::string& family, const FootTermOptions& options = {});

  // Horizontal speeds (m/s) of the made and the real heels from frame t-1 to t, t = 1..T-1:
  // [B, T-1, 2] each (4 with toes). made, real [B, T, D] and their controls [B, T, C] standardised
  // (the control of frame t is the root's step into it): the made heels move with made_control
  // (a family that generates its root passes its own steps), the real ones with real_control.
  // Computed once, they serve every term below.
  // planted_below_mps: the planted threshold of each step (m/s), [B, T-1, 1] with
  // planted_speed_fraction, else a scalar tensor; speeds assembled by hand may leave it undefined
  // (the term's planted_mps). root_mps: the data root's ground speed into each frame (m/s,
  // [B, T-1, 1], from real_control, not differentiated); undefined when assembled by hand.
  struct HeelSpeeds {
    torch::Tensor made_mps, real_mps, planted_below_mps, root_mps;
  };
  HeelSpeeds speeds(const torch::Tensor& made, const torch::Tensor& made_control, const torch::Tensor& real,
                    const torch::Tensor& real_control) const;
  // The root's ground speed (m/s) into each frame t = 1..T-1 from standardised control [B, T, C]
  // (the control of frame t is the root's step into it): [B, T-1], differentiable in control (a
  // family that generates its root steps can be charged for them).
  torch::Tensor root_mps(const torch::Tensor& control) const;
  // Both with the data's root steps (a family that takes the root as input).
  HeelSpeeds speeds(const torch::Tensor& made, const torch::Tensor& real, const torch::Tensor& control) const {
    return speeds(made, control, real, control);
  }

  // Each term below takes the speeds above, or made, real and control to compute them; valid
  // (optional [B, T-1], 0/1) leaves out steps into padded frames.

  // Mean horizontal speed (m/s) of the made heels from frame t-1 to t over the (heel, frame) pairs
  // where the real heel is planted, t = 1..T-1. made, real [B, T, D] and control [B, T, C]
  // standardised (the control of frame t is the root's step into it); valid (optional [B, T-1],
  // 0/1) leaves out steps into padded frames. A scalar, differentiable in made; 0 when nothing is
  // planted.
  torch::Tensor mean_planted_speed(const HeelSpeeds& speeds, const torch::Tensor& valid = {}) const;
  torch::Tensor mean_planted_speed(const torch::Tensor& made, const torch::Tensor& real, const torch::Tensor& control,
                                   const torch::Tensor& valid = {}) const {
    return mean_planted_speed(speeds(made, real, control), valid);
  }

  // Mean absolute difference (m/s) between the made and the real heels' horizontal speeds from
  // frame t-1 to t, over every (heel, step) pair (valid as above). Where the real heel is planted
  // it is the made heel's glide, as mean_planted_speed; where the real heel swings it also charges
  // a made heel that lingers slow around the contact. A scalar, differentiable in made.
  torch::Tensor mean_speed_error(const HeelSpeeds& speeds, const torch::Tensor& valid = {}) const;
  torch::Tensor mean_speed_error(const torch::Tensor& made, const torch::Tensor& real, const torch::Tensor& control,
                                 const torch::Tensor& valid = {}) const {
    return mean_speed_error(speeds(made, real, control), valid);
  }

  // Mean of max(0, threshold - made heel speed) over the (heel, step) pairs where the real heel
  // has lifted (moves at the planted threshold, planted_mps or the speed-scaled one, or faster):
  // how far below that threshold a made heel lingers where the data's has left the ground (valid
  // as above). The complement of mean_planted_speed: together they charge a contact that starts
  // late or ends late on either side, and nothing in the swing. A scalar, differentiable in made; 0 when nothing has lifted.
  torch::Tensor mean_lingering_speed(const HeelSpeeds& speeds, const torch::Tensor& valid = {}) const;
  torch::Tensor mean_lingering_speed(const torch::Tensor& made, const torch::Tensor& real, const torch::Tensor& control,
                                     const torch::Tensor& valid = {}) const {
    return mean_lingering_speed(speeds(made, real, control), valid);
  }

  // The phase-free stance term: over every run of `window` consecutive steps (each heel, sliding by
  // one step) in which the real heel is planted at least once, max(0, the made heel's slowest
  // speed in the run minus the planted threshold), averaged (m/s). A made heel that stops once in
  // each such run costs nothing, whatever its phase; one that glides through a stride, as the fast
  // runs' heels do once drawn free for a second or two, costs its glide. The speeds are [B, n, 2]
  // as from speeds() (steps of one sequence along dim 1); valid (optional [B, n]) leaves out every
  // run holding a padded step. A scalar, differentiable in made (through each run's slowest step);
  // 0 when no run counts (n < window included). Throws mosyn::Error when window < 1.
  // relative_to_data: the bar of each run is the real heel's slowest speed in the same run instead
  // of the planted threshold, so a heel that creeps just under the threshold through its stance
  // (0.1-0.15 m/s: MoGlow's drawn paths slid so) pays the difference from the data's plant.
  torch::Tensor mean_missed_stance(const HeelSpeeds& speeds, int64_t window, const torch::Tensor& valid = {},
                                   bool relative_to_data = false) const;

  // The phase-free lingering term, the stance term's counterpart: over the same runs (each heel,
  // `window` consecutive steps in which the real heel plants at least once), the share of the run's
  // steps in which the made heel is slower than a level, minus the real heel's share, where
  // positive; summed over the levels kSlowLevels x the planted threshold (0.15, 0.3, 0.6 m/s: a
  // walk's plant, a run's plant at 20 fps) and averaged over the runs (a fraction per level). A
  // share is soft for the made heel (a sigmoid of (level - speed) over kSlowSoftness x level), hard
  // for the real one. Why: a term that charges only each run's slowest step is met as
  // well by a long stance as by a short one, and MoGlow's drawn walks held each contact a third
  // longer than the takes. speeds and valid as mean_missed_stance. A scalar, differentiable in made; 0 when no
  // run counts. Throws mosyn::Error when window < 1.
  static constexpr double kSlowLevels[] = {1.0, 2.0, 4.0};
  static constexpr double kSlowSoftness = 0.2;
  torch::Tensor mean_excess_slow_share(const HeelSpeeds& speeds, int64_t window, const torch::Tensor& valid = {}) const;

  // The phase-free speed-distribution term: per row and joint, the made and the real heel's speeds
  // over the row's valid steps, each clamped at cap_mps and sorted, compared pair by pair: the mean
  // absolute difference (m/s; the 1-D Wasserstein distance between the two distributions of
  // speeds below the cap), averaged over rows and joints (toes at toe_weight). It asks the made
  // heel to be as slow as the data's for as many steps, wherever in the run they fall: a heel that
  // glides where the data's stands pays, and so does one that stays slow for longer than the
  // data's; the swing (above the cap) costs nothing. Why: the phase-locked planted
  // term, met under an uncertain phase by holding the heel down over a wider span, made MoGlow's
  // drawn contacts last a fifth to a quarter longer than the takes'. speeds [B, n, K] as from
  // speeds() (steps of one sequence along dim 1); valid (optional [B, n], 0/1) leaves steps out.
  // With cap_speed_fraction f > 0 each step's cap is max(cap_mps, f x speeds.root_mps) instead, the
  // same for the made and the real heel: a running heel's stance at 20 fps spans speeds a walk's
  // swing reaches (at a fixed 0.6 m/s MoGlow's drawn runs' stances softened, v_tol95 1.7x the
  // takes'). A scalar, differentiable in made; 0 when no step is valid. Throws mosyn::Error when
  // cap_mps <= 0, cap_speed_fraction < 0, or f > 0 without speeds.root_mps.
  static constexpr double kSpeedDistributionCapMps = 0.6;
  torch::Tensor mean_sorted_speed_error(const HeelSpeeds& speeds, const torch::Tensor& valid = {},
                                        double cap_mps = kSpeedDistributionCapMps,
                                        double cap_speed_fraction = 0.0) const;

  // Mean horizontal distance (m) between the made and the real pelvis (BodyPoints::pelvis_point; x
  // and z, relative to the root's floor point and heading) over the frames of made, real [B, n, D]
  // (standardised; frame i of one is frame i of the other); valid (optional [B, n], 0/1) leaves
  // frames out. Drawn free, a body that falls behind its root shows here as a
  // growing distance. A scalar, differentiable in made; 0 when no frame is valid.
  torch::Tensor mean_pelvis_offset_m(const torch::Tensor& made, const torch::Tensor& real,
                                     const torch::Tensor& valid = {}) const;

  // The toe slide: the independent check's foot skating (../shared/checks) as a cost. Over every
  // (toe, step t-1 -> t) of a sequence, a toe low at frame t-1 (within kLowToeM of its floor: its
  // lowest height over the sequence) that moves faster than kSlideMps counts max(0, speed -
  // kSlideMps), weighted by how low it is (a sigmoid of floor + kLowToeM - height over
  // kLowSoftnessM). The weight is not differentiated: the gradient slows a low toe and never lifts
  // it (a term that could lift toes made MoGlow's feet hover). frames [B, T, D] and control
  // [B, T, C] standardised, one sequence per row (the control of frame t is the root's step into
  // it); valid (optional [B, T-1], 0/1) leaves steps out. Throws mosyn::Error when the skeleton has
  // no joint below an ankle.
  static constexpr double kLowToeM = 0.01, kSlideMps = 0.10, kLowSoftnessM = 0.003;
  // Each row's mean over its (toe, step) pairs (m/s), [B]; 0 for a row with no valid step.
  torch::Tensor toe_slide_per_row(const torch::Tensor& frames, const torch::Tensor& control,
                                  const torch::Tensor& valid = {}) const;
  // The mean of toe_slide_per_row over the rows (m/s), a scalar.
  torch::Tensor mean_toe_slide(const torch::Tensor& frames, const torch::Tensor& control,
                               const torch::Tensor& valid = {}) const;
  // The toe-slide term: per row, how much more the made toes slide than the real ones of the same
  // window (max(0, made - real) of toe_slide_per_row; real toes slide too, about a tenth of the
  // frames of a Bandai-Namco walk), averaged over rows (m/s). Charging all of it pushed MoGlow
  // off the data and wrecked the gait within 100 steps. made, real [B, T, D] with their controls
  // as speeds(); rows whose valid steps are all 0 are left out of the mean (0 when no row has one).
  torch::Tensor mean_excess_toe_slide(const torch::Tensor& made, const torch::Tensor& made_control,
                                      const torch::Tensor& real, const torch::Tensor& real_control,
                                      const torch::Tensor& valid) const;
  torch::Tensor mean_excess_toe_slide(const torch::Tensor& made, const torch::Tensor& real,
                                      const torch::Tensor& control, const torch::Tensor& valid = {}) const {
    return mean_excess_toe_slide(made, control, real, control, valid);
  }

  // Mean absolute difference (m) between the lengths of the body's rigid pairs in made [B, T, D]
  // (standardised) and their rest lengths (BodyPoints::pair_lengths_m: bones of the positions form,
  // same-bone marker pairs of the markers form) over every (pair, frame); valid (optional [B, T],
  // 0/1) leaves frames out. A model of joint positions is free to stretch a bone, and a stretched
  // leg lets a foot stay put while the body moves on. A scalar, differentiable in made; 0 when no
  // frame is valid. Throws mosyn::Error when the form has no pairs (rotations).
  torch::Tensor mean_bone_length_error_m(const torch::Tensor& made, const torch::Tensor& valid = {}) const;

  // The points read, as BodyPoints indices: the heels, then the toes with with_toes.
  const std::vector<int>& heels() const { return heels_; }
  const std::vector<int>& toes() const { return toes_; }  // empty when the body has none
  const BodyPoints& body() const { return body_; }
  double fps() const { return fps_; }

 private:
  // Standardised pose [B, T, D] -> the points' positions [B, T, 3 P] in metres (3k..3k+2: point k);
  // standardised control [.., C] -> raw, in opts.
  torch::Tensor positions_m(const torch::Tensor& pose) const;
  torch::Tensor raw_control(const torch::Tensor& control, const torch::TensorOptions& opts) const;
  // speeds.planted_below_mps, or planted_mps_ as a scalar where it is undefined.
  torch::Tensor planted_threshold(const HeelSpeeds& speeds) const;

  BodyPoints body_;
  std::vector<int> heels_;
  std::vector<int> toes_;
  double fps_ = 30.0;
  double planted_mps_ = kDefaultPlantedMps;
  double planted_speed_fraction_ = 0.0;
  torch::Tensor joint_weight_;  // [K] of the joints read (1 a heel, toe_weight a toe); undefined: all 1
  torch::Tensor control_mean_, control_std_;  // [C], [C]
};

}  // namespace mosyn::nn
