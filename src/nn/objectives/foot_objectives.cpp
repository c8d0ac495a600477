#include "nn/objectives/foot_objectives.h"

#include <cmath>
#include <tuple>

#include "core/error.h"
#include "nn/label_features.h"
#include "nn/label_pattern.h"

namespace mosyn::nn {

FootTermOptions FootObjectiveOptions::term_options() const {
  FootTermOptions o;
  o.planted_mps = planted_mps;
  o.planted_speed_fraction = planted_speed_fraction;
  o.with_toes = toe_terms;
  o.toe_weight = toe_term_weight;
  o.toe_slide = toe_slide_weight > 0;
  o.bone_lengths = bone_length_weight > 0;
  return o;
}

namespace {

using O = FootObjectiveOptions;

// The heel terms' weights and the windows they read.
OptionFields<O> heel_fields(OptionFields<O>&& fields) {
  return std::move(fields)
      .field("foot_contact_weight", &O::foot_contact_weight, "training: weight of the planted-heel speed term",
             at_least(0.0))
      .written_if([](const O& o) { return o.foot_contact_weight > 0; })
      .field("heel_speed_weight", &O::heel_speed_weight, "training: weight of the heel-speed error", at_least(0.0))
      .written_if([](const O& o) { return o.heel_speed_weight > 0; })
      .field("lift_off_weight", &O::lift_off_weight, "training: weight of the lingering-heel (lift-off) term",
             at_least(0.0))
      .written_if([](const O& o) { return o.lift_off_weight > 0; })
      .field("lift_off_labels", &O::lift_off_labels,
             "training: the windows (CONTENT:STYLE patterns, * = any) the lingering-heel term reads; empty = all")
      .written_if([](const O& o) { return !o.lift_off_labels.empty(); })
      .rule([](const O& o) {
        for (const std::string& key : o.lift_off_labels)
          if (std::string problem = label_pattern_problem(key, "lift_off_labels"); !problem.empty()) return problem;
        return std::string();
      })
      .field("heel_label_weights", &O::heel_label_weights,
             "training: {\"CONTENT:STYLE\": factor} weights of the windows in the heel and pelvis terms")
      .written_if([](const O& o) { return !o.heel_label_weights.empty(); })
      .rule([](const O& o) {
        for (const auto& [key, factor] : o.heel_label_weights)
          if (std::string problem = label_factor_problem(key, factor, "heel_label_weights", /*zero_allowed=*/true);
              !problem.empty())
            return problem;
        return std::string();
      })
      .field("pelvis_follow_weight", &O::pelvis_follow_weight, "training: weight of the pelvis-offset term",
             at_least(0.0))
      .written_if([](const O& o) { return o.pelvis_follow_weight > 0; })
      .field("planted_mps", &O::planted_mps, "training: heel terms' planted threshold (m/s)", above_up_to(0.0, 1.0))
      .written_if([](const O& o) { return o.planted_mps != kDefaultPlantedMps; })
      .field("planted_speed_fraction", &O::planted_speed_fraction,
             "training: heel terms' planted threshold max(planted_mps, this x root speed); 0 = planted_mps", at_least(0.0))
      .written_if([](const O& o) { return o.planted_speed_fraction > 0; });
}

// The phase-free terms (stance, slow share, speed distribution).
OptionFields<O> phase_free_fields(OptionFields<O>&& fields) {
  return std::move(fields)
      .field("stance_weight", &O::stance_weight, "training: weight of the phase-free stance term", at_least(0.0))
      .written_if([](const O& o) { return o.stance_weight > 0; })
      .field("stance_window_s", &O::stance_window_s, "training: the stance term's run of steps, seconds",
             at_least(0.05))
      .written_if([](const O& o) { return o.stance_weight > 0 || o.slow_share_weight > 0; })
      .field("slow_share_weight", &O::slow_share_weight, "training: weight of the slow-share term on the stance runs",
             at_least(0.0))
      .written_if([](const O& o) { return o.slow_share_weight > 0; })
      .field("speed_distribution_weight", &O::speed_distribution_weight,
             "training: weight of the phase-free speed-distribution term", at_least(0.0))
      .written_if([](const O& o) { return o.speed_distribution_weight > 0; })
      .field("speed_distribution_cap_mps", &O::speed_distribution_cap_mps,
             "training: the speed-distribution term's cap (m/s): faster steps count as this", above_up_to(0.0, 10.0))
      .written_if([](const O& o) { return o.speed_distribution_cap_mps != FootTerms::kSpeedDistributionCapMps; })
      .field("speed_distribution_cap_fraction", &O::speed_distribution_cap_fraction,
             "training: the speed-distribution term's cap max(cap_mps, this x root speed); 0 = cap_mps", at_least(0.0))
      .written_if([](const O& o) { return o.speed_distribution_cap_fraction > 0; })
      .field("stance_relative", &O::stance_relative,
             "training: the stance term's bar is the data heel's slowest speed in each run, not the planted threshold")
      .written_if([](const O& o) { return o.stance_relative; });
}

// The toe terms and the bone lengths.
OptionFields<O> toe_and_bone_fields(OptionFields<O>&& fields) {
  return std::move(fields)
      .field("toe_terms", &O::toe_terms, "training: the heel terms also read the toes")
      .written_if([](const O& o) { return o.toe_terms; })
      .field("toe_term_weight", &O::toe_term_weight, "training: each toe's weight in the heel terms (a heel's is 1)",
             above_up_to(0.0, 1.0))
      .written_if([](const O& o) { return o.toe_term_weight != 1.0; })
      .rule([](const O& o) -> std::string {
        return o.toe_term_weight != 1.0 && !o.toe_terms ? "toe_term_weight needs toe_terms" : "";
      })
      .field("toe_slide_weight", &O::toe_slide_weight, "training: weight of the toe-slide term", at_least(0.0))
      .written_if([](const O& o) { return o.toe_slide_weight > 0; })
      .field("toe_slide_below_root_mps", &O::toe_slide_below_root_mps,
             "training: the toe-slide term reads steps where the data's root is slower (m/s); 0 = all", at_least(0.0))
      .written_if([](const O& o) { return o.toe_slide_below_root_mps > 0; })
      .rule([](const O& o) -> std::string {
        return o.toe_slide_below_root_mps > 0 && o.toe_slide_weight <= 0
                   ? "toe_slide_below_root_mps needs toe_slide_weight > 0"
                   : "";
      })
      .field("bone_length_weight", &O::bone_length_weight,
             "training: weight of the bone-length term (positions and markers forms)", at_least(0.0))
      .written_if([](const O& o) { return o.bone_length_weight > 0; });
}

}  // namespace

const OptionFields<FootObjectiveOptions>& foot_objective_fields() {
  static const auto fields = toe_and_bone_fields(phase_free_fields(heel_fields(OptionFields<O>("foot objectives"))));
  return fields;
}

FootObjectives::FootObjectives(const ModelContext& context, const FootObjectiveOptions& options,
                               const std::string& family)
    : options_(options), fps_(context.fps) {
  if (!options.any_on()) return;
  terms_ = FootTerms(context, family, options.term_options());
  if (!options.heel_label_weights.empty())
    heel_weight_table_ = label_weight_table(options.heel_label_weights, context.content_labels, context.style_labels,
                                            context.num_content, context.num_style,
                                            family + " config: heel_label_weights");
  if (!options.lift_off_labels.empty())
    lift_off_table_ = label_pattern_table(options.lift_off_labels, context.content_labels, context.style_labels,
                                          context.num_content, context.num_style, family + " config: lift_off_labels");
}

namespace {

// [B] in `options`: table's entry for each window's labels; ones without a table.
torch::Tensor table_rows(const torch::Tensor& table, const torch::Tensor& content, const torch::Tensor& style,
                         int64_t batch, const torch::TensorOptions& options) {
  if (!table.defined()) return torch::ones({batch}, options);
  return label_table_rows(table.to(options.device()), content, style, batch).to(options);
}

}  // namespace

torch::Tensor FootObjectives::heel_weight_rows(const torch::Tensor& content, const torch::Tensor& style,
                                               int64_t batch, const torch::TensorOptions& options) const {
  return table_rows(heel_weight_table_, content, style, batch, options);
}

torch::Tensor FootObjectives::lift_off_rows(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                                            const torch::TensorOptions& options) const {
  return table_rows(lift_off_table_, content, style, batch, options);
}

void FootObjectives::add(const Window& w, bool training, torch::Tensor* loss, LossTerms* out) const {
  if (!on() || w.made.size(1) < 2) return;
  const auto& o = options_;
  const auto opts = w.made.options();
  const int64_t b = w.made.size(0), t = w.made.size(1);
  const auto frames = w.valid.defined() ? w.valid.to(opts) : torch::ones({b, t}, opts);
  const auto steps = frames.narrow(1, 1, t - 1) * frames.narrow(1, 0, t - 1);  // [B, T-1]
  const auto heel_rows = heel_weight_rows(w.content, w.style, b, opts).view({b, 1});
  const auto weighted_steps = steps * heel_rows, weighted_frames = frames * heel_rows;
  const auto speeds = terms_.speeds(w.made, w.made_control, w.real, w.real_control);  // once for every term
  std::vector<std::tuple<torch::Tensor, double, const char*>> added;
  if (o.foot_contact_weight > 0)
    added.emplace_back(terms_.mean_planted_speed(speeds, weighted_steps), o.foot_contact_weight, "planted_heel_mps");
  if (o.heel_speed_weight > 0)
    added.emplace_back(terms_.mean_speed_error(speeds, weighted_steps), o.heel_speed_weight, "heel_speed_error_mps");
  if (o.lift_off_weight > 0) {
    const auto rows = lift_off_rows(w.content, w.style, b, opts).view({b, 1});
    added.emplace_back(terms_.mean_lingering_speed(speeds, weighted_steps * rows), o.lift_off_weight,
                       "lingering_heel_mps");
  }
  const auto window = std::max<int64_t>(1, std::lround(o.stance_window_s * fps_));
  if (o.stance_weight > 0)
    added.emplace_back(terms_.mean_missed_stance(speeds, window, weighted_steps, o.stance_relative), o.stance_weight,
                       "missed_stance_mps");
  if (o.slow_share_weight > 0)
    added.emplace_back(terms_.mean_excess_slow_share(speeds, window, weighted_steps), o.slow_share_weight,
                       "excess_slow_share");
  if (o.speed_distribution_weight > 0)
    added.emplace_back(terms_.mean_sorted_speed_error(speeds, weighted_steps, o.speed_distribution_cap_mps,
                                                      o.speed_distribution_cap_fraction),
                       o.speed_distribution_weight, "speed_distribution_mps");
  if (o.toe_slide_weight > 0) {
    auto toe_steps = steps;
    if (o.toe_slide_below_root_mps > 0)
      toe_steps = toe_steps * (speeds.root_mps.squeeze(-1) < o.toe_slide_below_root_mps).to(opts);
    added.emplace_back(terms_.mean_excess_toe_slide(w.made, w.made_control, w.real, w.real_control, toe_steps),
                       o.toe_slide_weight, "toe_slide_mps");
  }
  if (o.pelvis_follow_weight > 0)
    added.emplace_back(terms_.mean_pelvis_offset_m(w.made, w.real, weighted_frames), o.pelvis_follow_weight,
                       "pelvis_offset_m");
  if (o.bone_length_weight > 0)
    added.emplace_back(terms_.mean_bone_length_error_m(w.made, frames), o.bone_length_weight, "bone_length_error_m");
  for (const auto& [term, weight, name] : added) {
    if (training) *loss = *loss + weight * term;
    out->terms[name] = term.detach();
  }
}

}  // namespace mosyn::nn
