// Procedural skeleton and walking motion for unit tests in every layer (no data files needed).
#pragma once

#include <cstdint>

#include "core/skeleton.h"

namespace mosyn {

// A Y-up biped of 21 joints in centimetres (meters_per_unit 0.01), 1.66 m tall (head top),
// facing +Z in the rest pose with its left side at +X (arms stretched sideways, a T-pose; toes'
// end sites on the floor). Left/right
// offsets are exact mirrors about X = 0 (names with _L/_R suffixes, as Bandai-Namco):
//   0 Hips (root, rest offset (0, 96, 0)), 1 Spine, 2 Chest, 3 Neck, 4 Head,
//   5 Shoulder_L, 6 UpperArm_L, 7 LowerArm_L, 8 Hand_L, 9..12 the same _R,
//   13 UpperLeg_L, 14 LowerLeg_L, 15 Foot_L, 16 Toes_L, 17..20 the same _R.
// End sites (in this order): head top, Hand_L, Hand_R, Toes_L, Toes_R.
Skeleton make_synthetic_biped();

struct SyntheticWalkOptions {
  double speed_mps = 1.3;          // ground speed of the root, metres per second
  double turn_rate_rad_s = 0.0;    // heading change per second (positive: counter-clockwise
                                   // seen from above, i.e. about +up)
  double start_heading_rad = 0.5;  // heading at frame 0 (trajectory.h convention: 0 faces +Z)
  double cycle_hz = 0.9;           // gait cycles (two steps) per second
  double leg_swing_rad = 0.45;     // hip flexion amplitude
  double arm_swing_rad = 0.35;     // shoulder swing amplitude
  double bob_m = 0.03;             // root vertical bob amplitude (twice per cycle)
  double sway_rad = 0.05;          // root yaw and roll oscillation amplitude (once per cycle)
  double noise_rad = 0.0;          // std of Gaussian noise added to every rotation angle (0: none)
  std::uint64_t seed = 0;          // noise seed; the motion is a pure function of its arguments
};

// A procedural walk on `skeleton` (built for make_synthetic_biped; any skeleton with its joint
// names works, missing joints stay in the rest pose): the root (joint 0) starts above the origin
// at its rest height and moves at speed_mps along a circular arc (straight when turn_rate is 0)
// starting at start_heading_rad, facing along its path apart from a small yaw sway; legs and
// arms swing sinusoidally in opposite phase, knees and elbows flex, the root bobs. Root facing
// and path follow trajectory.h: heading(t) = start + turn_rate * t, velocity along
// (sin heading, 0, cos heading) for Y-up. Deterministic: equal arguments give equal motions.
// Throws mosyn::Error for num_frames < 0, fps <= 0 or a skeleton that is not Y-up.
Motion make_synthetic_walk(const Skeleton& skeleton, int num_frames, double fps,
                           const SyntheticWalkOptions& options = {});

}  // namespace mosyn
