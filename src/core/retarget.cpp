#include "core/retarget.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/joint_names.h"
#include "core/kinematics.h"
#include "core/units.h"

namespace mosyn {
namespace {

using Quat = Eigen::Quaterniond;
using Vec3 = Eigen::Vector3d;

constexpr double kStandingCos = 0.8;  // legs within ~37 degrees of down, spine of up: standing

// Shortest rotation taking direction a onto b; identity when either is (nearly) zero. Opposite
// directions turn about `fallback_axis` (the up axis keeps a half turn a yaw).
Quat swing(const Vec3& a, const Vec3& b, const Vec3& fallback_axis = Vec3::UnitY()) {
  if (a.norm() < 1e-12 || b.norm() < 1e-12) return Quat::Identity();
  if (a.normalized().dot(b.normalized()) < -1 + 1e-9) {
    Vec3 axis = fallback_axis - fallback_axis.dot(a.normalized()) * a.normalized();
    if (axis.norm() < 1e-9) axis = a.unitOrthogonal();
    return Quat(Eigen::AngleAxisd(M_PI, axis.normalized()));
  }
  return Quat::FromTwoVectors(a, b);
}

// Which rig joint is which, and which input joint drives it.
struct Pairing {
  std::vector<int> source_of;      // [J_rig] input joint, or -1
  std::vector<JointPart> part;     // [J_rig] from the rig joint's name, else from its partner's
  std::vector<int> aim;            // [J_rig] paired rig joint below whose bone the joint aims, or -1
  int hips = -1;                   // rig joints
  int spine_top = -1;              // the neck, else the last spine joint
  int thigh[2] = {-1, -1}, shin[2] = {-1, -1}, foot[2] = {-1, -1}, toe[2] = {-1, -1};  // [left, right]
};

int first_part(const Pairing& p, BodyPart part, BodySide side) {
  for (size_t j = 0; j < p.part.size(); ++j)
    if (p.source_of[j] >= 0 && p.part[j].part == part && p.part[j].side == side) return static_cast<int>(j);
  return -1;
}

// The paired joint below j that j's bone aims at: the only one, or the only one up the body
// (spine, neck, head: what the hips and chest point at, not the legs and arms beside them).
// Feet never aim: rigs differ in ankle height and foot length, so a foot turned onto the input's
// ankle-to-toe line would put its toes through the floor; it keeps its turn from the reference
// pose instead (flat stays flat).
int aim_of(const Skeleton& rig, const Pairing& p, int j) {
  if (p.part[j].part == BodyPart::kFoot || p.part[j].part == BodyPart::kToe) return -1;
  std::vector<int> below;
  for (int k = j + 1; k < rig.num_joints(); ++k) {
    int a = rig.parents[k];
    while (a >= 0 && a != j && p.source_of[a] < 0) a = rig.parents[a];
    if (a == j && p.source_of[k] >= 0) below.push_back(k);
  }
  if (below.size() == 1) return below[0];
  int up = -1, count = 0;
  for (int k : below) {
    const BodyPart part = p.part[k].part;
    if (part == BodyPart::kSpine || part == BodyPart::kNeck || part == BodyPart::kHead) {
      if (up < 0) up = k;
      ++count;
    }
  }
  return count >= 1 ? up : -1;
}

Pairing pair_joints(const Skeleton& source, const Skeleton& rig, const RetargetOptions& options,
                    RetargetReport* report) {
  Pairing p;
  p.source_of = match_joints(source, rig, options.joint_map);
  for (int j = 0; j < rig.num_joints(); ++j) {
    // The pair's part: the rig joint's name says it, else the input joint's (as match_joints).
    JointPart part = classify_joint_name(rig.joint_names[j]);
    if (p.source_of[j] >= 0 && part.part == BodyPart::kNone) part = classify_joint_name(source.joint_names[p.source_of[j]]);
    p.part.push_back(part);
    if (p.source_of[j] >= 0) report->pairs.emplace_back(rig.joint_names[j], source.joint_names[p.source_of[j]]);
  }
  p.aim.resize(p.part.size());
  for (int j = 0; j < rig.num_joints(); ++j) p.aim[j] = p.source_of[j] >= 0 ? aim_of(rig, p, j) : -1;
  p.hips = first_part(p, BodyPart::kHips, BodySide::kCentre);
  for (int j = 0; j < rig.num_joints(); ++j)
    if (p.source_of[j] >= 0 && (p.part[j].part == BodyPart::kSpine || p.part[j].part == BodyPart::kNeck))
      if (p.spine_top < 0 || p.part[p.spine_top].part != BodyPart::kNeck) p.spine_top = j;
  for (int s = 0; s < 2; ++s) {
    const BodySide side = s == 0 ? BodySide::kLeft : BodySide::kRight;
    p.thigh[s] = first_part(p, BodyPart::kThigh, side);
    p.shin[s] = first_part(p, BodyPart::kShin, side);
    p.foot[s] = first_part(p, BodyPart::kFoot, side);
    p.toe[s] = first_part(p, BodyPart::kToe, side);
  }
  return p;
}

// The body's landmarks on one side of the pairing: rig joints, or their input partners.
struct Landmarks {
  int hips, spine_top, thigh[2], shin[2], foot[2], toe[2];  // toe -1 where the rig has none
};

Landmarks landmarks(const Pairing& p, bool of_source) {
  auto at = [&](int j) { return j < 0 ? -1 : of_source ? p.source_of[j] : j; };
  return {at(p.hips),
          at(p.spine_top),
          {at(p.thigh[0]), at(p.thigh[1])},
          {at(p.shin[0]), at(p.shin[1])},
          {at(p.foot[0]), at(p.foot[1])},
          {at(p.toe[0]), at(p.toe[1])}};
}

bool stands(const WorldPoses& pose, const Landmarks& l, const Vec3& up) {
  for (int s = 0; s < 2; ++s) {
    const Vec3 leg = pose.position(0, l.foot[s]) - pose.position(0, l.thigh[s]);
    if (leg.norm() < 1e-12 || leg.normalized().dot(-up) < kStandingCos) return false;
  }
  const Vec3 spine = pose.position(0, l.spine_top) - pose.position(0, l.hips);
  return spine.norm() < 1e-12 || spine.normalized().dot(up) >= kStandingCos;
}

// Height above the lowest height over the frames, along up, of joint j at frame t.
double above_lowest(const WorldPoses& w, int t, int j, const Vec3& up) {
  double lowest = w.position(0, j).dot(up);
  for (int u = 1; u < w.num_frames; ++u) lowest = std::min(lowest, w.position(u, j).dot(up));
  return w.position(t, j).dot(up) - lowest;
}

// The frame of `frames` that stands with both ankles nearest their lowest heights (both feet
// down, so flat), or -1 when no frame stands.
int standing_frame(const Skeleton& skeleton, const Motion& frames, const Landmarks& l) {
  if (frames.num_frames == 0) return -1;
  const Vec3 up = Vec3::Unit(skeleton.up_axis);
  const WorldPoses w = forward_kinematics(skeleton, frames);
  std::vector<double> lowest(2);
  for (int s = 0; s < 2; ++s) lowest[s] = w.position(0, l.foot[s]).dot(up) - above_lowest(w, 0, l.foot[s], up);
  int best = -1;
  double best_height = 0;
  for (int t = 0; t < frames.num_frames; ++t) {
    const double height = std::max(w.position(t, l.foot[0]).dot(up) - lowest[0], w.position(t, l.foot[1]).dot(up) - lowest[1]);
    if (best >= 0 && height >= best_height) continue;
    Motion one = Motion::rest(skeleton, 1, frames.fps);
    for (int j = 0; j < skeleton.num_joints(); ++j) {
      one.rotation(0, j) = frames.rotation(t, j);
      one.translation(0, j) = frames.translation(t, j);
    }
    if (!stands(forward_kinematics(skeleton, one), l, up)) continue;
    best = t;
    best_height = height;
  }
  return best;
}

// A one-frame motion: the rest pose (rest_rotations or identity, rest offsets) when it stands,
// else the frame of `frames` that stands with both feet down. *rest says which.
Motion reference_pose(const Skeleton& skeleton, const std::vector<Quat>& rest_rotations, const Motion& frames,
                      const Landmarks& l, const std::string& what, bool* rest) {
  const Vec3 up = Vec3::Unit(skeleton.up_axis);
  Motion pose = Motion::rest(skeleton, 1, 30.0);
  if (!rest_rotations.empty()) pose.rotations = rest_rotations;
  *rest = true;
  if (stands(forward_kinematics(skeleton, pose), l, up)) return pose;
  *rest = false;
  const int t = standing_frame(skeleton, frames, l);
  if (t < 0)
    throw Error("retarget: neither the rest pose nor any frame of the " + what +
                " stands (legs down, spine up along the up axis): cannot align its rest pose");
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    pose.rotation(0, j) = frames.rotation(t, j);
    pose.translation(0, j) = frames.translation(t, j);
  }
  return pose;
}

// Yaw (about up) turning the input's reference pose to face the rig's: left hip onto left hip.
Quat facing_turn(const WorldPoses& source_ref, const Landmarks& ls, const WorldPoses& rig_ref, const Landmarks& lr,
                 const Vec3& up) {
  auto left_of = [&](const WorldPoses& w, const Landmarks& l) {
    Vec3 left = w.position(0, l.thigh[0]) - w.position(0, l.thigh[1]);
    return Vec3(left - left.dot(up) * up);
  };
  return swing(left_of(source_ref, ls), left_of(rig_ref, lr), up);
}

// Mean length of the two legs (hip to knee to ankle) in a one-frame pose.
double leg_length(const WorldPoses& pose, const Landmarks& l) {
  double sum = 0;
  for (int s = 0; s < 2; ++s)
    sum += (pose.position(0, l.shin[s]) - pose.position(0, l.thigh[s])).norm() +
           (pose.position(0, l.foot[s]) - pose.position(0, l.shin[s])).norm();
  return sum / 2;
}

// Height of the ankle above the toe joint below it when the foot is down: the difference of their
// lowest heights over the frames of `w` (a standing pose will do). 0 without a toe.
double toe_drop(const WorldPoses& w, int foot, int toe, const Vec3& up) {
  if (toe < 0) return 0;
  return (w.position(0, foot).dot(up) - above_lowest(w, 0, foot, up)) -
         (w.position(0, toe).dot(up) - above_lowest(w, 0, toe, up));
}

// What stays constant over the frames.
struct Alignment {
  std::vector<Quat> rig_from_source;  // [J_rig] C_j: rig world rotation = input world rotation * C_j
  std::vector<Vec3> aim_local;        // [J_rig] the bone to aim[j] in joint j's frame, rig units
  Motion rig_reference;               // one frame
  double scale = 1;                   // rig units per input unit
  // Rig units along up added to the scaled path: the rig's ankle height above its toe joints minus
  // the input's, scaled, so the rig's toes stand on the input's floor, scaled.
  double lift = 0;
  // The midpoint of the rig's hip sockets (thigh joints) in its hips' frame: the path is the
  // sockets', so rigs whose hips joint sits higher above the legs stand as tall.
  Vec3 sockets_local = Vec3::Zero();
};

// The rig's toes stand where the input's do, scaled: the difference of the ankles' heights above
// the toes in the two reference poses (both standing, feet down).
double lift_of(const WorldPoses& source_reference, const WorldPoses& rig_reference, const Pairing& p, double scale,
               const Vec3& up) {
  const Landmarks ls = landmarks(p, true), lr = landmarks(p, false);
  double lift = 0;
  for (int s = 0; s < 2; ++s) {
    if (lr.toe[s] < 0) return 0;
    lift += 0.5 * (toe_drop(rig_reference, lr.foot[s], lr.toe[s], up) -
                   scale * toe_drop(source_reference, ls.foot[s], ls.toe[s], up));
  }
  return lift;
}

Alignment align(const Skeleton& source, const WorldPoses& sref, const RetargetRig& rig, const Motion& rig_reference,
                const Pairing& p) {
  const Skeleton& sk = rig.skeleton;
  const WorldPoses rref = forward_kinematics(sk, rig_reference);
  const Landmarks ls = landmarks(p, true), lr = landmarks(p, false);
  const Vec3 up = Vec3::Unit(sk.up_axis);
  const Quat turn = facing_turn(sref, ls, rref, lr, up);
  Alignment a;
  a.rig_reference = rig_reference;
  const double source_leg = leg_length(sref, ls);
  if (!(source_leg > 0)) throw Error("retarget: the input's legs have no length");
  a.scale = leg_length(rref, lr) / source_leg;
  a.lift = lift_of(sref, rref, p, a.scale, up);
  a.sockets_local = rref.rotation(0, p.hips).conjugate() *
                    (0.5 * (rref.position(0, lr.thigh[0]) + rref.position(0, lr.thigh[1])) - rref.position(0, p.hips));
  const int n = sk.num_joints();
  a.rig_from_source.assign(n, Quat::Identity());
  a.aim_local.assign(n, Vec3::Zero());
  std::vector<Quat> bent(n);  // the rig's reference pose bent onto the input's bone directions
  for (int j = 0; j < n; ++j) {
    const int parent = sk.parents[j];
    bent[j] = (parent < 0 ? Quat::Identity() : bent[parent]) * rig_reference.rotation(0, j);
    const int s = p.source_of[j];
    if (s < 0) continue;
    // Feet stand flat in both reference poses whatever the legs above them do: they keep their
    // world orientation rather than riding on the shins' swings.
    const BodyPart part = p.part[j].part;
    if (part == BodyPart::kFoot || part == BodyPart::kToe) bent[j] = rref.rotation(0, j);
    const int k = p.aim[j];
    if (k >= 0) {
      a.aim_local[j] = rref.rotation(0, j).conjugate() * (rref.position(0, k) - rref.position(0, j));
      const Vec3 wanted = turn * (sref.position(0, p.source_of[k]) - sref.position(0, s));
      bent[j] = swing(bent[j] * a.aim_local[j], wanted, up) * bent[j];
    }
    a.rig_from_source[j] = (sref.rotation(0, s).conjugate() * turn.conjugate() * bent[j]).normalized();
  }
  return a;
}

// Frame t's local rotations: paired joints from the input's world rotations, aimed along the
// input's bones; unpaired ones as in the reference pose. Returns the world rotations.
std::vector<Quat> pose_frame(const Skeleton& rig, const Pairing& p, const Alignment& a, const WorldPoses& source_world,
                             int t, Motion* out) {
  const int n = rig.num_joints();
  std::vector<Quat> world(n);
  for (int j = 0; j < n; ++j) {
    const int parent = rig.parents[j], s = p.source_of[j];
    const Quat parent_world = parent < 0 ? Quat::Identity() : world[parent];
    if (s < 0) {
      world[j] = parent_world * a.rig_reference.rotation(0, j);
    } else {
      Quat w = source_world.rotation(t, s) * a.rig_from_source[j];
      const int k = p.aim[j];
      if (k >= 0)
        w = swing(w * a.aim_local[j], source_world.position(t, p.source_of[k]) - source_world.position(t, s),
                  Vec3::Unit(rig.up_axis)) * w;
      world[j] = w.normalized();
    }
    out->rotation(t, j) = (parent_world.conjugate() * world[j]).normalized();
  }
  return world;
}

// Frame t's translations: rest offsets (the reference's for the root), the hips moved to the
// input's scaled position through the hips when the rig can translate them, else the root.
// Moves frame t's hips by `delta` (world, rig units): through the hips' translation when the rig
// can translate them (hips_parent_world: their parent's world rotation), else the root's.
void move_path(const RetargetRig& rig, const Pairing& p, const Quat& hips_parent_world, const Vec3& delta, int t,
               Motion* out) {
  const bool hips_move = p.hips == 0 || rig.translatable.empty() || rig.translatable[p.hips];
  if (hips_move && p.hips != 0)
    out->translation(t, p.hips) += hips_parent_world.conjugate() * delta;
  else
    out->translation(t, 0) += delta;
}

void place_hips(const RetargetRig& rig, const Pairing& p, const Alignment& a, const std::vector<Quat>& world,
                const Vec3& hips_target, int t, Motion* out) {
  const Skeleton& sk = rig.skeleton;
  for (int j = 0; j < sk.num_joints(); ++j) out->translation(t, j) = sk.offsets[j];
  out->translation(t, 0) = a.rig_reference.translation(0, 0);
  std::vector<int> path;  // hips up to the root
  for (int j = p.hips; j >= 0; j = sk.parents[j]) path.push_back(j);
  Vec3 at = out->translation(t, 0);
  for (size_t i = path.size() - 1; i-- > 0;) at += world[sk.parents[path[i]]] * out->translation(t, path[i]);
  move_path(rig, p, world[sk.parents[p.hips] < 0 ? 0 : sk.parents[p.hips]], hips_target - at, t, out);
}

// p5 over the frames of the lowest height of the given joints: where they stand.
double floor_of(const WorldPoses& w, const std::vector<int>& joints, const Vec3& up) {
  std::vector<double> lowest(static_cast<size_t>(w.num_frames));
  for (int t = 0; t < w.num_frames; ++t) {
    lowest[t] = w.position(t, joints[0]).dot(up);
    for (int j : joints) lowest[t] = std::min(lowest[t], w.position(t, j).dot(up));
  }
  const size_t k = static_cast<size_t>(0.05 * (lowest.size() - 1) + 0.5);
  std::nth_element(lowest.begin(), lowest.begin() + static_cast<long>(k), lowest.end());
  return lowest[k];
}

// Moves the whole body so the rig's feet (ankles and toes) stand on the input's floor, scaled:
// the lift (reference poses) gets it close, the contacts' IK may leave it off by a little.
void level_floor(const WorldPoses& sw, const RetargetRig& rig, const Pairing& p, double scale, Motion* out) {
  std::vector<int> rig_feet, source_feet;
  for (int s = 0; s < 2; ++s)
    for (int j : {p.foot[s], p.toe[s]})
      if (j >= 0) {
        rig_feet.push_back(j);
        source_feet.push_back(p.source_of[j]);
      }
  const Vec3 up = Vec3::Unit(rig.skeleton.up_axis);
  const WorldPoses rw = forward_kinematics(rig.skeleton, *out);
  const double shift = scale * floor_of(sw, source_feet, up) - floor_of(rw, rig_feet, up);
  const int parent = rig.skeleton.parents[p.hips];
  for (int t = 0; t < out->num_frames; ++t)
    move_path(rig, p, parent < 0 ? Quat::Identity() : rw.rotation(t, parent), shift * up, t, out);
}

// How still joint j of the input is at frame t, 0..1: (1 - horizontal speed / the contact speed)^2,
// so pins sit where the input's foot rests, not where it slides in or out.
double stillness(const Skeleton& source, const WorldPoses& sw, int j, int t, const RetargetOptions& o, double fps) {
  const Vec3 up = Vec3::Unit(source.up_axis);
  Vec3 step = sw.position(std::min(t + 1, sw.num_frames - 1), j) - sw.position(std::max(t - 1, 0), j);
  step -= step.dot(up) * up;
  const double speed_mps = step.norm() * source.meters_per_unit * fps / 2;
  return std::pow(std::max(1e-3, 1 - speed_mps / o.contacts.contact_speed_mps), 2);
}

// Per frame, the largest contact weight of one ankle and its target there.
struct Plant {
  std::vector<double> weight;
  std::vector<Vec3> target;
};

Plant plan_plant(const Skeleton& source, const WorldPoses& sw, int source_ankle, const WorldPoses& rw, int rig_ankle,
                 const Alignment& a, const RetargetOptions& o, double fps, int* contacts) {
  const int n = sw.num_frames;
  const Vec3 up = Vec3::Unit(source.up_axis);
  Plant plant{std::vector<double>(n, 0.0), std::vector<Vec3>(n, Vec3::Zero())};
  const int blend = contact_blend_frames(o.contacts, fps);
  for (const auto& [begin, end] : find_contacts(source, sw, source_ankle, o.contacts, fps)) {
    ++*contacts;
    // One floor position per contact, horizontally: the rig's own ankle (its own stance, hip width
    // and proportions) averaged over the contact, weighted to where the input's ankle is stillest
    // (a heel still sliding in at the start pulls the pin least); vertically the input's ankle,
    // scaled.
    Vec3 pin = Vec3::Zero();
    double total = 0;
    for (int t = begin; t < end; ++t) {
      const double w = stillness(source, sw, source_ankle, t, o, fps);
      pin += w * rw.position(t, rig_ankle);
      total += w;
    }
    pin /= total;
    pin -= pin.dot(up) * up;
    for (int t = std::max(0, begin - blend); t < std::min(n, end + blend); ++t) {
      const double w = contact_weight(t, begin, end, blend);
      if (w <= plant.weight[t]) continue;
      plant.weight[t] = w;
      plant.target[t] = pin + (a.scale * sw.position(t, source_ankle).dot(up) + a.lift) * up;
    }
  }
  return plant;
}

// While the input's toe is down, the rig's toe stays where it rests (after the ankle's contact
// has placed the foot), rising as the input's toe does, so the foot pivots about its toe as the
// heel lifts: the ankle moves by the toe's correction, the foot keeping its orientation; blended
// in and out like the ankle's contacts.
void plant_toe(const Skeleton& source, const WorldPoses& sw, const RetargetRig& rig, const Pairing& p, int side,
               const Alignment& a, const RetargetOptions& o, Motion* out) {
  const Skeleton& sk = rig.skeleton;
  const int toe = p.toe[side], foot = p.foot[side];
  if (toe < 0 || sk.parents[toe] != foot) return;
  const LegChain leg{p.thigh[side], p.shin[side], foot};
  const WorldPoses rw = forward_kinematics(sk, *out);
  const Vec3 up = Vec3::Unit(sk.up_axis);
  const int n = out->num_frames, blend = contact_blend_frames(o.contacts, out->fps);
  const int source_toe = p.source_of[toe];
  std::vector<double> weight(static_cast<size_t>(n), 0.0);
  std::vector<Vec3> target(static_cast<size_t>(n), Vec3::Zero());
  for (const auto& [begin, end] : find_contacts(source, sw, source_toe, o.contacts, out->fps)) {
    // Where the rig's toe rests over the contact (weighted to the input's stillest frames), and
    // its height there above the input's toe, scaled.
    Vec3 pin = Vec3::Zero();
    double rise = 0, total = 0;
    for (int t = begin; t < end; ++t) {
      const double w = stillness(source, sw, source_toe, t, o, out->fps);
      pin += w * rw.position(t, toe);
      rise += w * (rw.position(t, toe).dot(up) - a.scale * sw.position(t, source_toe).dot(up));
      total += w;
    }
    pin /= total;
    pin -= pin.dot(up) * up;
    rise /= total;
    for (int t = std::max(0, begin - blend); t < std::min(n, end + blend); ++t) {
      const double w = contact_weight(t, begin, end, blend);
      if (w <= weight[t]) continue;
      weight[t] = w;
      target[t] = pin + (a.scale * sw.position(t, source_toe).dot(up) + rise) * up;
    }
  }
  for (int t = 0; t < n; ++t)
    if (weight[t] > 0)
      reach_with_leg(sk, rw, t, leg, rw.position(t, foot) + weight[t] * (target[t] - rw.position(t, toe)), out, t);
}

// Two-bone IK of each leg whose thigh, shin and foot are parent and child, onto the input's
// contacts (see the top of retarget.h).
void plant_feet(const Skeleton& source, const WorldPoses& sw, const RetargetRig& rig, const Pairing& p,
                const Alignment& a, const RetargetOptions& o, Motion* out, int* contacts) {
  const Skeleton& sk = rig.skeleton;
  const WorldPoses rw = forward_kinematics(sk, *out);
  bool planted[2] = {false, false};
  for (int s = 0; s < 2; ++s) {
    const LegChain leg{p.thigh[s], p.shin[s], p.foot[s]};
    if (sk.parents[leg.ankle] != leg.knee || sk.parents[leg.knee] != leg.hip) continue;
    const Plant plant = plan_plant(source, sw, p.source_of[leg.ankle], rw, leg.ankle, a, o, out->fps, contacts);
    for (int t = 0; t < out->num_frames; ++t) {
      if (plant.weight[t] <= 0) continue;
      const Vec3 free = rw.position(t, leg.ankle);
      reach_with_leg(sk, rw, t, leg, free + plant.weight[t] * (plant.target[t] - free), out, t);
    }
    planted[s] = true;
  }
  for (int s = 0; s < 2; ++s)
    if (planted[s]) plant_toe(source, sw, rig, p, s, a, o, out);
}

void check_inputs(const Skeleton& source, const Motion& motion, const RetargetRig& rig) {
  source.validate();
  motion.validate();
  rig.skeleton.validate();
  const int n = rig.skeleton.num_joints();
  if (motion.num_joints != source.num_joints())
    throw Error("retarget: the motion has " + std::to_string(motion.num_joints) + " joints, its skeleton " +
                std::to_string(source.num_joints()));
  if (!rig.rest_rotations.empty() && static_cast<int>(rig.rest_rotations.size()) != n)
    throw Error("retarget: the rig has " + std::to_string(rig.rest_rotations.size()) + " rest rotations for " +
                std::to_string(n) + " joints");
  if (!rig.translatable.empty() && static_cast<int>(rig.translatable.size()) != n)
    throw Error("retarget: the rig's translatable flags do not match its joints");
  if (rig.frames.num_frames > 0) {
    rig.frames.validate();
    if (rig.frames.num_joints != n) throw Error("retarget: the rig's frames do not match its joints");
  }
  for (const Quat& q : rig.rest_rotations)
    if (!q.coeffs().allFinite() || std::abs(q.norm() - 1) > 1e-3)
      throw Error("retarget: the rig's rest rotations must be finite unit quaternions");
  if (source.up_axis != rig.skeleton.up_axis) throw Error("retarget: the input and the rig have different up axes");
}

}  // namespace

