#include "core/foot_lock.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/kinematics.h"

namespace mosyn {
namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// p-th percentile (0..100) of values (copied).
double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(p / 100.0 * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

// Maximal runs [begin, end) of true values at least min_len long.
std::vector<std::pair<int, int>> runs_of(const std::vector<bool>& flags, int min_len) {
  std::vector<std::pair<int, int>> out;
  const int n = static_cast<int>(flags.size());
  for (int t = 0; t < n;) {
    if (!flags[t]) {
      ++t;
      continue;
    }
    int end = t;
    while (end < n && flags[end]) ++end;
    if (end - t >= min_len) out.emplace_back(t, end);
    t = end;
  }
  return out;
}

// Per-frame pinned target and weight (0 free .. 1 pinned) of one ankle.
struct AnkleTargets {
  std::vector<Eigen::Vector3d> target;
  std::vector<double> weight;
};

AnkleTargets pin_contacts(const Skeleton& skeleton, const WorldPoses& world, int ankle, const FootLockOptions& o,
                          double fps, FootLockReport* report) {
  const int n = world.num_frames;
  AnkleTargets out;
  out.target.assign(static_cast<size_t>(n), Eigen::Vector3d::Zero());
  out.weight.assign(static_cast<size_t>(n), 0.0);
  const int blend = contact_blend_frames(o, fps);
  for (const auto& [begin, end] : find_contacts(skeleton, world, ankle, o, fps)) {
    // One floor position per contact: the mean, which moves the ankle least overall.
    Eigen::Vector3d pin = Eigen::Vector3d::Zero();
    for (int t = begin; t < end; ++t) pin += world.position(t, ankle);
    pin /= (end - begin);
    ++report->contacts;
    for (int t = std::max(0, begin - blend); t < std::min(n, end + blend); ++t) {
      const double w = contact_weight(t, begin, end, blend);
      if (w <= out.weight[t]) continue;
      out.weight[t] = w;
      out.target[t] = pin;
    }
  }
  return out;
}

void check_options(const FootLockOptions& o) {
  if (!(o.contact_height_m > 0) || !(o.contact_speed_mps > 0) || !(o.min_contact_s >= 0) || !(o.blend_s >= 0))
    throw Error("foot lock: thresholds must be positive and durations non-negative");
}

// Shortest rotation taking direction a onto direction b (identity for degenerate input).
Eigen::Quaterniond rotation_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  if (a.norm() < 1e-12 || b.norm() < 1e-12) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond::FromTwoVectors(a, b);
}

}  // namespace

std::vector<std::pair<int, int>> find_contacts(const Skeleton& skeleton, const WorldPoses& world, int ankle,
                                               const FootLockOptions& o, double fps) {
  check_options(o);
  const int n = world.num_frames, up = skeleton.up_axis;
  const double mpu = skeleton.meters_per_unit > 0 ? skeleton.meters_per_unit : 1.0;
  std::vector<double> heights(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) heights[t] = world.position(t, ankle)[up];
  const double floor = percentile(heights, 5.0);
  std::vector<bool> contact(static_cast<size_t>(n), false);
  for (int t = 0; t < n; ++t) {
    const int a = std::max(t - 1, 0), b = std::min(t + 1, n - 1);
    Eigen::Vector3d d = world.position(b, ankle) - world.position(a, ankle);
    d[up] = 0;
    const double speed = b > a ? d.norm() * mpu * fps / (b - a) : 0.0;
    contact[t] = (heights[t] - floor) * mpu < o.contact_height_m && speed < o.contact_speed_mps;
  }
  return runs_of(contact, std::max(1, static_cast<int>(std::lround(o.min_contact_s * fps))));
}

int contact_blend_frames(const FootLockOptions& o, double fps) {
  return std::max(0, static_cast<int>(std::lround(o.blend_s * fps)));
}

double contact_weight(int t, int begin, int end, int blend_frames) {
  const int outside = t < begin ? begin - t : (t >= end ? t - end + 1 : 0);
  if (outside == 0) return 1.0;
  if (outside > blend_frames) return 0.0;
  return 0.5 * (1.0 + std::cos(M_PI * outside / (blend_frames + 1)));
}

