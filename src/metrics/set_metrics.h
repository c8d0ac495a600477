// All metrics of metrics.h that apply to a plain set of motions (no model, no prediction context),
// as named rows: what `mosyn metrics` prints for the given files and for a reference set.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "metrics/metrics.h"

namespace mosyn::eval {

struct SetMetricsOptions {
  FootstepOptions footsteps;
  FootSkatingOptions skating;
  ToeSlideOptions toe_slide;
  std::vector<std::string> foot_joints;  // overrides for find_foot_joints (empty: by name)
};

// One metric of a set. value is NaN when the metric does not apply (e.g. APD of one motion).
struct MetricValue {
  std::string key;    // stable identifier for JSON, e.g. "footsteps.v_tol95_mps"
  std::string label;  // human-readable, with unit, e.g. "v_tol95 (cm/s)"
  double value = 0;   // in the unit of the label
};

// Rows, in this order: motions, frames, footsteps (max f_est), v_tol95 (cm/s), steps at v_tol95,
// step duration mean and std (s), contacts per foot per s and their mean (s) at the fixed
// tolerance, foot skating ratio (mean over motions), toe slide ratio (mean over the motions with
// toe joints; NaN without any), the pelvis' ground speed over 1-s spans (m/s,
// spans pooled over motions: pelvis_ground_speed_mps), bone-length RMSE (cm,
// over all frames pooled), deformation of each default rigid part (mm, mean over motions that have
// it), APD (m; whole sequences, motions cut to the shortest, needs >= 2 motions with the same
// joints), mean distance to the per-frame mean pose (m, averaged over frames; same conditions),
// spectral entropy (mean over motions). Throws mosyn::Error for an empty set.
std::vector<MetricValue> set_metrics(const std::vector<MotionPositions>& motions, const SetMetricsOptions& options = {});

// A value as the table shows it: "n/a" for NaN, integers without decimals, else 4 significant digits.
std::string format_metric_value(double value);

// {"key": value, ...} with NaN written as null.
nlohmann::json metrics_to_json(const std::vector<MetricValue>& values);

}  // namespace mosyn::eval
