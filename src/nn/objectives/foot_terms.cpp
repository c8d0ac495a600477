#include "nn/objectives/foot_terms.h"

#include "core/error.h"
#include "core/foot_lock.h"
#include "nn/kinematics.h"

namespace mosyn::nn {

FootTerms::FootTerms(const ModelContext& context, const std::string& family, const FootTermOptions& options)
    : fps_(context.fps), planted_mps_(options.planted_mps), planted_speed_fraction_(options.planted_speed_fraction) {
  if (!(options.planted_mps > 0 && options.planted_mps <= 1)) throw Error(family + ": planted_mps must be in (0, 1]");
  if (!(options.planted_speed_fraction >= 0)) throw Error(family + ": planted_speed_fraction must not be negative");
  if (!(options.toe_weight > 0 && options.toe_weight <= 1)) throw Error(family + ": toe_term_weight must be in (0, 1]");
  body_ = BodyPoints(context, family);
  heels_ = body_.heel_points();
  toes_ = body_.toe_points();
  const bool need_toes = options.with_toes || options.toe_slide;
  if (need_toes && toes_.empty())
    throw Error(family + ": toe_terms and toe_slide_weight need a joint below each ankle (the toes)");
  if (options.bone_lengths && body_.num_pairs() == 0)
    throw Error(family + ": bone_length_weight needs the positions or markers form with the dataset's skeleton "
                         "(rotations keep bone lengths by construction)");
  if (options.with_toes) {
    heels_.insert(heels_.end(), toes_.begin(), toes_.end());
    if (options.toe_weight != 1.0)
      joint_weight_ = torch::tensor({1.0, 1.0, options.toe_weight, options.toe_weight});
  }
  control_mean_ = torch::tensor(context.stats.control_mean);
  control_std_ = torch::tensor(context.stats.control_std);
}

torch::Tensor FootTerms::positions_m(const torch::Tensor& pose) const {
  const auto points = body_.points_m(pose);  // [B, T, P, 3]
  return points.reshape({points.size(0), points.size(1), -1});
}

torch::Tensor FootTerms::raw_control(const torch::Tensor& control, const torch::TensorOptions& opts) const {
  return control.to(opts) * control_std_.to(opts) + control_mean_.to(opts);
}

namespace {

// The root's ground speed (m/s) into frames 1..T-1 from raw control [B, T, C] (the control of frame
// t is the root's step into it: sideways, forward in metres; turn): [B, T-1]. eps > 0 under the
// root keeps the gradient finite at standstill.
torch::Tensor root_speed_mps(const torch::Tensor& raw_control, double fps, double eps) {
  const auto step = raw_control.narrow(1, 1, raw_control.size(1) - 1).narrow(2, 0, 2);
  return (step.pow(2).sum(-1) + eps).sqrt() * fps;
}

}  // namespace

torch::Tensor FootTerms::root_mps(const torch::Tensor& control) const {
  if (heels_.empty()) throw Error("FootTerms: not built from a model context");
  return root_speed_mps(raw_control(control, control.options()), fps_, 1e-12);
}

namespace {

// max(floor_mps, fraction x the root's ground speed) per step, [B, T-1, 1]: a threshold or cap that
// rises with the gait's speed (root_mps as HeelSpeeds::root_mps).
torch::Tensor scaled_by_root_speed(const torch::Tensor& root_mps, double floor_mps, double fraction) {
  return (root_mps * fraction).clamp_min(floor_mps);
}

}  // namespace

FootTerms::HeelSpeeds FootTerms::speeds(const torch::Tensor& made, const torch::Tensor& made_control,
                                         const torch::Tensor& real, const torch::Tensor& real_control) const {
  if (heels_.empty()) throw Error("FootTerms: not built from a model context");
  const auto opts = made.options();
  const auto made_ctrl = raw_control(made_control, opts);
  const auto real_ctrl = made_control.is_same(real_control) ? made_ctrl : raw_control(real_control, opts);
  const auto root_mps = root_speed_mps(real_ctrl, fps_, 0.0).unsqueeze(-1).detach();
  HeelSpeeds out{joint_ground_speed_mps(positions_m(made), made_ctrl, heels_, fps_),
                 joint_ground_speed_mps(positions_m(real.to(opts)), real_ctrl, heels_, fps_),
                 torch::full({}, planted_mps_, opts), root_mps};
  if (planted_speed_fraction_ > 0)
    out.planted_below_mps = scaled_by_root_speed(root_mps, planted_mps_, planted_speed_fraction_);
  return out;
}

namespace {

// Mean of value [B, T-1, K] (K heels, or 1) over the entries where `counted` (0/1, same shape) is 1
// and valid ([B, T-1], optional) allows, each joint k weighted by joint_weight[k] (optional [K]);
// 0 when none is.
torch::Tensor mean_over(const torch::Tensor& value, torch::Tensor counted, const torch::Tensor& valid,
                        const torch::Tensor& joint_weight = {}) {
  if (valid.defined()) counted = counted * valid.to(value.options()).unsqueeze(-1);
  if (joint_weight.defined()) counted = counted * joint_weight.to(value.options());
  return (value * counted).sum() / counted.sum().clamp_min(1.0);
}


// The runs of `window` consecutive steps the stance terms read, for speeds s [B, n, K] (n >= window)
// and the planted threshold (FootTerms::planted_threshold):
// runs(x) unfolds x (broadcast to s's shape) to [B, n - window + 1, K, window]; planted [B, m, K] is
// 1 where the real heel plants in the run; whole [B, m] 1 where no step of it is padded (undefined
// without valid).
struct StanceRuns {
  int64_t window;
  torch::Tensor like, planted, whole;
  torch::Tensor runs(const torch::Tensor& x) const { return x.expand_as(like).unfold(1, window, 1); }
};

StanceRuns stance_runs(const FootTerms::HeelSpeeds& s, const torch::Tensor& threshold, int64_t window,
                       const torch::Tensor& valid) {
  StanceRuns r{window, s.made_mps, {}, {}};
  r.planted = std::get<0>(r.runs((s.real_mps < threshold).to(s.made_mps.dtype())).max(-1));
  if (valid.defined()) r.whole = std::get<0>(valid.to(s.made_mps.options()).unfold(1, window, 1).min(-1));
  return r;
}

}  // namespace

torch::Tensor FootTerms::planted_threshold(const HeelSpeeds& s) const {
  return s.planted_below_mps.defined() ? s.planted_below_mps : torch::full({}, planted_mps_, s.made_mps.options());
}

torch::Tensor FootTerms::mean_planted_speed(const HeelSpeeds& s, const torch::Tensor& valid) const {
  return mean_over(s.made_mps, (s.real_mps < planted_threshold(s)).to(s.made_mps.dtype()), valid, joint_weight_);
}

torch::Tensor FootTerms::mean_lingering_speed(const HeelSpeeds& s, const torch::Tensor& valid) const {
  const auto threshold = planted_threshold(s);
  return mean_over(torch::relu(threshold - s.made_mps), (s.real_mps >= threshold).to(s.made_mps.dtype()), valid,
                   joint_weight_);
}

torch::Tensor FootTerms::mean_missed_stance(const HeelSpeeds& s, int64_t window, const torch::Tensor& valid,
                                                 bool relative_to_data) const {
  if (window < 1) throw Error("FootTerms: the stance window must be at least one step");
  if (s.made_mps.size(1) < window) return torch::zeros({}, s.made_mps.options());
  const auto threshold = planted_threshold(s);
  const StanceRuns r = stance_runs(s, threshold, window, valid);
  const auto above = relative_to_data
                         ? std::get<0>(r.runs(s.made_mps).min(-1)) - std::get<0>(r.runs(s.real_mps).min(-1))
                         : std::get<0>(r.runs(s.made_mps - threshold).min(-1));
  return mean_over(torch::relu(above), r.planted, r.whole, joint_weight_);
}

torch::Tensor FootTerms::mean_excess_slow_share(const HeelSpeeds& s, int64_t window,
                                                      const torch::Tensor& valid) const {
  if (window < 1) throw Error("FootTerms: the stance window must be at least one step");
  if (s.made_mps.size(1) < window) return torch::zeros({}, s.made_mps.options());
  const auto threshold = planted_threshold(s);
  const StanceRuns r = stance_runs(s, threshold, window, valid);
  torch::Tensor excess = torch::zeros_like(r.planted);  // [B, n - window + 1, K]
  for (double level : kSlowLevels) {
    const auto bar = threshold * level;
    const auto made_slow = torch::sigmoid((bar - s.made_mps) / (bar * kSlowSoftness));
    const auto real_slow = (s.real_mps < bar).to(s.made_mps.dtype());
    excess = excess + torch::relu(r.runs(made_slow).mean(-1) - r.runs(real_slow).mean(-1));
  }
  return mean_over(excess, r.planted, r.whole, joint_weight_);
}

torch::Tensor FootTerms::mean_sorted_speed_error(const HeelSpeeds& s, const torch::Tensor& valid,
                                                      double cap_mps, double cap_speed_fraction) const {
  if (!(cap_mps > 0)) throw Error("FootTerms: the speed-distribution cap must be positive");
  if (!(cap_speed_fraction >= 0)) throw Error("FootTerms: the speed-distribution cap fraction must not be negative");
  const auto opts = s.made_mps.options();
  auto cap = torch::full({}, cap_mps, opts);
  if (cap_speed_fraction > 0) {
    if (!s.root_mps.defined()) throw Error("FootTerms: a speed-scaled cap needs the root speeds (speeds())");
    cap = scaled_by_root_speed(s.root_mps.to(opts), cap_mps, cap_speed_fraction);
  }
  auto made = torch::min(s.made_mps, cap), real = torch::min(s.real_mps.to(opts), cap);
  auto counted = torch::ones_like(made);
  if (valid.defined()) {
    // Left-out steps become -1 in both: sorted, they come first in equal numbers and cancel.
    const auto keep = valid.to(opts).unsqueeze(-1).expand_as(made);
    made = torch::where(keep > 0, made, torch::full_like(made, -1.0));
    real = torch::where(keep > 0, real, torch::full_like(real, -1.0));
    counted = std::get<0>(keep.sort(1));
  }
  const auto error = (std::get<0>(made.sort(1)) - std::get<0>(real.sort(1))).abs();
  return mean_over(error, counted, {}, joint_weight_);
}

torch::Tensor FootTerms::mean_pelvis_offset_m(const torch::Tensor& made, const torch::Tensor& real,
                                             const torch::Tensor& valid) const {
  if (heels_.empty()) throw Error("FootTerms: not built from a model context");
  const int pelvis = body_.pelvis_point();
  const auto ground = torch::tensor({0L, 2L}, torch::dtype(torch::kInt64).device(made.device()));
  const auto at = [&](const torch::Tensor& pose) {
    return body_.points_m(pose).select(-2, pelvis).index_select(-1, ground);  // [B, n, 2]: x, z
  };
  const auto offset = at(made) - at(real.to(made.options()));
  // [B, n, 1], as the heel terms' [B, n, 2]; eps keeps the gradient finite at 0.
  const auto distance = (offset.pow(2).sum(-1, /*keepdim=*/true) + 1e-12).sqrt();
  return mean_over(distance, torch::ones_like(distance), valid);
}

torch::Tensor FootTerms::mean_bone_length_error_m(const torch::Tensor& made, const torch::Tensor& valid) const {
  if (body_.num_pairs() == 0) throw Error("FootTerms: the bone-length term needs the positions or markers form");
  const auto rest = body_.rest_lengths_m().to(made.options());
  const auto error = (body_.pair_lengths_m(made) - rest).abs();  // [B, T, N]
  return mean_over(error, torch::ones_like(error), valid);
}

torch::Tensor FootTerms::toe_slide_per_row(const torch::Tensor& frames, const torch::Tensor& control,
                                                const torch::Tensor& valid) const {
  if (toes_.empty()) throw Error("FootTerms: the toe-slide term needs a joint below each ankle (the toes)");
  const auto opts = frames.options();
  const auto metres = positions_m(frames);
  const auto speed = joint_ground_speed_mps(metres, raw_control(control, opts), toes_, fps_);  // [B, T-1, 2]
  std::vector<torch::Tensor> heights;                                                          // y is up
  for (int j : toes_) heights.push_back(metres.select(-1, 3 * j + 1).detach());
  const auto height = torch::stack(heights, -1);  // [B, T, 2]
  const auto floor = std::get<0>(height.min(1, /*keepdim=*/true));
  // Not differentiated: lifting a toe off the floor is no cure (MoGlow's feet hovered and the heels
  // glided), only slowing it is.
  const auto low = torch::sigmoid((floor + kLowToeM - height.narrow(1, 0, height.size(1) - 1)) / kLowSoftnessM);
  auto counted = torch::ones_like(speed);
  if (valid.defined()) counted = counted * valid.to(opts).unsqueeze(-1);
  return (low * torch::relu(speed - kSlideMps) * counted).sum({1, 2}) / counted.sum({1, 2}).clamp_min(1.0);
}

torch::Tensor FootTerms::mean_toe_slide(const torch::Tensor& frames, const torch::Tensor& control,
                                             const torch::Tensor& valid) const {
  return toe_slide_per_row(frames, control, valid).mean();
}

torch::Tensor FootTerms::mean_excess_toe_slide(const torch::Tensor& made, const torch::Tensor& made_control,
                                              const torch::Tensor& real, const torch::Tensor& real_control,
                                              const torch::Tensor& valid) const {
  const auto data = toe_slide_per_row(real.to(made.options()), real_control, valid).detach();
  const auto excess = torch::relu(toe_slide_per_row(made, made_control, valid) - data);  // [B]
  if (!valid.defined()) return excess.mean();
  const auto rows = (valid.to(made.options()).sum(1) > 0).to(made.options());  // rows with a step to read
  return (excess * rows).sum() / rows.sum().clamp_min(1.0);
}

torch::Tensor FootTerms::mean_speed_error(const HeelSpeeds& s, const torch::Tensor& valid) const {
  return mean_over((s.made_mps - s.real_mps).abs(), torch::ones_like(s.made_mps), valid, joint_weight_);
}

}  // namespace mosyn::nn