void reach_with_leg(const Skeleton& skeleton, const WorldPoses& world, int t, const LegChain& leg,
                    const Eigen::Vector3d& target, Motion* motion, int motion_frame) {
  const Eigen::Vector3d hip = world.position(t, leg.hip), knee = world.position(t, leg.knee);
  const Eigen::Vector3d ankle = world.position(t, leg.ankle);
  const double upper = (knee - hip).norm(), lower = (ankle - knee).norm();
  const Eigen::Vector3d new_knee = two_bone_knee(hip, knee, target, upper, lower);
  const int hip_parent = skeleton.parents[leg.hip];
  const Eigen::Quaterniond parent_world = hip_parent >= 0 ? world.rotation(t, hip_parent) : Eigen::Quaterniond::Identity();
  // Hip: swing the thigh onto the new knee; knee: swing the shin onto the target.
  const Eigen::Quaterniond hip_world = rotation_between(knee - hip, new_knee - hip) * world.rotation(t, leg.hip);
  const Eigen::Vector3d shin = hip_world * (world.rotation(t, leg.hip).conjugate() * (ankle - knee));
  const Eigen::Quaterniond knee_local = world.rotation(t, leg.hip).conjugate() * world.rotation(t, leg.knee);
  const Eigen::Quaterniond knee_world = rotation_between(shin, target - new_knee) * (hip_world * knee_local);
  motion->rotation(motion_frame, leg.hip) = (parent_world.conjugate() * hip_world).normalized();
  motion->rotation(motion_frame, leg.knee) = (hip_world.conjugate() * knee_world).normalized();
  // The foot keeps its world orientation, so the toes stay flat where they were planted.
  motion->rotation(motion_frame, leg.ankle) = (knee_world.conjugate() * world.rotation(t, leg.ankle)).normalized();
}

std::vector<LegChain> find_legs(const Skeleton& skeleton) {
  std::vector<LegChain> legs;
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    const std::string name = lower(skeleton.joint_names[j]);
    if (name.find("toe") != std::string::npos || name.find("end") != std::string::npos) continue;
    if (name.find("foot") == std::string::npos && name.find("ankle") == std::string::npos) continue;
    const int knee = skeleton.parents[j];
    const int hip = knee >= 0 ? skeleton.parents[knee] : -1;
    if (hip < 0) continue;
    if (skeleton.offsets[j].norm() <= 0 || skeleton.offsets[knee].norm() <= 0) continue;
    legs.push_back({hip, knee, j});
  }
  return legs;
}

Eigen::Vector3d two_bone_knee(const Eigen::Vector3d& hip, const Eigen::Vector3d& knee, const Eigen::Vector3d& target,
                              double upper_length, double lower_length) {
  const Eigen::Vector3d to_target = target - hip;
  const double reach_max = upper_length + lower_length, reach_min = std::abs(upper_length - lower_length);
  const double d = std::clamp(to_target.norm(), reach_min + 1e-9 * reach_max, reach_max * (1 - 1e-9));
  const Eigen::Vector3d axis = to_target.norm() > 1e-12 ? to_target.normalized() : (knee - hip).normalized();
  // Bend towards the current knee: its offset from the hip-target line.
  Eigen::Vector3d pole = (knee - hip) - (knee - hip).dot(axis) * axis;
  if (pole.norm() < 1e-12) pole = axis.unitOrthogonal();
  pole.normalize();
  const double along = (upper_length * upper_length - lower_length * lower_length + d * d) / (2 * d);
  const double radius = std::sqrt(std::max(0.0, upper_length * upper_length - along * along));
  return hip + along * axis + radius * pole;
}

