#include "core/markers.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <initializer_list>

#include "core/error.h"
#include "core/rotation.h"

namespace mosyn {
namespace {

// First joint with one of the names, or -1.
int find_any(const Skeleton& skeleton, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    const int j = skeleton.find(n);
    if (j >= 0) return j;
  }
  return -1;
}

// Position of descendant d relative to j, in j's frame, with identity local rotations on the path.
Eigen::Vector3d rest_vector(const Skeleton& skeleton, int j, int d) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (; d != j && d >= 0; d = skeleton.parents[d]) v += skeleton.offsets[d];
  if (d != j) throw Error("markers: joint " + std::to_string(d) + " is not below " + std::to_string(j));
  return v;
}

// One frame of forward kinematics: world rotations and positions [J].
void frame_fk(const Skeleton& skeleton, const Motion& motion, int t, std::vector<Eigen::Quaterniond>* rot,
              std::vector<Eigen::Vector3d>* pos) {
  const int n = skeleton.num_joints();
  rot->resize(n);
  pos->resize(n);
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    if (p < 0) {
      (*rot)[j] = motion.rotation(t, j);
      (*pos)[j] = motion.translation(t, j);
    } else {
      (*rot)[j] = ((*rot)[p] * motion.rotation(t, j)).normalized();
      (*pos)[j] = (*pos)[p] + (*rot)[p] * motion.translation(t, j);
    }
  }
}

// Where a marker sits in the canonical pose: between two body-part joints plus an offset in body
// axes (left, up, forward) in metres, carried by the `attach` part. Left-side definitions; the
// right side mirrors them (left coordinate negated, right parts).
enum Part { kPelvis, kChest, kNeck, kHead, kClavicle, kUpperArm, kForearm, kHand, kThigh, kShin, kFoot, kToe };
struct MarkerSpec {
  const char* name;
  int side;  // 0 left, 1 right, 2 centre (used as given)
  Part attach, from, to;
  double fraction;  // 0 = at `from`, 1 = at `to`
  double left, up, forward;  // metres
};

