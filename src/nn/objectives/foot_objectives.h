// The training objectives every family shares on its made motion (beyond the papers): planted feet
// stay planted, heels move at the data's speeds and lift off when the data's do, toes do not slide,
// the pelvis follows the root, bones keep their lengths. A likelihood, an ELBO or a feature-space
// reconstruction per feature barely notices a foot that glides a few millimetres a frame; drawn
// free, the families without these terms skated 5-6x as much as real walks (hvrnn, DFN, MOJO on
// Bandai-Namco) while the two that had them (MoGlow, the recurrent VAE) walked like the takes.
// src/nn/objectives/README.md gives each term's measurement.
//
// Three parts:
//   FootObjectiveOptions  the weights and thresholds, with one field list (foot_objective_fields)
//                         that each family's own list includes (OptionFields::include), so the
//                         JSON keys sit at the top level of every family's model config;
//   FootTerms             the terms themselves on standardised poses (foot_terms.h), through
//                         BodyPoints (body_points.h): any pose form whose poses give joint
//                         positions (positions; markers; rotations after forward kinematics);
//   FootObjectives        the one call a family makes on its made and real windows (below).
#pragma once

#include <torch/types.h>

#include <map>
#include <string>
#include <vector>

#include "nn/context.h"
#include "nn/model.h"
#include "nn/objectives/foot_terms.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

// The weights (0 = off, every default) and thresholds of the shared terms. JSON keys are the
// member names; a family's config writes each only when it differs from its default, so configs
// of runs made before a term existed stay byte-identical. Where a term comes from:
// src/nn/objectives/README.md.
struct FootObjectiveOptions {
  // Planted heels stay planted: FootTerms::mean_planted_speed, the made heels' ground speed (m/s)
  // where the data's heels are planted. Logged as planted_heel_mps.
  double foot_contact_weight = 0.0;
  // Heel speeds match the data's on every step: FootTerms::mean_speed_error (m/s). Also charges a
  // made heel that lingers slow into the data's swing (contacts too long: steps 1.5x real).
  // Logged as heel_speed_error_mps.
  double heel_speed_weight = 0.0;
  // Lift-off: FootTerms::mean_lingering_speed, how far below the planted threshold a made heel
  // stays where the data's has lifted (contacts at 0.15 m/s lasted 0.40 s in MoGlow's walks against
  // the takes' 0.32). Logged as lingering_heel_mps.
  double lift_off_weight = 0.0;
  // The windows the lift-off term reads, "CONTENT:STYLE" patterns (nn/label_pattern.h; "*" = any);
  // empty = every window. Needs the context's vocabularies (a dataset or run).
  std::vector<std::string> lift_off_labels;
  // {"CONTENT:STYLE": factor}: each window's weight in the means of the heel, stance and pelvis
  // terms (the product of the factors of every pattern it matches; 1 where none does; 0 leaves it
  // out). The toe-slide term, a mean of per-window means, is unweighted.
  std::map<std::string, double> heel_label_weights;
  // The pelvis follows the root: FootTerms::mean_pelvis_offset_m, the horizontal distance (m)
  // between the made and the data's pelvis relative to the root (held-out runs at 3.3 m/s drawn
  // free: the body made 1.7 m/s behind its root). Logged as pelvis_offset_m.
  double pelvis_follow_weight = 0.0;
  // A data heel slower than this (m/s) is planted. Real heels roll at 0.1-0.15 m/s at the ends of
  // a stance, swinging feet move metres per second.
  double planted_mps = kDefaultPlantedMps;
  // f > 0: the planted threshold is max(planted_mps, f x the root's ground speed): a running heel at
  // 20 fps seldom falls under 0.15 m/s for more than one frame.
  double planted_speed_fraction = 0.0;
  // The phase-free stance term: FootTerms::mean_missed_stance over runs of stance_window_s, each
  // made heel must stop once in every run in which the data's heel plants, at any phase.
  // Logged as missed_stance_mps.
  double stance_weight = 0.0;
  double stance_window_s = 1.0;  // longer than a stride of the slowest gait the data holds
  // The stance term's bar in each run: the data heel's slowest speed there instead of the planted
  // threshold (drawn stance feet crept at 0.1-0.15 m/s, under the threshold, where real planted
  // heels stop at 0.06-0.07 m/s).
  bool stance_relative = false;
  // FootTerms::mean_excess_slow_share on the stance term's runs: how much more of each run a made
  // heel spends slow than the data's. Logged as excess_slow_share. Measured on MoGlow at weight 1:
  // the heels left the slow band by sliding, not lifting; kept for further work.
  double slow_share_weight = 0.0;
  // The phase-free speed distribution: FootTerms::mean_sorted_speed_error, the made and the data
  // heels' speeds clamped at the cap and sorted, compared pair by pair (m/s). Charges a gliding
  // stance and a stance held longer than the data's alike. Logged as speed_distribution_mps.
  double speed_distribution_weight = 0.0;
  double speed_distribution_cap_mps = FootTerms::kSpeedDistributionCapMps;
  // Each step's cap is max(speed_distribution_cap_mps, this x the root's ground speed); 0 = fixed.
  double speed_distribution_cap_fraction = 0.0;
  // The heel terms (planted, speed error, lift-off, stance, slow share, speed distribution) also
  // read the toes (each ankle's first child joint; the toe markers), each at toe_term_weight
  // against a heel's 1: continued training moved MoGlow's slide from the heels to the toes.
  bool toe_terms = false;
  double toe_term_weight = 1.0;
  // Toes do not slide: FootTerms::mean_excess_toe_slide, the independent check's foot skating (a
  // toe within 1 cm of its floor moving faster than 0.1 m/s counts the excess) as a cost, what each
  // window's made toes slide more than the data's. Logged as toe_slide_mps.
  double toe_slide_weight = 0.0;
  // The toe-slide term reads only the steps where the data's root moves slower than this (m/s):
  // stops, starts and standing, where continued training brought the slide; 0 = every step.
  double toe_slide_below_root_mps = 0.0;
  // Bones keep their lengths (positions and markers forms; rotations keep them by construction):
  // FootTerms::mean_bone_length_error_m, the mean |made - rest| length (m) of every bone (joint
  // positions) or of every pair of markers carried by one bone. Logged as bone_length_error_m.
  double bone_length_weight = 0.0;