Motion foot_lock(const Skeleton& skeleton, const Motion& motion, const FootLockOptions& o, FootLockReport* report) {
  check_options(o);
  motion.validate();
  if (motion.num_joints != skeleton.num_joints()) throw Error("foot lock: motion and skeleton joint counts differ");
  FootLockReport local_report;
  FootLockReport* r = report ? report : &local_report;
  *r = FootLockReport{};
  Motion out = motion;
  const std::vector<LegChain> legs = find_legs(skeleton);
  if (legs.empty() || motion.num_frames < 2) return out;
  const WorldPoses world = forward_kinematics(skeleton, motion);
  const double mpu = skeleton.meters_per_unit > 0 ? skeleton.meters_per_unit : 1.0;
  const int up = skeleton.up_axis;
  for (const LegChain& leg : legs) {
    const AnkleTargets pins = pin_contacts(skeleton, world, leg.ankle, o, motion.fps, r);
    for (int t = 0; t < motion.num_frames; ++t) {
      if (pins.weight[t] <= 0) continue;
      const Eigen::Vector3d ankle = world.position(t, leg.ankle);
      Eigen::Vector3d target = ankle + pins.weight[t] * (pins.target[t] - ankle);
      target[up] = ankle[up];  // horizontal pin only: the ankle keeps its own height (lift and roll)
      r->max_correction_m = std::max(r->max_correction_m, (target - ankle).norm() * mpu);
      reach_with_leg(skeleton, world, t, leg, target, &out, t);
    }
  }
  return out;
}

StreamingFootLock::StreamingFootLock(const Skeleton& skeleton, double fps, const FootLockOptions& options)
    : skeleton_(skeleton), options_(options), fps_(fps), legs_(find_legs(skeleton)) {
  if (!(fps > 0)) throw Error("foot lock: fps must be positive");
  check_options(options);
  states_.resize(legs_.size());
}

void StreamingFootLock::reset() { states_.assign(legs_.size(), LegState{}); }

Motion StreamingFootLock::apply(const Motion& frame) {
  if (frame.num_frames != 1 || frame.num_joints != skeleton_.num_joints())
    throw Error("foot lock: streaming frames must be one frame of the skeleton's joints");
  Motion out = frame;
  if (legs_.empty()) return out;
  const WorldPoses world = forward_kinematics(skeleton_, frame);
  const double mpu = skeleton_.meters_per_unit > 0 ? skeleton_.meters_per_unit : 1.0;
  const int up = skeleton_.up_axis;
  const size_t history = static_cast<size_t>(std::max(1.0, 2.0 * fps_));  // floor: lowest of the last 2 s
  const double blend_step = options_.blend_s > 0 ? 1.0 / (options_.blend_s * fps_) : 1.0;
  for (size_t k = 0; k < legs_.size(); ++k) {
    LegState& st = states_[k];
    const Eigen::Vector3d ankle = world.position(0, legs_[k].ankle);
    st.heights.push_back(ankle[up]);
    if (st.heights.size() > history) st.heights.pop_front();
    const double floor = *std::min_element(st.heights.begin(), st.heights.end());
    const double above_m = (ankle[up] - floor) * mpu;
    Eigen::Vector3d moved = st.has_previous ? Eigen::Vector3d(ankle - st.previous) : Eigen::Vector3d::Zero();
    moved[up] = 0;
    const double speed = moved.norm() * mpu * fps_;
    st.previous = ankle;
    st.has_previous = true;
    Eigen::Vector3d from_pin = ankle - st.pin;
    from_pin[up] = 0;
    if (!st.contact && above_m < options_.contact_height_m && speed < options_.contact_speed_mps) {
      st.contact = true;
      st.pin = ankle;
    } else if (st.contact && (above_m > 1.5 * options_.contact_height_m || from_pin.norm() * mpu > kMaxStretchM)) {
      st.contact = false;  // lifted, or pulled too far by the body: let go and blend out
    }
    st.weight = st.contact ? std::min(1.0, st.weight + blend_step) : std::max(0.0, st.weight - blend_step);
    if (st.weight <= 0) continue;
    Eigen::Vector3d target = ankle + st.weight * (st.pin - ankle);
    target[up] = ankle[up];
    reach_with_leg(skeleton_, world, 0, legs_[k], target, &out, 0);
  }
  return out;
}

}  // namespace mosyn
