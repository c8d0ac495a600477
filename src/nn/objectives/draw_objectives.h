// Objectives on a family's free draws: motion generated from its priors, as at sampling, rather
// than decoded from a posterior's codes or teacher-forced. The foot terms on reconstructions
// (foot_objectives.h) reach a latent model's decoder, not the priors its samples come from: DFN
// continued 750 steps with them still skated 4.4x the held-out takes, MOJO 3.5x
// (docs/experiments.md). On a draw the footsteps need not fall where the data's do, so only the
// phase-free terms apply (stance, speed distribution, toe slide), and a speed term holds the
// draw's root speed to the data window it stands for: without it the cheapest way not to slide
// is not to walk (DFN's open-loop draws fell to 0.04 of the takes' pelvis speed).
#pragma once

#include <torch/types.h>

#include <string>

#include "nn/context.h"
#include "nn/model.h"
#include "nn/objectives/foot_objectives.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

// The weights (0 = off, every default) of the terms on free draws. JSON keys are the member names,
// written only off their defaults.
struct DrawObjectiveOptions {
  // The phase-free foot terms of FootObjectiveOptions (stance_weight, speed_distribution_weight,
  // toe_slide_weight) on the draw, with the thresholds of the family's FootObjectiveOptions.
  double draw_stance_weight = 0.0;
  double draw_speed_distribution_weight = 0.0;
  double draw_toe_slide_weight = 0.0;
  // The root-speed term: draw_speed_weight x mean over windows of
  // max(0, |log(made + e) - log(real + e)| - log(draw_speed_tolerance))^2, made / real the draw's
  // and the data window's mean root ground speed (m/s), e = kDrawSpeedFloorMps (a standing window
  // neither explodes the ratio nor asks for exact zero). A moment of the motion, not a pose: it does
  // not pull draws to the data's poses, only keeps them moving as fast as the data moves.
  double draw_speed_weight = 0.0;
  double draw_speed_tolerance = 1.0;  // ratio (>= 1) left unpenalised

  bool foot_on() const {
    return draw_stance_weight > 0 || draw_speed_distribution_weight > 0 || draw_toe_slide_weight > 0;
  }
  bool any_on() const { return foot_on() || draw_speed_weight > 0; }
  // `thresholds` (a family's foot options) with every weight off but the three draw weights above.
  FootObjectiveOptions foot(const FootObjectiveOptions& thresholds) const;
};

// The floor added to both speeds of the speed term (m/s).
constexpr double kDrawSpeedFloorMps = 0.05;

// The shared fields; a family's list takes them with .include(&Options::draw, draw_objective_fields()).
const OptionFields<DrawObjectiveOptions>& draw_objective_fields();

// Elementwise max(0, |log(made + floor) - log(real + floor)| - log(tolerance))^2 of two speeds (m/s,
// same shape): the speed term of one window. tolerance >= 1.
torch::Tensor speed_ratio_excess(const torch::Tensor& made_mps, const torch::Tensor& real_mps, double tolerance,
                                 double floor_mps = kDrawSpeedFloorMps);

// The terms a family adds for its free draws, in one call. Build once per model.
class DrawObjectives {
 public:
  DrawObjectives() = default;
  // thresholds: the family's FootObjectiveOptions (planted threshold, caps, toe options). Throws
  // mosyn::Error as FootObjectives does when a term is on and the context cannot give its points.
  DrawObjectives(const ModelContext& context, const DrawObjectiveOptions& options,
                 const FootObjectiveOptions& thresholds, const std::string& family);

  bool on() const { return options_.any_on(); }
  const DrawObjectiveOptions& options() const { return options_; }

  // window: the draw as FootObjectives::Window's made side (standardised [B, T, D] poses with the
  // root steps the draw made, [B, T, C]), the data window it stands for as the real side. Adds
  // every term that is on, times its weight, to *loss when training; logs each in out->terms as
  // "draw_" + the foot term's name, "draw_speed", "draw_root_mps" and "real_root_mps".
  void add(const FootObjectives::Window& window, bool training, torch::Tensor* loss, LossTerms* out) const;

 private:
  DrawObjectiveOptions options_;
  FootObjectives foot_;  // the three phase-free terms
  FootTerms speed_terms_;  // root speeds (FootTerms::root_mps) when foot_ is off
};

}  // namespace mosyn::nn