// The CMU 41-marker layout (SOMA's cmu_41 names), placed as described in the header. Offsets are
// typical adult values (e.g. head markers 10-11 cm above the skull-base joint, wrist markers 3 cm
// either side of the wrist, heel 4 cm below and 6 cm behind the ankle).
const std::vector<MarkerSpec>& marker_specs() {
  static const std::vector<MarkerSpec> specs = {
      {"C7", 2, kChest, kNeck, kNeck, 0, 0.0, 0.0, -0.07},
      {"CLAV", 2, kChest, kNeck, kNeck, 0, 0.0, -0.05, 0.07},
      {"LANK", 0, kShin, kFoot, kFoot, 0, 0.04, 0.0, 0.0},
      {"LBHD", 0, kHead, kHead, kHead, 0, 0.05, 0.09, -0.08},
      {"LBWT", 0, kPelvis, kPelvis, kPelvis, 0, 0.07, 0.06, -0.10},
      {"LELB", 0, kUpperArm, kForearm, kForearm, 0, 0.0, 0.02, -0.045},
      {"LFIN", 0, kHand, kHand, kHand, 0, 0.08, 0.01, 0.0},
      {"LFHD", 0, kHead, kHead, kHead, 0, 0.05, 0.11, 0.09},
      {"LFRM", 0, kForearm, kForearm, kHand, 0.45, 0.0, 0.04, -0.02},
      {"LFWT", 0, kPelvis, kPelvis, kPelvis, 0, 0.09, 0.05, 0.08},
      {"LHEE", 0, kFoot, kFoot, kFoot, 0, 0.0, -0.04, -0.06},
      {"LIWR", 0, kForearm, kHand, kHand, 0, 0.0, 0.0, 0.03},
      {"LKNE", 0, kThigh, kShin, kShin, 0, 0.05, 0.0, 0.0},
      {"LMT5", 0, kFoot, kToe, kToe, 0, 0.04, -0.01, -0.02},
      {"LOWR", 0, kForearm, kHand, kHand, 0, 0.0, 0.0, -0.03},
      {"LSHN", 0, kShin, kShin, kFoot, 0.5, 0.01, 0.0, 0.05},
      {"LSHO", 0, kClavicle, kUpperArm, kUpperArm, 0, 0.0, 0.05, 0.0},
      {"LTHI", 0, kThigh, kThigh, kShin, 0.5, 0.07, 0.0, 0.01},
      {"LTOE", 0, kToe, kToe, kToe, 0, 0.0, 0.01, 0.04},
      {"LUPA", 0, kUpperArm, kUpperArm, kForearm, 0.5, 0.0, 0.03, -0.04},
      {"RANK", 1, kShin, kFoot, kFoot, 0, 0.04, 0.0, 0.0},
      {"RBAK", 2, kChest, kNeck, kNeck, 0, -0.10, -0.15, -0.09},
      {"RBHD", 1, kHead, kHead, kHead, 0, 0.05, 0.09, -0.08},
      {"RBWT", 1, kPelvis, kPelvis, kPelvis, 0, 0.07, 0.06, -0.10},
      {"RELB", 1, kUpperArm, kForearm, kForearm, 0, 0.0, 0.02, -0.045},
      {"RFHD", 1, kHead, kHead, kHead, 0, 0.05, 0.11, 0.09},
      {"RFIN", 1, kHand, kHand, kHand, 0, 0.08, 0.01, 0.0},
      {"RFRM", 1, kForearm, kForearm, kHand, 0.45, 0.0, 0.04, -0.02},
      {"RFWT", 1, kPelvis, kPelvis, kPelvis, 0, 0.09, 0.05, 0.08},
      {"RHEE", 1, kFoot, kFoot, kFoot, 0, 0.0, -0.04, -0.06},
      {"RIWR", 1, kForearm, kHand, kHand, 0, 0.0, 0.0, 0.03},
      {"RKNE", 1, kThigh, kShin, kShin, 0, 0.05, 0.0, 0.0},
      {"RMT5", 1, kFoot, kToe, kToe, 0, 0.04, -0.01, -0.02},
      {"ROWR", 1, kForearm, kHand, kHand, 0, 0.0, 0.0, -0.03},
      {"RSHN", 1, kShin, kShin, kFoot, 0.5, 0.01, 0.0, 0.05},
      {"RSHO", 1, kClavicle, kUpperArm, kUpperArm, 0, 0.0, 0.05, 0.0},
      {"RTHI", 1, kThigh, kThigh, kShin, 0.5, 0.07, 0.0, 0.01},
      {"RTOE", 1, kToe, kToe, kToe, 0, 0.0, 0.01, 0.04},
      {"RUPA", 1, kUpperArm, kUpperArm, kForearm, 0.5, 0.0, 0.03, -0.04},
      {"STRN", 2, kChest, kNeck, kNeck, 0, 0.0, -0.20, 0.10},
      {"T10", 2, kChest, kNeck, kNeck, 0, 0.0, -0.25, -0.10},
  };
  return specs;
}

int part_joint(const BodyParts& b, Part part, int side) {
  const int s = side == 1 ? 1 : 0;
  switch (part) {
    case kPelvis: return b.pelvis;
    case kChest: return b.chest;
    case kNeck: return b.neck;
    case kHead: return b.head;
    case kClavicle: return b.clavicle[s];
    case kUpperArm: return b.upper_arm[s];
    case kForearm: return b.forearm[s];
    case kHand: return b.hand[s];
    case kThigh: return b.thigh[s];
    case kShin: return b.shin[s];
    case kFoot: return b.foot[s];
    case kToe: return b.toe[s];
  }
  return -1;
}

// The deepest nonzero-length descendant point of j along its first children (an end site when
// the joint has one), in j's frame; zero when there is none.
Eigen::Vector3d leaf_vector(const Skeleton& skeleton, int j) {
  for (const EndSite& e : skeleton.end_sites)
    if (e.parent == j && e.offset.norm() > 0) return e.offset;
  for (int c : skeleton.children(j))
    if (skeleton.offsets[c].norm() > 0) return skeleton.offsets[c];
  return Eigen::Vector3d::Zero();
}

// A canonical direction for joint j: which vector (in j's frame) should point where.
struct Aim {
  Eigen::Vector3d local = Eigen::Vector3d::Zero();
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d second_local = Eigen::Vector3d::Zero();  // optional secondary (pelvis, chest)
  Eigen::Vector3d second_target = Eigen::Vector3d::Zero();
};

