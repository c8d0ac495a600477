// Guessing the length unit of a skeleton (BVH files do not say).
#pragma once

#include <string>

#include "core/skeleton.h"

namespace mosyn {

struct UnitsGuess {
  double meters_per_unit = 1.0;  // e.g. 0.01
  std::string name;              // "metres", "centimetres", "millimetres", "inches", "feet",
                                 // "CMU units (0.056444 m)"
  double height_units = 0;       // estimated standing height, skeleton units
  double height_m = 0;           // height_units * meters_per_unit
};

// Estimated standing height in skeleton units, from bone lengths only so that any rest pose
// works (Bandai-Namco's lies along +X): the longest path between two leaves of the hierarchy,
// end sites included (hand to foot for a human, about 1.25 body heights), divided by 1.25.
// 0 for a skeleton with no bones.
double estimate_height_units(const Skeleton& skeleton);

// The candidate unit (metres 1, centimetres 0.01, millimetres 0.001, inches 0.0254, feet 0.3048,
// CMU units 0.056444) that puts the estimated height closest to a 1.7 m human in log scale:
// neighbouring candidates differ by at least x2.2, so a human-sized skeleton of about 1.15..2.5 m
// (as estimated) in any of them is recognised. Centimetres for Bandai-Namco, CMU units for the CMU 31-joint skeleton.
// Returns metres (1.0) for a skeleton with no bones.
UnitsGuess guess_units(const Skeleton& skeleton);

// guess_units(skeleton).meters_per_unit.
double guess_meters_per_unit(const Skeleton& skeleton);

// Metres per skeleton unit to use: `requested` when positive, else the skeleton's own value when
// it has been set (anything but 1, the value io leaves on parsed files), else the guess.
double resolve_meters_per_unit(const Skeleton& skeleton, double requested = 0);

}  // namespace mosyn
