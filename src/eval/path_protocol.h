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

// N samples along every synthetic path (seed + path index), the "walk" content label when the
// model takes labels and knows it, warm-up as warmup_frames (nn::SampleExtras). Returns the
// decoded world positions [paths * N].
std::vector<MotionPositions> sample_synthetic_paths(const nn::LoadedRun& run, int n, std::uint64_t seed,
                                                    double temperature, int warmup_frames);

}  // namespace mosyn::eval