std::vector<Aim> canonical_aims(const Skeleton& skeleton, const BodyParts& b, const BodyAxes& ax) {
  std::vector<Aim> aims(skeleton.num_joints());
  auto aim_at = [&](int j, int d, const Eigen::Vector3d& target) {
    if (j < 0 || d < 0) return;
    aims[j].local = rest_vector(skeleton, j, d);
    aims[j].target = target;
  };
  const int spine_top = b.spine >= 0 ? b.spine : b.chest;
  aim_at(b.pelvis, spine_top, ax.up);
  aims[b.pelvis].second_local = rest_vector(skeleton, b.pelvis, b.thigh[0]) - rest_vector(skeleton, b.pelvis, b.thigh[1]);
  aims[b.pelvis].second_target = ax.left;
  if (b.spine >= 0) aim_at(b.spine, b.chest, ax.up);
  aim_at(b.chest, b.neck, ax.up);
  if (aims[b.chest].local.norm() == 0) aim_at(b.chest, b.head, ax.up);
  aims[b.chest].second_local = rest_vector(skeleton, b.chest, b.upper_arm[0]) - rest_vector(skeleton, b.chest, b.upper_arm[1]);
  aims[b.chest].second_target = ax.left;
  aim_at(b.neck, b.head, ax.up);
  aims[b.head].local = leaf_vector(skeleton, b.head);
  aims[b.head].target = ax.up;
  const Eigen::Vector3d foot_dir = (ax.forward - 0.3 * ax.up).normalized();
  for (int s = 0; s < 2; ++s) {
    const Eigen::Vector3d out = s == 0 ? ax.left : Eigen::Vector3d(-ax.left);
    aim_at(b.clavicle[s], b.upper_arm[s], out);
    aim_at(b.upper_arm[s], b.forearm[s], out);
    aim_at(b.forearm[s], b.hand[s], out);
    aims[b.hand[s]].local = leaf_vector(skeleton, b.hand[s]);
    aims[b.hand[s]].target = out;
    aim_at(b.thigh[s], b.shin[s], -ax.up);
    aim_at(b.shin[s], b.foot[s], -ax.up);
    aim_at(b.foot[s], b.toe[s], foot_dir);
    aims[b.toe[s]].local = leaf_vector(skeleton, b.toe[s]);
    aims[b.toe[s]].target = ax.forward;
  }
  return aims;
}

// Rotation about `axis` (unit) taking a's component perpendicular to it onto b's.
Eigen::Quaterniond twist_onto(const Eigen::Vector3d& axis, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d pa = a - axis * axis.dot(a), pb = b - axis * axis.dot(b);
  if (pa.norm() < 1e-12 || pb.norm() < 1e-12) return Eigen::Quaterniond::Identity();
  const double angle = std::atan2(axis.dot(pa.cross(pb)), pa.dot(pb));
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis));
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

double skeleton_extent(const Skeleton& skeleton) {
  double total = 0.0;
  for (const Eigen::Vector3d& o : skeleton.offsets) total += o.norm();
  return total > 0 ? total : 1.0;
}

}  // namespace

int MarkerSet::find(const std::string& name) const {
  for (size_t i = 0; i < markers.size(); ++i)
    if (markers[i].name == name) return static_cast<int>(i);
  return -1;
}

const std::vector<std::string>& cmu41_marker_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const MarkerSpec& s : marker_specs()) out.push_back(s.name);
    return out;
  }();
  return names;
}

