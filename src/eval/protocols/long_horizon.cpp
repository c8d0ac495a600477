// Long-horizon stability: N samples of long_horizon_s seconds (a meandering walk for families that
// take control, free generation for the others), scored per time window: does the body keep its
// shape (bone lengths), its feet planted (skating) and its liveliness (body speed), or does it
// freeze or explode?
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;
using detail::body_speed_mps;
using detail::largest_extent_m;
using detail::kExplodedExtent;
using detail::kFrozenFraction;
using detail::mean_finite;
using detail::slice;

// The three per-window metrics of one motion (or of a whole real clip).
struct WindowValues {
  double bone_cm = kNaN, skating = kNaN, speed_mps = kNaN;
};

WindowValues window_values(const MotionPositions& m, const SetMetricsOptions& o) {
  WindowValues v;
  v.bone_cm = 100.0 * bone_length_rmse_m(m);
  v.skating = foot_skating_ratio(m, find_foot_joints(m, o.foot_joints), o.skating);
  v.speed_mps = body_speed_mps(m);
  return v;
}

class LongHorizonProtocol : public Protocol {
 public:
  std::string name() const override { return "long_horizon"; }
  bool enabled(const EvalOptions& o) const override { return o.long_horizon_s > 0; }
  bool applies_to(const nn::ModelTraits&) const override { return true; }
  void run(EvalContext& ctx, EvalResult& result) const override;
};

void LongHorizonProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  if (!(o.long_horizon_window_s > 0)) throw Error("evaluate: long_horizon_window_s must be > 0");
  const int window = std::max(2, static_cast<int>(std::lround(o.long_horizon_window_s * run.dataset.fps)));
  const std::vector<float> control = detail::long_horizon_control(run, o.long_horizon_s);
  const int frames = static_cast<int>(control.size()) / run.context.control_dim;
  if (frames < 2) throw Error("evaluate: the long horizon must last at least 2 frames");
  const int num_windows = std::max(1, frames / window);
  ctx.report("long horizon", 0, 1);
  const auto motions = nn::sample_motions(run, control, ctx.num_samples(), o.seed + 5000011, o.temperature,
                                          detail::walk_extras(run, ctx.warmup_frames()));
  // Reference levels from the real clips, each clip whole.
  std::vector<double> real_bone, real_skating, real_speed;
  double real_extent = 0;
  for (const auto& m : ctx.real()) {
    const WindowValues v = window_values(m, o.metrics);
    real_bone.push_back(v.bone_cm);
    real_skating.push_back(v.skating);
    real_speed.push_back(v.speed_mps);
    real_extent = std::max(real_extent, largest_extent_m(m));
  }
  const double real_speed_mean = mean_finite(real_speed);
  // [window] values over samples, and the per-sample summaries.
  std::vector<std::vector<double>> bone(num_windows), skating(num_windows), speed(num_windows);
  std::vector<double> ratio, frozen, exploded;
  for (const auto& motion : motions) {
    const MotionPositions m = motion_positions(nn::decode_motion(run, motion), 0.0, "long horizon");
    const int per = std::max(1, m.num_frames / num_windows);
    bool is_frozen = false;
    double first_speed = kNaN, last_speed = kNaN;
    for (int k = 0; k < num_windows; ++k) {
      const int from = std::min(k * per, m.num_frames), to = k + 1 == num_windows ? m.num_frames : from + per;
      if (to - from < 2) continue;
      const WindowValues v = window_values(slice(m, from, to), o.metrics);
      bone[k].push_back(v.bone_cm);
      skating[k].push_back(v.skating);
      speed[k].push_back(v.speed_mps);
      if (k == 0) first_speed = v.speed_mps;
      last_speed = v.speed_mps;
      if (k > 0 && !(v.speed_mps >= kFrozenFraction * real_speed_mean)) is_frozen = true;
    }
    ratio.push_back(last_speed / first_speed);
    frozen.push_back(is_frozen ? 1.0 : 0.0);
    exploded.push_back(largest_extent_m(m) > kExplodedExtent * real_extent ? 1.0 : 0.0);
  }
  const double seconds_per_window = static_cast<double>(frames) / num_windows / run.dataset.fps;
  auto add_windows = [&](const std::string& key, const std::string& label, const std::vector<std::vector<double>>& v,
                         double real) {
    for (int k = 0; k < num_windows; ++k) {
      char at[64];
      std::snprintf(at, sizeof at, "long horizon %.3g-%.3g s: ", k * seconds_per_window, (k + 1) * seconds_per_window);
      result.rows.push_back({"long_horizon." + key + ".w" + std::to_string(k), at + label, mean_finite(v[k]), real});
    }
  };
  add_windows("bone_length_rmse_cm", "bone-length RMSE (cm)", bone, mean_finite(real_bone));
  add_windows("foot_skating_ratio", "foot skating ratio", skating, mean_finite(real_skating));
  add_windows("body_speed_mps", "body speed relative to the pelvis (m/s)", speed, real_speed_mean);
  result.rows.push_back({"long_horizon.body_speed_ratio", "long horizon: body speed, last window over first",
                         mean_finite(ratio), kNaN});
  result.rows.push_back({"long_horizon.frozen_fraction", "long horizon: fraction of samples that freeze",
                         mean_finite(frozen), kNaN});
  result.rows.push_back({"long_horizon.exploded_fraction", "long horizon: fraction of samples that explode",
                         mean_finite(exploded), kNaN});
  ctx.report("long horizon", 1, 1);
}

}  // namespace

std::unique_ptr<Protocol> make_long_horizon_protocol() { return std::make_unique<LongHorizonProtocol>(); }

}  // namespace mosyn::eval
