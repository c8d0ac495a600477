#include "nn/objectives/draw_objectives.h"

#include <cmath>

#include "core/error.h"

namespace mosyn::nn {

FootObjectiveOptions DrawObjectiveOptions::foot(const FootObjectiveOptions& thresholds) const {
  FootObjectiveOptions o = thresholds;
  o.foot_contact_weight = o.heel_speed_weight = o.lift_off_weight = o.pelvis_follow_weight = 0;
  o.slow_share_weight = o.bone_length_weight = 0;
  o.stance_weight = draw_stance_weight;
  o.speed_distribution_weight = draw_speed_distribution_weight;
  o.toe_slide_weight = draw_toe_slide_weight;
  return o;
}

const OptionFields<DrawObjectiveOptions>& draw_objective_fields() {
  using O = DrawObjectiveOptions;
  static const auto fields =
      OptionFields<O>("draw objectives")
          .field("draw_stance_weight", &O::draw_stance_weight, "training: phase-free stance term on free draws",
                 at_least(0.0))
          .written_if([](const O& o) { return o.draw_stance_weight > 0; })
          .field("draw_speed_distribution_weight", &O::draw_speed_distribution_weight,
                 "training: heel speed-distribution term on free draws", at_least(0.0))
          .written_if([](const O& o) { return o.draw_speed_distribution_weight > 0; })
          .field("draw_toe_slide_weight", &O::draw_toe_slide_weight, "training: toe-slide term on free draws",
                 at_least(0.0))
          .written_if([](const O& o) { return o.draw_toe_slide_weight > 0; })
          .field("draw_speed_weight", &O::draw_speed_weight,
                 "training: root-speed term (squared log ratio to the data window's) on free draws", at_least(0.0))
          .written_if([](const O& o) { return o.draw_speed_weight > 0; })
          .field("draw_speed_tolerance", &O::draw_speed_tolerance,
                 "training: speed ratio the draw term leaves unpenalised (>= 1)", at_least(1.0))
          .written_if([](const O& o) { return o.draw_speed_tolerance != 1.0; });
  return fields;
}

torch::Tensor speed_ratio_excess(const torch::Tensor& made_mps, const torch::Tensor& real_mps, double tolerance,
                                 double floor_mps) {
  if (!(tolerance >= 1.0)) throw Error("speed_ratio_excess: tolerance must be >= 1");
  const double band = std::log(tolerance);
  return torch::relu((torch::log(made_mps + floor_mps) - torch::log(real_mps + floor_mps)).abs() - band).pow(2);
}

DrawObjectives::DrawObjectives(const ModelContext& context, const DrawObjectiveOptions& options,
                               const FootObjectiveOptions& thresholds, const std::string& family)
    : options_(options) {
  if (!options.any_on()) return;
  foot_ = FootObjectives(context, options.foot(thresholds), family);
  // The speed term reads root speeds through the foot terms' FootTerms when they are on.
  if (options.draw_speed_weight > 0 && !options.foot_on())
    speed_terms_ = FootTerms(context, family, thresholds.term_options());
}

void DrawObjectives::add(const FootObjectives::Window& w, bool training, torch::Tensor* loss, LossTerms* out) const {
  if (!on() || w.made.size(1) < 2) return;
  LossTerms foot;
  foot_.add(w, training, loss, &foot);
  for (const auto& [name, value] : foot.terms) out->terms["draw_" + name] = value;
  if (options_.draw_speed_weight <= 0) return;
  const FootTerms& terms = foot_.on() ? foot_.terms() : speed_terms_;
  const auto made = terms.root_mps(w.made_control);  // [B, T-1]
  torch::Tensor real;
  {
    torch::NoGradGuard no_grad;
    real = terms.root_mps(w.real_control.to(w.made.options()));
  }
  // The steps whose two frames are both read (every step without valid).
  torch::Tensor steps = torch::ones_like(made);
  if (w.valid.defined()) {
    const auto v = w.valid.to(w.made.options());
    steps = v.narrow(1, 1, v.size(1) - 1) * v.narrow(1, 0, v.size(1) - 1);
  }
  const auto count = steps.sum(1).clamp_min(1.0);
  const auto made_mean = (made * steps).sum(1) / count, real_mean = (real * steps).sum(1) / count;
  const auto term = speed_ratio_excess(made_mean, real_mean, options_.draw_speed_tolerance).mean();
  if (training) *loss = *loss + options_.draw_speed_weight * term;
  out->terms["draw_speed"] = term.detach();
  out->terms["draw_root_mps"] = made_mean.mean().detach();
  out->terms["real_root_mps"] = real_mean.mean().detach();
}

}  // namespace mosyn::nn