BodyParts find_body_parts(const Skeleton& skeleton) {
  BodyParts b;
  const Skeleton& s = skeleton;
  b.pelvis = find_any(s, {"Hips", "hips", "Pelvis", "pelvis"});
  b.spine = find_any(s, {"Spine"});
  b.chest = find_any(s, {"Chest", "Spine1", "Spine2"});
  if (b.chest == b.spine) b.spine = -1;
  b.neck = find_any(s, {"Neck"});
  b.head = find_any(s, {"Head"});
  b.clavicle[0] = find_any(s, {"Shoulder_L", "LeftShoulder"});
  b.clavicle[1] = find_any(s, {"Shoulder_R", "RightShoulder"});
  b.upper_arm[0] = find_any(s, {"UpperArm_L", "LeftArm"});
  b.upper_arm[1] = find_any(s, {"UpperArm_R", "RightArm"});
  b.forearm[0] = find_any(s, {"LowerArm_L", "LeftForeArm"});
  b.forearm[1] = find_any(s, {"LowerArm_R", "RightForeArm"});
  b.hand[0] = find_any(s, {"Hand_L", "LeftHand"});
  b.hand[1] = find_any(s, {"Hand_R", "RightHand"});
  b.thigh[0] = find_any(s, {"UpperLeg_L", "LeftUpLeg"});
  b.thigh[1] = find_any(s, {"UpperLeg_R", "RightUpLeg"});
  b.shin[0] = find_any(s, {"LowerLeg_L", "LeftLeg"});
  b.shin[1] = find_any(s, {"LowerLeg_R", "RightLeg"});
  b.foot[0] = find_any(s, {"Foot_L", "LeftFoot"});
  b.foot[1] = find_any(s, {"Foot_R", "RightFoot"});
  b.toe[0] = find_any(s, {"Toes_L", "LeftToeBase"});
  b.toe[1] = find_any(s, {"Toes_R", "RightToeBase"});
  const std::pair<const char*, int> required[] = {
      {"pelvis (Hips)", b.pelvis}, {"chest (Chest, Spine1)", b.chest}, {"neck (Neck)", b.neck},
      {"head (Head)", b.head}, {"left clavicle", b.clavicle[0]}, {"right clavicle", b.clavicle[1]},
      {"left upper arm", b.upper_arm[0]}, {"right upper arm", b.upper_arm[1]}, {"left forearm", b.forearm[0]},
      {"right forearm", b.forearm[1]}, {"left hand", b.hand[0]}, {"right hand", b.hand[1]},
      {"left thigh", b.thigh[0]}, {"right thigh", b.thigh[1]}, {"left shin", b.shin[0]},
      {"right shin", b.shin[1]}, {"left foot", b.foot[0]}, {"right foot", b.foot[1]},
      {"left toe", b.toe[0]}, {"right toe", b.toe[1]}};
  for (const auto& [what, j] : required)
    if (j < 0) throw Error(std::string("markers: the skeleton has no ") + what + " joint (Bandai-Namco or CMU names)");
  return b;
}

BodyAxes canonical_body_axes(const Skeleton& skeleton) {
  BodyAxes ax;
  ax.up = Eigen::Vector3d::Unit(skeleton.up_axis);
  ax.forward = skeleton.up_axis == 1 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::Unit((skeleton.up_axis + 1) % 3);
  ax.left = ax.up.cross(ax.forward);
  return ax;
}

Motion canonical_pose(const Skeleton& skeleton, const BodyParts& parts) {
  const BodyAxes ax = canonical_body_axes(skeleton);
  const std::vector<Aim> aims = canonical_aims(skeleton, parts, ax);
  Motion motion = Motion::rest(skeleton, 1, 30.0);
  const int n = skeleton.num_joints();
  std::vector<Eigen::Quaterniond> world(n);
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    const Eigen::Quaterniond parent = p < 0 ? Eigen::Quaterniond::Identity() : world[p];
    Eigen::Quaterniond w = parent;
    const Aim& a = aims[j];
    if (a.local.norm() > 0) {
      w = (Eigen::Quaterniond::FromTwoVectors(parent * a.local, a.target) * parent).normalized();
      if (a.second_local.norm() > 0) w = (twist_onto(a.target, w * a.second_local, a.second_target) * w).normalized();
    }
    world[j] = w;
    motion.rotation(0, j) = (parent.conjugate() * w).normalized();
  }
  // Pelvis at the origin.
  std::vector<Eigen::Quaterniond> rot;
  std::vector<Eigen::Vector3d> pos;
  frame_fk(skeleton, motion, 0, &rot, &pos);
  motion.translation(0, 0) -= pos[parts.pelvis];
  return motion;
}

MarkerSet cmu41_markers(const Skeleton& skeleton) {
  skeleton.validate();
  const BodyParts parts = find_body_parts(skeleton);
  const BodyAxes ax = canonical_body_axes(skeleton);
  const Motion pose = canonical_pose(skeleton, parts);
  std::vector<Eigen::Quaterniond> rot;
  std::vector<Eigen::Vector3d> pos;
  frame_fk(skeleton, pose, 0, &rot, &pos);
  const double units_per_m = 1.0 / skeleton.meters_per_unit;
  MarkerSet set;
  for (const MarkerSpec& s : marker_specs()) {
    const double mirror = s.side == 1 ? -1.0 : 1.0;
    const int attach = part_joint(parts, s.attach, s.side);
    const Eigen::Vector3d base =
        (1.0 - s.fraction) * pos[part_joint(parts, s.from, s.side)] + s.fraction * pos[part_joint(parts, s.to, s.side)];
    const Eigen::Vector3d world =
        base + units_per_m * (mirror * s.left * ax.left + s.up * ax.up + s.forward * ax.forward);
    set.markers.push_back({s.name, attach, rot[attach].conjugate() * (world - pos[attach])});
  }
  return set;
}

