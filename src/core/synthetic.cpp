#include "core/synthetic.h"

#include <cmath>
#include <random>
#include <string>

#include "core/error.h"

namespace mosyn {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Quaterniond rot_x(double a) { return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX())); }
Eigen::Quaterniond rot_y(double a) { return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY())); }
Eigen::Quaterniond rot_z(double a) { return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ())); }

}  // namespace

Skeleton make_synthetic_biped() {
  Skeleton s;
  s.meters_per_unit = 0.01;
  s.up_axis = 1;
  auto add = [&](const std::string& name, int parent, const Eigen::Vector3d& offset) {
    s.joint_names.push_back(name);
    s.parents.push_back(parent);
    s.offsets.push_back(offset);
    return s.num_joints() - 1;
  };
  const int hips = add("Hips", -1, {0, 96, 0});
  add("Spine", hips, {0, 10, 0});
  const int chest = add("Chest", 1, {0, 15, 0});
  add("Neck", chest, {0, 20, 0});
  const int head = add("Head", 3, {0, 10, 0});
  s.end_sites.push_back({head, {0, 15, 0}});
  int hands[2], toes[2];
  for (int k = 0; k < 2; ++k) {  // left (+X) then right (-X)
    const double x = k == 0 ? 1.0 : -1.0;
    const std::string suffix = k == 0 ? "_L" : "_R";
    const int shoulder = add("Shoulder" + suffix, chest, {x * 5, 15, 0});
    const int upper = add("UpperArm" + suffix, shoulder, {x * 12, 0, 0});
    const int lower = add("LowerArm" + suffix, upper, {x * 28, 0, 0});
    hands[k] = add("Hand" + suffix, lower, {x * 25, 0, 0});
  }
  for (int k = 0; k < 2; ++k) {
    const double x = k == 0 ? 1.0 : -1.0;
    const std::string suffix = k == 0 ? "_L" : "_R";
    const int upper = add("UpperLeg" + suffix, hips, {x * 9, -5, 0});
    const int lower = add("LowerLeg" + suffix, upper, {0, -42, 0});
    const int foot = add("Foot" + suffix, lower, {0, -43, 0});
    toes[k] = add("Toes" + suffix, foot, {0, -6, 12});
  }
  for (int k = 0; k < 2; ++k) s.end_sites.push_back({hands[k], {(k == 0 ? 10.0 : -10.0), 0, 0}});
  for (int k = 0; k < 2; ++k) s.end_sites.push_back({toes[k], {0, 0, 6}});
  return s;
}

Motion make_synthetic_walk(const Skeleton& skeleton, int num_frames, double fps, const SyntheticWalkOptions& o) {
  if (num_frames < 0) throw Error("synthetic walk: negative frame count");
  if (!(fps > 0)) throw Error("synthetic walk: fps must be positive");
  if (skeleton.up_axis != 1) throw Error("synthetic walk: the skeleton must be Y-up");
  skeleton.validate();
  Motion m = Motion::rest(skeleton, num_frames, fps);
  const double units_per_m = 1.0 / skeleton.meters_per_unit;
  const double v = o.speed_mps * units_per_m, w = o.turn_rate_rad_s;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);

  auto set = [&](int t, const char* name, const Eigen::Quaterniond& q) {
    const int j = skeleton.find(name);
    if (j >= 0) m.rotation(t, j) = q;
  };
  for (int t = 0; t < num_frames; ++t) {
    const double time = t / fps;
    const double phase = 2 * kPi * o.cycle_hz * time;
    const double s = std::sin(phase);
    const double heading = o.start_heading_rad + w * time;

    // Root path: the integral of v (sin heading, 0, cos heading), in closed form.
    Eigen::Vector3d root = skeleton.offsets[0];
    if (std::abs(w) > 1e-12) {
      root.x() += v / w * (std::cos(o.start_heading_rad) - std::cos(heading));
      root.z() += v / w * (std::sin(heading) - std::sin(o.start_heading_rad));
    } else {
      root.x() += v * time * std::sin(heading);
      root.z() += v * time * std::cos(heading);
    }
    root.y() += o.bob_m * units_per_m * std::cos(2 * phase);
    m.translation(t, 0) = root;
    m.rotation(t, 0) = rot_y(heading + o.sway_rad * s) * rot_x(0.05) * rot_z(o.sway_rad * std::cos(phase));

    // Left leg forward when s > 0 (negative rotation about X swings a hanging limb to +Z).
    set(t, "Spine", rot_y(-0.5 * o.sway_rad * s));
    set(t, "Chest", rot_y(-0.5 * o.sway_rad * s));
    set(t, "Neck", rot_x(-0.05));
    set(t, "UpperLeg_L", rot_x(-o.leg_swing_rad * s));
    set(t, "UpperLeg_R", rot_x(o.leg_swing_rad * s));
    set(t, "LowerLeg_L", rot_x(0.6 * (0.5 + 0.5 * std::sin(phase + 1.2))));
    set(t, "LowerLeg_R", rot_x(0.6 * (0.5 - 0.5 * std::sin(phase + 1.2))));
    set(t, "Foot_L", rot_x(-0.2 * std::cos(phase)));
    set(t, "Foot_R", rot_x(0.2 * std::cos(phase)));
    // Arms hang 80 degrees down from the T-pose and swing opposite to the legs.
    set(t, "UpperArm_L", rot_x(o.arm_swing_rad * s) * rot_z(-80 * kPi / 180));
    set(t, "UpperArm_R", rot_x(-o.arm_swing_rad * s) * rot_z(80 * kPi / 180));
    // Elbows flex forward (+Z): about -Y for the left forearm (along +X), +Y for the right.
    set(t, "LowerArm_L", rot_y(-0.3 - 0.15 * s));
    set(t, "LowerArm_R", rot_y(0.3 - 0.15 * s));

    if (o.noise_rad > 0)
      for (int j = 0; j < m.num_joints; ++j) {
        const Eigen::Vector3d e(normal(rng), normal(rng), normal(rng));
        const Eigen::Vector3d n = e * o.noise_rad;
        const double angle = n.norm();
        if (angle > 0) m.rotation(t, j) = (m.rotation(t, j) * Eigen::Quaterniond(Eigen::AngleAxisd(angle, n / angle))).normalized();
      }
  }
  return m;
}

}  // namespace mosyn
