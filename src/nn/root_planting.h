// Root planting of sampled motion (core/root_planting.h) as a run applies it: the run's
// config.json may hold "root_planting": {} (the defaults) or an object of RootPlantingOptions
// fields; without the key a run keeps its model's own root steps. Sampling (sample_motions, the
// real-time Generator) plants the frames a family generates when its root motion is its own.
// No LibTorch in this header.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/root_planting.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

struct LoadedRun;
struct SampledMotion;

// The keys of config.json's "root_planting" (types only: RootPlantingOptions::validate checks
// the values).
const OptionFields<RootPlantingOptions>& root_planting_fields();

// config.json's "root_planting" (nullopt without the key). Throws mosyn::Error naming config_path
// for an unknown key, a wrong type or a value out of range.
std::optional<RootPlantingOptions> root_planting_from_config(const nlohmann::json& config,
                                                            const std::string& config_path);

// Whether sampling plants `run`'s root steps: its family makes its own root motion, its config
// has root_planting, and the caller did not ask for the raw root.
bool plants_root(const LoadedRun& run, bool raw_root);

// A planter for one motion of `run` (which plants_root) that continues the raw prefix [P, D]
// (empty: none): the prefix's last frames, up to the floor window, show it the feet and floors.
RootPlanter planter_after(const LoadedRun& run, const std::vector<float>& prefix_pose);

// Plants the step control_row[0..1] (dx, dz metres) of the raw pose row [D] that follows the
// frames `planter` has seen, in place; the row is decoded alone on the floor origin. The
// frame-by-frame form, as the real-time Generator steps.
void plant_root_frame(const LoadedRun& run, RootPlanter* planter, const float* pose_row, float* control_row);

// Plants the floor steps of a generated motion (raw pose [T, D], control [T, C]) that follows the
// raw prefix [P, D], in place: as plant_root_frame frame by frame, but the poses decoded as one
// sequence (for the markers form, each frame's body fit starts from the last). Throws
// mosyn::Error when the sizes do not match the run.
void plant_root(const LoadedRun& run, const std::vector<float>& prefix_pose, SampledMotion* motion);

}  // namespace mosyn::nn