std::vector<Eigen::Vector3d> marker_positions(const MarkerSet& markers, const WorldPoses& world, int t) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(markers.markers.size());
  for (const Marker& m : markers.markers) out.push_back(world.position(t, m.joint) + world.rotation(t, m.joint) * m.offset);
  return out;
}

std::vector<Eigen::Vector3d> marker_positions(const Skeleton& skeleton, const MarkerSet& markers, const Motion& motion) {
  const WorldPoses world = forward_kinematics(skeleton, motion);
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<size_t>(motion.num_frames) * markers.markers.size());
  for (int t = 0; t < motion.num_frames; ++t) {
    const auto frame = marker_positions(markers, world, t);
    out.insert(out.end(), frame.begin(), frame.end());
  }
  return out;
}

namespace {

// Residuals (metres: markers; then the pose prior) of frame t, and optionally their Jacobian.
double fit_residuals(const Skeleton& skeleton, const MarkerSet& markers, const std::vector<Eigen::Vector3d>& targets,
                     const Motion& motion, int t, const std::vector<Eigen::Quaterniond>& start, double prior_sqrt,
                     Eigen::VectorXd* r, Eigen::MatrixXd* jac) {
  const int n = skeleton.num_joints(), m = markers.num_markers();
  const double mpu = skeleton.meters_per_unit;
  std::vector<Eigen::Quaterniond> rot;
  std::vector<Eigen::Vector3d> pos;
  frame_fk(skeleton, motion, t, &rot, &pos);
  r->setZero(3 * m + 3 * n);
  if (jac) jac->setZero(3 * m + 3 * n, 3 + 3 * n);
  for (int i = 0; i < m; ++i) {
    const Marker& mk = markers.markers[i];
    const Eigen::Vector3d p = pos[mk.joint] + rot[mk.joint] * mk.offset;
    r->segment<3>(3 * i) = (p - targets[i]) * mpu;
    if (!jac) continue;
    jac->block<3, 3>(3 * i, 0) = Eigen::Matrix3d::Identity() * mpu;
    for (int j = mk.joint; j >= 0; j = skeleton.parents[j]) jac->block<3, 3>(3 * i, 3 + 3 * j) = -skew(p - pos[j]) * mpu;
  }
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    const Eigen::Quaterniond parent = p < 0 ? Eigen::Quaterniond::Identity() : rot[p];
    const Eigen::Vector3d change = expmap_from_quat((motion.rotation(t, j) * start[j].conjugate()).normalized());
    r->segment<3>(3 * m + 3 * j) = prior_sqrt * (parent * change);
    if (jac) jac->block<3, 3>(3 * m + 3 * j, 3 + 3 * j) = prior_sqrt * Eigen::Matrix3d::Identity();
  }
  return r->squaredNorm();
}

// Applies a step: root translation delta (skeleton units) and world-axis rotations of each subtree.
void apply_step(const Skeleton& skeleton, const Eigen::VectorXd& step, Motion* motion, int t) {
  const int n = skeleton.num_joints();
  std::vector<Eigen::Quaterniond> rot;
  std::vector<Eigen::Vector3d> pos;
  frame_fk(skeleton, *motion, t, &rot, &pos);
  motion->translation(t, 0) += step.head<3>();  // skeleton units (its Jacobian column is mpu)
  for (int j = 0; j < n; ++j) {
    const int p = skeleton.parents[j];
    const Eigen::Quaterniond parent = p < 0 ? Eigen::Quaterniond::Identity() : rot[p];
    const Eigen::Quaterniond q = quat_from_expmap(step.segment<3>(3 + 3 * j));
    motion->rotation(t, j) = (parent.conjugate() * q * parent * motion->rotation(t, j)).normalized();
  }
}

}  // namespace

