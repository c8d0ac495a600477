// Root planting of sampled motion (core/root_planting.h) as a run applies it: the run's
// config.json may hold "root_planting": {} (the defaults) or an object of RootPlantingOptions
// fields; without the key a run keeps its model's own root steps. Sampling (sample_motions, the
// real-time Generator) plants the frames a family generates when its root motion is its own.
// No LibTorch in this header.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/root_planting.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

struct LoadedRun;
struct SampledMotion;

const OptionFields<RootPlantingOptions>& root_planting_fields();

// config.json's "root_planting" (nullopt without the key). Throws mosyn::Error naming config_path
// for an unknown key, a wrong type or a value out of range.
std::optional<RootPlantingOptions> root_planting_from_config(const nlohmann::json& config,
                                                            const std::string& config_path);

// Replaces the floor steps (control columns 0, 1: dx, dz metres) of `motion`'s frames from
// first_frame on by the planted ones; the frames before it (an observed prefix) only show the
// planter the feet and floors. motion holds raw pose [T, D] and control [T, C] of `run`.
// Decodes the poses once on the floor origin (data::decode with no root motion: for the markers
// form that is a body fit per frame). Throws mosyn::Error when the sizes do not match the run.
void plant_root(const LoadedRun& run, const RootPlantingOptions& options, int first_frame, SampledMotion* motion);

// The frame-by-frame form (the real-time Generator): plants the step control_row[0..1] of the raw
// pose row [D] that follows the frames `planter` has seen, in place. Each row is decoded alone on
// the floor origin. planter belongs to one character of `run` (a stream's state).
void plant_root_frame(const LoadedRun& run, RootPlanter* planter, const float* pose_row, float* control_row);

// Shows `planter` the last frames of a raw prefix [P, D] (up to its floor window) as plant_root
// does before a continuation: their feet and floors, their steps unchanged.
void show_prefix(const LoadedRun& run, const std::vector<float>& prefix_pose, RootPlanter* planter);

}  // namespace mosyn::nn
