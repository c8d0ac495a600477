// Separate from sampling.cpp: no LibTorch.
#include "nn/root_planting.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/kinematics.h"
#include "data/representation.h"
#include "nn/run.h"
#include "nn/sampling.h"

namespace mosyn::nn {

const OptionFields<RootPlantingOptions>& root_planting_fields() {
  using O = RootPlantingOptions;
  static const auto fields =
      OptionFields<O>("root_planting")
          .field("contact_height_m", &O::contact_height_m, "a foot point this close to its floor is planted",
                 at_least(0.0))
          .field("release_height_m", &O::release_height_m, "a foot point this far above its floor is free",
                 at_least(0.0))
          .field("floor_window_s", &O::floor_window_s, "a point's floor: its lowest height over these seconds",
                 above_up_to(0.0, 60.0))
          .field("keep_weight", &O::keep_weight, "the chosen foot stays chosen while its weight exceeds this",
                 in_range(0.0, 1.0))
          .field("switch_ratio", &O::switch_ratio, "unless the other foot is this many times more firmly planted",
                 at_least(1.0))
          .rule([](const O& o) {
            return o.release_height_m > o.contact_height_m ? "" : "release_height_m must be above contact_height_m";
          });
  return fields;
}

std::optional<RootPlantingOptions> root_planting_from_config(const nlohmann::json& config,
                                                            const std::string& config_path) {
  if (!config.contains("root_planting")) return std::nullopt;
  const auto& section = config.at("root_planting");
  if (!section.is_object())
    throw Error(config_path + ": root_planting must be an object of options ({} for the defaults)");
  RootPlantingOptions o;
  try {
    root_planting_fields().read(section, &o);
    root_planting_fields().check(o);
  } catch (const Error& e) {
    throw Error(config_path + ": " + e.what());
  }
  return o;
}

void plant_root(const LoadedRun& run, const RootPlantingOptions& options, int first_frame, SampledMotion* motion) {
  const size_t d = run.context.pose_dim, c = run.context.control_dim;
  if (d == 0 || c < 3 || motion->pose.size() % d != 0 || motion->control.size() != motion->pose.size() / d * c)
    throw Error("plant_root: pose and control are not [T, " + std::to_string(d) + "] and [T, " + std::to_string(c) + "]");
  const int t_frames = static_cast<int>(motion->pose.size() / d);
  if (first_frame < 0 || first_frame > t_frames) throw Error("plant_root: first_frame out of range");
  const Skeleton& skeleton = run.dataset.skeleton;
  RootPlanter planter(skeleton, run.dataset.fps, options);
  if (!planter.has_feet() || t_frames < 2) return;
  // Every frame on the floor origin at heading 0: the ground frame positions the planter reads.
  const std::vector<float> still(static_cast<size_t>(t_frames) * c, 0.0f);
  const Motion placed = data::decode(skeleton, run.dataset.layout, motion->pose.data(), still.data(), t_frames,
                                     run.dataset.fps);
  const WorldPoses ground = forward_kinematics(skeleton, placed);
  const int joints = skeleton.num_joints();
  std::vector<Eigen::Vector3d> frame(static_cast<size_t>(joints));
  for (int t = 0; t < t_frames; ++t) {
    for (int j = 0; j < joints; ++j) frame[j] = ground.position(t, j);
    float* row = motion->control.data() + static_cast<size_t>(t) * c;
    const Eigen::Vector2d planted = planter.step(frame, Eigen::Vector2d(row[0], row[1]), row[2]);
    if (t < first_frame) continue;
    row[0] = static_cast<float>(planted[0]);
    row[1] = static_cast<float>(planted[1]);
  }
}

void plant_root_frame(const LoadedRun& run, RootPlanter* planter, const float* pose_row, float* control_row) {
  const Skeleton& skeleton = run.dataset.skeleton;
  const std::vector<float> still(static_cast<size_t>(run.context.control_dim), 0.0f);
  const Motion placed = data::decode(skeleton, run.dataset.layout, pose_row, still.data(), 1, run.dataset.fps);
  const WorldPoses ground = forward_kinematics(skeleton, placed);
  const Eigen::Vector2d planted =
      planter->step(ground.positions, Eigen::Vector2d(control_row[0], control_row[1]), control_row[2]);
  control_row[0] = static_cast<float>(planted[0]);
  control_row[1] = static_cast<float>(planted[1]);
}

void show_prefix(const LoadedRun& run, const std::vector<float>& prefix_pose, RootPlanter* planter) {
  const size_t d = run.context.pose_dim;
  const size_t frames = prefix_pose.size() / d;
  const size_t window = static_cast<size_t>(std::lround(planter->options().floor_window_s * run.dataset.fps));
  std::vector<float> control(static_cast<size_t>(run.context.control_dim), 0.0f);
  for (size_t t = frames - std::min(frames, window); t < frames; ++t)
    plant_root_frame(run, planter, prefix_pose.data() + t * d, control.data());
}

}  // namespace mosyn::nn