MarkerFitResult fit_markers(const Skeleton& skeleton, const MarkerSet& markers, const std::vector<Eigen::Vector3d>& targets,
                            Motion* motion, int t, const MarkerFitOptions& options) {
  if (static_cast<int>(targets.size()) != markers.num_markers())
    throw Error("fit_markers: " + std::to_string(targets.size()) + " targets for " +
                std::to_string(markers.num_markers()) + " markers");
  if (t < 0 || t >= motion->num_frames) throw Error("fit_markers: frame " + std::to_string(t) + " out of range");
  const int n = skeleton.num_joints();
  std::vector<Eigen::Quaterniond> start(n);
  for (int j = 0; j < n; ++j) start[j] = motion->rotation(t, j);
  const double prior_sqrt = std::sqrt(std::max(0.0, options.pose_prior));
  Eigen::VectorXd r, r_new;
  Eigen::MatrixXd jac;
  double cost = fit_residuals(skeleton, markers, targets, *motion, t, start, prior_sqrt, &r, &jac);
  double mu = 1e-3;
  MarkerFitResult result;
  const double extent = skeleton_extent(skeleton);
  for (int it = 0; it < options.max_iterations; ++it) {
    result.iterations = it + 1;
    const Eigen::MatrixXd a = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    Eigen::MatrixXd damped = a;
    damped.diagonal() += mu * (a.diagonal().array() + 1e-9).matrix();
    const Eigen::VectorXd step = damped.ldlt().solve(-g);
    Motion trial = *motion;
    apply_step(skeleton, step, &trial, t);
    const double trial_cost = fit_residuals(skeleton, markers, targets, trial, t, start, prior_sqrt, &r_new, nullptr);
    if (std::isfinite(trial_cost) && trial_cost < cost) {
      for (int j = 0; j < n; ++j) motion->rotation(t, j) = trial.rotation(t, j);
      motion->translation(t, 0) = trial.translation(t, 0);
      cost = fit_residuals(skeleton, markers, targets, *motion, t, start, prior_sqrt, &r, &jac);
      mu = std::max(1e-9, mu / 3.0);
      const double max_rot = step.tail(3 * n).cwiseAbs().maxCoeff();
      if (max_rot < options.tolerance && step.head<3>().norm() / extent < options.tolerance) break;
    } else {
      mu *= 4.0;
      if (mu > 1e8) break;
    }
  }
  double sq = 0.0;
  auto pos = [&] {
    std::vector<Eigen::Quaterniond> rot;
    std::vector<Eigen::Vector3d> p;
    frame_fk(skeleton, *motion, t, &rot, &p);
    std::vector<Eigen::Vector3d> out;
    for (const Marker& mk : markers.markers) out.push_back(p[mk.joint] + rot[mk.joint] * mk.offset);
    return out;
  }();
  for (int i = 0; i < markers.num_markers(); ++i) sq += (pos[i] - targets[i]).squaredNorm();
  result.rms_error = std::sqrt(sq / std::max(1, markers.num_markers()));
  result.fitted = pos;
  return result;
}

void initialise_from_markers(const Skeleton& skeleton, const MarkerSet& markers,
                             const std::vector<Eigen::Vector3d>& targets, Motion* motion, int t) {
  if (static_cast<int>(targets.size()) != markers.num_markers())
    throw Error("initialise_from_markers: targets do not match the markers");
  const BodyParts parts = find_body_parts(skeleton);
  const BodyAxes ax = canonical_body_axes(skeleton);
  const Motion canon = canonical_pose(skeleton, parts);
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    motion->rotation(t, j) = canon.rotation(0, j);
    motion->translation(t, j) = canon.translation(0, j);
  }
  const int lf = markers.find("LFWT"), lb = markers.find("LBWT"), rf = markers.find("RFWT"), rb = markers.find("RBWT");
  if (lf < 0 || lb < 0 || rf < 0 || rb < 0) return;  // not the CMU layout: the canonical pose at the origin
  const Eigen::Vector3d left = (targets[lf] + targets[lb]) - (targets[rf] + targets[rb]);
  const Eigen::Quaterniond turn = twist_onto(ax.up, ax.left, left);
  motion->rotation(t, 0) = (turn * motion->rotation(t, 0)).normalized();
  motion->translation(t, 0) = turn * motion->translation(t, 0);
  const WorldPoses world = [&] {
    Motion one = Motion::rest(skeleton, 1, motion->fps);
    for (int j = 0; j < skeleton.num_joints(); ++j) {
      one.rotation(0, j) = motion->rotation(t, j);
      one.translation(0, j) = motion->translation(t, j);
    }
    return forward_kinematics(skeleton, one);
  }();
  const auto now = marker_positions(markers, world, 0);
  const Eigen::Vector3d shift = 0.25 * ((targets[lf] + targets[lb] + targets[rf] + targets[rb]) -
                                        (now[lf] + now[lb] + now[rf] + now[rb]));
  motion->translation(t, 0) += shift;
}

}  // namespace mosyn
