#include "metrics/set_metrics.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace mosyn::eval {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

std::vector<MetricValue> set_metrics(const std::vector<MotionPositions>& motions, const SetMetricsOptions& options) {
  if (motions.empty()) throw Error("metrics need at least one motion");
  std::vector<MetricValue> rows;
  long frames = 0;
  for (const auto& m : motions) frames += m.num_frames;
  rows.push_back({"motions", "motions", static_cast<double>(motions.size())});
  rows.push_back({"frames", "frames", static_cast<double>(frames)});

  std::vector<FootJoints> feet;
  for (const auto& m : motions) feet.push_back(find_foot_joints(m, options.foot_joints));
  const FootstepAnalysis steps = analyse_footsteps(motions, feet, options.footsteps);
  rows.push_back({"footsteps.max_steps", "footsteps f_est (max over v_tol)", static_cast<double>(steps.max_steps)});
  rows.push_back({"footsteps.v_tol95_cmps", "v_tol95 (cm/s)", steps.max_steps > 0 ? steps.v_tol95_mps * 100 : kNaN});
  rows.push_back({"footsteps.steps_at_v_tol95", "steps at v_tol95", static_cast<double>(steps.steps_at_v_tol95)});
  rows.push_back({"footsteps.duration_mean_s", "step duration mean (s)", steps.step_duration_mean_s});
  rows.push_back({"footsteps.duration_std_s", "step duration std (s)", steps.step_duration_std_s});
  const std::string fixed_cmps = std::to_string(static_cast<int>(std::lround(options.footsteps.fixed_tol_mps * 100)));
  rows.push_back({"footsteps.fixed_tol.contacts_per_foot_s", "contacts per foot per s at " + fixed_cmps + " cm/s",
                  steps.contacts_per_foot_s});
  rows.push_back({"footsteps.fixed_tol.contact_mean_s", "contact mean (s) at " + fixed_cmps + " cm/s",
                  steps.contact_mean_at_fixed_tol_s});

  double skating = 0, toe_slide = 0, bone_sq = 0;
  int with_toes = 0;
  long bone_count = 0;
  std::map<std::string, std::pair<double, int>> deformation;
  std::vector<std::string> part_order = {"head", "upper torso", "lower torso"};
  for (size_t i = 0; i < motions.size(); ++i) {
    const auto& m = motions[i];
    skating += foot_skating_ratio(m, feet[i], options.skating);
    const double toes = toe_slide_ratio(m, feet[i], options.toe_slide);
    if (!std::isnan(toes)) toe_slide += toes, ++with_toes;
    const double rmse = bone_length_rmse_m(m);
    const long n = static_cast<long>(m.num_frames) * (m.num_joints - 1);
    bone_sq += rmse * rmse * n;
    bone_count += n;
    for (const auto& part : default_rigid_parts(m)) {
      auto& d = deformation[part.name];
      d.first += rigid_part_deformation_m(m, part);
      d.second += 1;
    }
  }
  rows.push_back({"foot_skating_ratio", "foot skating ratio", skating / motions.size()});
  rows.push_back({"toe_slide_ratio", "toe slide ratio", with_toes > 0 ? toe_slide / with_toes : kNaN});
  rows.push_back({"pelvis_ground_speed_mps", "pelvis ground speed over 1 s (m/s)", pelvis_ground_speed_mps(motions, 1.0)});
  rows.push_back({"bone_length_rmse_cm", "bone-length RMSE (cm)", bone_count > 0 ? std::sqrt(bone_sq / bone_count) * 100 : 0.0});
  for (const auto& name : part_order) {
    const auto it = deformation.find(name);
    std::string key = name;
    for (char& c : key)
      if (c == ' ') c = '_';
    rows.push_back({"deformation." + key + "_mm", "deformation " + name + " (mm)",
                    it == deformation.end() ? kNaN : it->second.first / it->second.second * 1000});
  }

  // Diversity over whole motions, cut to the shortest so shapes agree.
  double apd = kNaN, spread = kNaN;
  bool same_joints = motions.size() >= 2;
  int shortest = motions[0].num_frames;
  for (const auto& m : motions) {
    same_joints = same_joints && m.num_joints == motions[0].num_joints;
    shortest = std::min(shortest, m.num_frames);
  }
  if (same_joints && shortest > 0) {
    std::vector<Eigen::MatrixXd> seqs;
    for (const auto& m : motions) seqs.push_back(m.sequence().topRows(shortest));
    apd = average_pairwise_distance(seqs);
    spread = mean_pose_distance(seqs).mean_m.mean();
  }
  rows.push_back({"apd_m", "APD diversity (m)", apd});
  rows.push_back({"mean_pose_distance_m", "distance to per-frame mean pose (m)", spread});
  double entropy = 0;
  for (const auto& m : motions) entropy += spectral_entropy(m.sequence());
  rows.push_back({"spectral_entropy", "spectral entropy (nats)", entropy / motions.size()});
  return rows;
}

nlohmann::json metrics_to_json(const std::vector<MetricValue>& values) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& v : values) j[v.key] = std::isfinite(v.value) ? nlohmann::json(v.value) : nlohmann::json(nullptr);
  return j;
}

std::string format_metric_value(double v) {
  if (!std::isfinite(v)) return "n/a";
  if (std::abs(v) < 1e-9) v = 0;  // rounding noise of exact zeros (e.g. rigid parts under FK)
  char buf[32];
  if (v == std::round(v) && std::abs(v) < 1e9)
    std::snprintf(buf, sizeof buf, "%.0f", v);
  else
    std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

}  // namespace mosyn::eval