// Everything constant over the frames: the pairing and the alignment of the two skeletons.
struct RetargetPlan {
  Skeleton source;  // with meters_per_unit resolved (contacts are found in metres)
  Pairing pairing;
  Alignment alignment;
};

namespace {

// `frames`: the input's frames whose standing one is its reference when its rest pose does not stand.
RetargetPlan make_plan(const Skeleton& source_in, const Motion& frames, const RetargetRig& rig,
                       const RetargetOptions& options, RetargetReport* r) {
  check_inputs(source_in, frames, rig);
  RetargetPlan plan;
  plan.source = source_in;
  plan.source.meters_per_unit = resolve_meters_per_unit(source_in);
  plan.pairing = pair_joints(plan.source, rig.skeleton, options, r);
  const Pairing& p = plan.pairing;
  const Motion source_reference =
      reference_pose(plan.source, {}, frames, landmarks(p, true), "input", &r->input_rest_reference);
  const Motion rig_reference =
      reference_pose(rig.skeleton, rig.rest_rotations, rig.frames, landmarks(p, false), "rig", &r->rig_rest_reference);
  plan.alignment = align(plan.source, forward_kinematics(plan.source, source_reference), rig, rig_reference, p);
  r->scale = plan.alignment.scale;
  r->lift = plan.alignment.lift;
  return plan;
}

// Frame t of `sw` (the input's FK) posed and placed on the rig into frame t of *out.
void retarget_frame(const RetargetPlan& plan, const RetargetRig& rig, const WorldPoses& sw, int t, Motion* out) {
  const Pairing& p = plan.pairing;
  const Alignment& a = plan.alignment;
  const std::vector<Quat> world = pose_frame(rig.skeleton, p, a, sw, t, out);
  const Vec3 sockets = 0.5 * (sw.position(t, p.source_of[p.thigh[0]]) + sw.position(t, p.source_of[p.thigh[1]]));
  const Vec3 lift = a.lift * Vec3::Unit(rig.skeleton.up_axis);
  place_hips(rig, p, a, world, a.scale * sockets + lift - world[p.hips] * a.sockets_local, t, out);
}

}  // namespace

