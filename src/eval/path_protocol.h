// Locomotion along drawn paths: the protocol that judges what users do most ("draw a path, get
// walks along it"). A fixed set of synthetic paths (a curve, a zigzag, stop-and-go, straight lines
// at 0.8, 1.3 and 1.8 m/s), each walked by N samples, scored with the set metrics against the real
// held-out clips. Applies to every family that takes a control.
#pragma once

#include <string>
#include <vector>

#include "metrics/metrics.h"
#include "metrics/set_metrics.h"
#include "nn/run.h"

namespace mosyn::eval {

struct SyntheticPath {
  std::string name;   // e.g. "curve"
  std::string path;   // waypoints as `mosyn sample --path` takes them, metres
  double speed_mps;   // walking speed along it
};

// The protocol's paths (the same as scripts/natural_eval.py).
const std::vector<SyntheticPath>& synthetic_paths();

// What a drawn path asks of the walker at a frame, from the speed of its (smoothed) control.
enum class PathPhase {
  kSteady,    // at >= 90% of the path's speed
  kChanging,  // between: starting, stopping, slowing into a sharp corner
  kStanding,  // under 5 cm/s
};

// The phase of every frame of a control [T, 3] row-major (dx, dz in metres per frame, dtheta) at
// fps, for a path walked at speed_mps: of the path as drawn (data::control_from_path, before the
// dataset's smoothing), i.e. what the user asked for at that instant. The Bandai-Namco takes hold no start or stop at all (every
// locomotion take begins and ends in stride), so kChanging and kStanding frames ask a model for
// motion it has not seen.
std::vector<PathPhase> path_phases(const std::vector<float>& control, double fps, double speed_mps);

// N samples along every synthetic path (seed + path index), the "walk" content label when the
// model takes labels and knows it, warm-up as warmup_frames (nn::SampleExtras). Returns the
// decoded world positions [paths * N].
// phases (optional): per returned motion, path_phases of its path as drawn (as many frames as
// the motion).
std::vector<MotionPositions> sample_synthetic_paths(const nn::LoadedRun& run, int n, std::uint64_t seed,
                                                    double temperature, int warmup_frames,
                                                    std::vector<std::vector<PathPhase>>* phases = nullptr);

// The parts of motions where their paths ask for steady walking (PathPhase::kSteady runs of at
// least min_frames frames; phases[m] per frame of along_paths[m], extra frames on either side
// ignored), each cut out as a motion of its own (name, skeleton and fps kept). The takes hold no
// start or stop, so these parts compare like for like with them: a stop at a path's end is one long
// contact per foot, and it lengthens the mean step of the whole sample however natural the stop.
std::vector<MotionPositions> steady_parts(const std::vector<MotionPositions>& along_paths,
                                          const std::vector<std::vector<PathPhase>>& phases, int min_frames);

}  // namespace mosyn::eval