  // Whether any term is on (any weight above 0).
  bool any_on() const {
    return foot_contact_weight > 0 || heel_speed_weight > 0 || lift_off_weight > 0 || pelvis_follow_weight > 0 ||
           stance_weight > 0 || slow_share_weight > 0 || toe_slide_weight > 0 || speed_distribution_weight > 0 ||
           bone_length_weight > 0;
  }
  // The options FootTerms is built with.
  FootTermOptions term_options() const;
};

// The shared fields: every key above with its check, written only off its default. A family's
// list takes them with .include(&Options::foot, foot_objective_fields()).
const OptionFields<FootObjectiveOptions>& foot_objective_fields();

// The terms a family adds to its training loss, in one call. Build it once per model (with the
// model's context and its options' FootObjectiveOptions); off (on() false) when no weight is on.
class FootObjectives {
 public:
  FootObjectives() = default;
  // family names the caller in errors. Throws mosyn::Error when a term is on and the context cannot
  // give its points (FootTerms), or lift_off_labels / heel_label_weights name unknown labels.
  FootObjectives(const ModelContext& context, const FootObjectiveOptions& options, const std::string& family);

  bool on() const { return options_.any_on(); }
  const FootObjectiveOptions& options() const { return options_; }
  const FootTerms& terms() const { return terms_; }

  // A window the terms compare, all standardised and frame for frame: made [B, T, D] with the root
  // steps made_control [B, T, C] that go with it (a family that generates its root passes its own;
  // one that takes the root as input, the data's), real and real_control the data's. valid
  // (optional [B, T], 0/1) marks the frames to read; a step counts when both its frames do.
  // content, style ([B] int64, optional): the windows' labels, for lift_off_labels and
  // heel_label_weights.
  struct Window {
    torch::Tensor made, made_control, real, real_control, valid, content, style;
  };
  // Adds every term whose weight is on, times its weight, to *loss when training (so a validation
  // loss stays the family's own objective, comparable across runs), and logs each term (detached)
  // in out->terms under its name (FootObjectiveOptions). Nothing when off or T < 2.
  void add(const Window& window, bool training, torch::Tensor* loss, LossTerms* out) const;

  // Per window [B] in `options`: heel_label_weights' factor and lift_off_labels' 0/1 (ones where
  // the option is empty), for families that weigh their own draws (MoGlow).
  torch::Tensor heel_weight_rows(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                                 const torch::TensorOptions& options) const;
  torch::Tensor lift_off_rows(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                              const torch::TensorOptions& options) const;

 private:
  FootObjectiveOptions options_;
  FootTerms terms_;
  double fps_ = 30.0;
  torch::Tensor heel_weight_table_, lift_off_table_;  // undefined: every window 1
};

}  // namespace mosyn::nn