Motion retarget(const Skeleton& source_in, const Motion& motion, const RetargetRig& rig, const RetargetOptions& options,
                RetargetReport* report) {
  RetargetReport local_report;
  RetargetReport* r = report ? report : &local_report;
  *r = RetargetReport{};
  const RetargetPlan plan = make_plan(source_in, motion, rig, options, r);
  const WorldPoses sw = forward_kinematics(plan.source, motion);
  Motion out = Motion::rest(rig.skeleton, motion.num_frames, motion.fps);
  for (int t = 0; t < motion.num_frames; ++t) retarget_frame(plan, rig, sw, t, &out);
  if (options.plant_feet && motion.num_frames > 1) {
    plant_feet(plan.source, sw, rig, plan.pairing, plan.alignment, options, &out, &r->contacts);
    level_floor(sw, rig, plan.pairing, plan.alignment.scale, &out);
  }
  out.validate();
  return out;
}

StreamingRetarget::StreamingRetarget(const Skeleton& source, const Motion& reference, const RetargetRig& rig,
                                     const RetargetOptions& options)
    : rig_(rig) {
  RetargetReport report;
  plan_ = std::make_shared<const RetargetPlan>(make_plan(source, reference, rig, options, &report));
  scale_ = report.scale;
}

Motion StreamingRetarget::apply(const Motion& frame) const {
  if (frame.num_frames != 1 || frame.num_joints != plan_->source.num_joints())
    throw Error("retarget: a streamed frame must be one frame of the input's " +
                std::to_string(plan_->source.num_joints()) + " joints");
  frame.validate();
  Motion out = Motion::rest(rig_.skeleton, 1, frame.fps);
  retarget_frame(*plan_, rig_, forward_kinematics(plan_->source, frame), 0, &out);
  return out;
}

}  // namespace mosyn
