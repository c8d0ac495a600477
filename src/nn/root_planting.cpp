// Separate from sampling.cpp: no LibTorch.
#include "nn/root_planting.h"

#include <algorithm>

#include "core/error.h"
#include "core/kinematics.h"
#include "data/representation.h"
#include "nn/run.h"
#include "nn/sampling.h"

namespace mosyn::nn {

namespace {

// One frame of ground-frame positions through the planter, its step written back into the row.
void plant_row(RootPlanter* planter, const std::vector<Eigen::Vector3d>& ground_frame_positions, float* control_row) {
  const Eigen::Vector2d planted =
      planter->step(ground_frame_positions, Eigen::Vector2d(control_row[0], control_row[1]), control_row[2]);
  control_row[0] = static_cast<float>(planted[0]);
  control_row[1] = static_cast<float>(planted[1]);
}

// Every joint of every frame of raw poses [T, D] on the floor origin at heading 0 (no root motion).
WorldPoses on_floor_origin(const LoadedRun& run, const float* poses, int frames) {
  const std::vector<float> still(static_cast<size_t>(frames) * run.context.control_dim, 0.0f);
  return forward_kinematics(run.dataset.skeleton, data::decode(run.dataset.skeleton, run.dataset.layout, poses,
                                                               still.data(), frames, run.dataset.fps));
}

}  // namespace

const OptionFields<RootPlantingOptions>& root_planting_fields() {
  using O = RootPlantingOptions;
  static const auto fields =
      OptionFields<O>("root_planting")
          .field("contact_height_m", &O::contact_height_m, "a foot point this close to its floor is planted")
          .field("release_height_m", &O::release_height_m, "a foot point this far above its floor is free")
          .field("floor_window_s", &O::floor_window_s, "a point's floor: its lowest height over these seconds")
          .field("keep_weight", &O::keep_weight, "the chosen foot stays chosen while its weight exceeds this")
          .field("switch_ratio", &O::switch_ratio, "unless the other foot is this many times more firmly planted");
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
    o.validate();
  } catch (const Error& e) {
    throw Error(config_path + ": " + e.what());
  }
  return o;
}

bool plants_root(const LoadedRun& run, bool raw_root) {
  return run.traits.control == InputUse::kGenerates && run.root_planting.has_value() && !raw_root;
}

RootPlanter planter_after(const LoadedRun& run, const std::vector<float>& prefix_pose) {
  if (!run.root_planting) throw Error("planter_after: " + run.run_dir + " does not plant its root");
  RootPlanter planter(run.dataset.skeleton, run.dataset.fps, *run.root_planting);
  const size_t d = run.context.pose_dim;
  const size_t frames = prefix_pose.size() / d, window = static_cast<size_t>(planter.window_frames());
  std::vector<float> control(static_cast<size_t>(run.context.control_dim), 0.0f);
  for (size_t t = frames - std::min(frames, window); t < frames; ++t)
    plant_root_frame(run, &planter, prefix_pose.data() + t * d, control.data());
  return planter;
}

void plant_root_frame(const LoadedRun& run, RootPlanter* planter, const float* pose_row, float* control_row) {
  plant_row(planter, on_floor_origin(run, pose_row, 1).positions, control_row);
}

void plant_root(const LoadedRun& run, const std::vector<float>& prefix_pose, SampledMotion* motion) {
  const size_t d = run.context.pose_dim, c = run.context.control_dim;
  if (d == 0 || c < 3 || motion->pose.size() % d != 0 || motion->control.size() != motion->pose.size() / d * c)
    throw Error("plant_root: pose and control are not [T, " + std::to_string(d) + "] and [T, " + std::to_string(c) + "]");
  const int frames = static_cast<int>(motion->pose.size() / d);
  RootPlanter planter = planter_after(run, prefix_pose);
  if (!planter.has_feet() || frames == 0) return;
  const WorldPoses ground = on_floor_origin(run, motion->pose.data(), frames);
  const int joints = run.dataset.skeleton.num_joints();
  std::vector<Eigen::Vector3d> frame(static_cast<size_t>(joints));
  for (int t = 0; t < frames; ++t) {
    std::copy_n(ground.positions.begin() + static_cast<size_t>(t) * joints, joints, frame.begin());
    plant_row(&planter, frame, motion->control.data() + static_cast<size_t>(t) * c);
  }
}

}  // namespace mosyn::nn
