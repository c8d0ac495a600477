#include "core/units.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mosyn {
namespace {

constexpr double kHumanHeightM = 1.7;
// Hand-to-foot path length over standing height for adult proportions.
constexpr double kPathPerHeight = 1.25;

struct Unit {
  double meters_per_unit;
  const char* name;
};
constexpr Unit kUnits[] = {{1.0, "metres"},     {0.01, "centimetres"}, {0.001, "millimetres"},
                           {0.0254, "inches"},  {0.3048, "feet"},      {0.056444, "CMU units (0.056444 m)"}};

}  // namespace

double estimate_height_units(const Skeleton& skeleton) {
  const int n = skeleton.num_joints();
  if (n == 0) return 0;
  // Tree diameter by dynamic programming over children (parents[j] < j): deepest[j] is the
  // longest downward path from joint j, including end sites.
  std::vector<double> deepest(n, 0.0), second(n, 0.0);
  auto offer = [&](int j, double length) {
    if (length > deepest[j]) {
      second[j] = deepest[j];
      deepest[j] = length;
    } else if (length > second[j]) {
      second[j] = length;
    }
  };
  for (const EndSite& e : skeleton.end_sites)
    if (e.parent >= 0 && e.parent < n) offer(e.parent, e.offset.norm());
  double diameter = 0;
  for (int j = n - 1; j >= 0; --j) {
    diameter = std::max(diameter, deepest[j] + second[j]);
    const int p = j < static_cast<int>(skeleton.parents.size()) ? skeleton.parents[j] : -1;
    if (p >= 0 && p < j && j < static_cast<int>(skeleton.offsets.size())) offer(p, deepest[j] + skeleton.offsets[j].norm());
  }
  return diameter / kPathPerHeight;
}

UnitsGuess guess_units(const Skeleton& skeleton) {
  UnitsGuess best;
  best.height_units = estimate_height_units(skeleton);
  best.name = kUnits[0].name;
  best.meters_per_unit = kUnits[0].meters_per_unit;
  best.height_m = best.height_units;
  if (!(best.height_units > 0)) return best;
  double best_error = INFINITY;
  for (const Unit& u : kUnits) {
    const double error = std::abs(std::log(best.height_units * u.meters_per_unit / kHumanHeightM));
    if (error < best_error) {
      best_error = error;
      best.meters_per_unit = u.meters_per_unit;
      best.name = u.name;
    }
  }
  best.height_m = best.height_units * best.meters_per_unit;
  return best;
}

double guess_meters_per_unit(const Skeleton& skeleton) { return guess_units(skeleton).meters_per_unit; }

double resolve_meters_per_unit(const Skeleton& skeleton, double requested) {
  if (requested > 0) return requested;
  return skeleton.meters_per_unit != 1.0 ? skeleton.meters_per_unit : guess_meters_per_unit(skeleton);
}

}  // namespace mosyn
