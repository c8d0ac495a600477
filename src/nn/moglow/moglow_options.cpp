// MoGlow's options (MoGlowOptions): the JSON keys, their checks and the presets.
#include <string>

#include "core/error.h"
#include "nn/moglow/moglow.h"
#include "nn/objectives/foot_objectives.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

namespace {

// The paper's data dropout on the pose history: 0.95 for joint positions (Sec. 4.1), which carry
// the motion's state redundantly; 0.6 for rotations, which do not.
double default_dropout(data::PoseForm form) {
  switch (form) {
    case data::PoseForm::kRotations: return 0.6;
    case data::PoseForm::kPositions: return 0.95;
    case data::PoseForm::kMarkers: return 0.95;  // positions of surface points: as joint positions
  }
  throw Error("moglow: invalid pose form");
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Options

namespace {

// Look-ahead offsets: at most 16, each at most 1000 frames (entries >= 1 is checked on reading).
std::string lookahead_problem(const MoGlowOptions& o) {
  if (o.lookahead.size() > 16) return "at most 16 look-ahead offsets";
  for (int k : o.lookahead)
    if (k > 1000) return "look-ahead offsets must be at most 1000 frames";
  if (o.predicted_lookahead > 0 && o.lookahead.empty()) return "predicted_lookahead needs look-ahead offsets";
  return "";
}

// The shared foot objectives (nn/objectives/foot_objectives.h) and how MoGlow draws the frames they
// read: free-running or teacher-forced draws, their temperature, the phase-locked span, cold starts.
OptionFields<MoGlowOptions> with_foot_terms(OptionFields<MoGlowOptions>&& fields) {
  using O = MoGlowOptions;
  return std::move(fields)
      .include(&O::foot, foot_objective_fields())
      .field("foot_contact_rollout", &O::foot_contact_rollout,
             "frames of the foot terms' draws generated from the model's own history; 0 = teacher-forced",
             at_least(0))
      .written_if([](const O& o) { return o.foot_contact_rollout > 0; })
      .field("foot_contact_temperature", &O::foot_contact_temperature,
             "latent standard deviation of the foot terms' draws", at_least(0.0))
      .written_if([](const O& o) { return o.foot_contact_temperature != 1.0; })
      .field("phase_locked_frames", &O::phase_locked_frames,
             "training: draws the planted, speed-error and lingering terms read; 0 = all", at_least(0))
      .written_if([](const O& o) { return o.phase_locked_frames > 0; })
      .field("cold_start_fraction", &O::cold_start_fraction,
             "training: share of windows whose foot-term draws start from the mean pose", in_range(0.0, 1.0))
      .written_if([](const O& o) { return o.cold_start_fraction > 0; })
      .rule([](const O& o) -> std::string {
        return o.cold_start_fraction > 0 && o.foot_contact_rollout < 1
                   ? "cold_start_fraction needs foot_contact_rollout > 0 (draws run free)"
                   : "";
      })
      .rule([](const O& o) -> std::string {
        return o.foot.toe_slide_weight > 0 && o.foot_contact_rollout < 1
                   ? "toe_slide_weight needs foot_contact_rollout > 0 (draws run free)"
                   : "";
      });
}

const OptionFields<MoGlowOptions>& moglow_fields() {
  using O = MoGlowOptions;
  static const auto fields =
      with_foot_terms(OptionFields<O>("moglow")
          .field("preset", &O::preset, "named defaults: \"default\" or \"paper\" (K=16, 2 x 512 LSTM, tau=10)")
          .field("num_steps", &O::num_steps, "K, steps of flow", at_least(1))
          .field("hidden", &O::hidden, "LSTM units per layer in each coupling network", at_least(1))
          .field("lstm_layers", &O::lstm_layers, "LSTM layers per coupling network", at_least(1))
          .field("tau", &O::tau, "frames of pose history conditioned on", at_least(1))
          .field("dropout", &O::dropout, "data dropout of history frames; < 0 = by pose form", in_range(0.0, 1.0))
          .field("scale_eps", &O::scale_eps, "coupling scale floor: s = sigmoid(h + 2) + scale_eps", at_least(0.0))
          .field("labels", &O::labels, "content and style labels as conditions")
          .written_if([](const O& o) { return o.labels; })
          .field("label_dropout", &O::label_dropout, "probability a window's label is dropped in training",
                 in_range(0.0, 1.0))
          .written_if([](const O& o) { return o.labels; })
          .field_checked_on_read("lookahead", &O::lookahead, "look-ahead offsets (frames) of the path; empty = causal",
                                 entries_at_least(1))
          .written_if([](const O& o) { return !o.lookahead.empty(); })
          .field("predicted_lookahead", &O::predicted_lookahead,
                 "training: probability a window's look-ahead is the real-time controller's prediction",
                 in_range(0.0, 1.0))
          .written_if([](const O& o) { return o.predicted_lookahead > 0; })
          .field("prediction_smoothing_s", &O::prediction_smoothing_s,
                 "sigma (s) of the controller's filter for predicted_lookahead; <= 0 = the dataset's root smoothing",
                 in_range(-1.0, 10.0))
          .written_if([](const O& o) { return o.prediction_smoothing_s > 0; })
          .field("short_clips", &O::short_clips, "train on clips shorter than the window (padding masked)")
          .written_if([](const O& o) { return !o.short_clips; })
          .field("residual", &O::residual, "the flow models each frame minus the transported previous one")
          .written_if([](const O& o) { return o.residual; })
          .field("history_noise", &O::history_noise,
                 "training: std of Gaussian noise on the poses conditioned on (standardised units)", at_least(0.0))
          .written_if([](const O& o) { return o.history_noise > 0; })
          .field("lead_in_s", &O::lead_in_s,
                 "sampling: seconds generated along the control's first step and dropped (without a prefix)",
                 in_range(0.0, 60.0))
          .written_if([](const O& o) { return o.lead_in_s != 1.0; }))
          .rule(lookahead_problem);
  return fields;
}

}  // namespace

MoGlowOptions MoGlowOptions::from_json(const nlohmann::json& config, const ModelContext& context) {
  const auto& fields = moglow_fields();
  MoGlowOptions o;
  if (!config.is_object()) throw Error("moglow config must be a JSON object");
  if (config.contains("preset")) fields.read_key(config, "preset", &o);  // the preset's defaults first
  if (o.preset == "paper") {
    o.num_steps = 16;
    o.hidden = 512;
    o.lstm_layers = 2;
    o.tau = 10;
  } else if (o.preset != "default") {
    throw Error("moglow config: unknown preset '" + o.preset + "' (known: default, paper)");
  }
  fields.read(config, &o);
  if (o.dropout < 0) o.dropout = default_dropout(context.pose_form);
  fields.check(o);
  return o;
}

// Labels, look-ahead and the residual are written only when on (short_clips only when off), so
// configs of runs made before they existed stay byte-identical.
nlohmann::json MoGlowOptions::to_json() const { return moglow_fields().write(*this); }

}  // namespace mosyn::nn
