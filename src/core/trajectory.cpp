#include "core/trajectory.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/mirror.h"

namespace mosyn {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d axis_vector(int axis) { return Eigen::Vector3d::Unit(axis); }

void check_up_axis(const Skeleton& s) {
  if (s.up_axis < 0 || s.up_axis > 2) throw Error("skeleton up_axis must be 0, 1 or 2");
}

// Rest-pose world positions (identity rotations, rest offsets).
std::vector<Eigen::Vector3d> rest_positions(const Skeleton& skeleton) {
  const int n = skeleton.num_joints();
  std::vector<Eigen::Vector3d> p(n);
  for (int j = 0; j < n; ++j) {
    const int parent = skeleton.parents[j];
    p[j] = parent < 0 ? skeleton.offsets[j] : p[parent] + skeleton.offsets[j];
  }
  return p;
}

// x[i] for any integer i: beyond the ends, point reflection about the end sample
// (x[-k] = 2 x[0] - x[k]), clamped to the clip for kernels longer than it.
template <typename V>
V extend_by_reflection(const std::vector<V>& x, int i) {
  const int n = static_cast<int>(x.size());
  if (i < 0) return 2.0 * x[0] - x[std::min(-i, n - 1)];
  if (i >= n) return 2.0 * x[n - 1] - x[std::max(2 * (n - 1) - i, 0)];
  return x[i];
}

}  // namespace

// For up axis a, e_{a+1} and e_{a+2} (Y-up: +Z and +X), since R_a(90) e_{a+1} = e_{a+2}.
int forward_axis(const Skeleton& s) { return (s.up_axis + 1) % 3; }
int sideways_axis(const Skeleton& s) { return (s.up_axis + 2) % 3; }

Eigen::Vector3d estimate_forward_in_root(const Skeleton& skeleton) {
  skeleton.validate();
  const Eigen::Vector3d fallback = axis_vector(forward_axis(skeleton));
  const int n = skeleton.num_joints();
  const std::vector<int> map = mirror_map(skeleton);
  const std::vector<int> side = joint_sides(skeleton);
  const std::vector<Eigen::Vector3d> rest = rest_positions(skeleton);

  std::vector<int> depth(n, 0);
  double scale = 0;
  for (int j = 1; j < n; ++j) {
    depth[j] = depth[skeleton.parents[j]] + 1;
    scale = std::max(scale, (rest[j] - rest[0]).norm());
  }
  const double eps = 1e-6 * std::max(scale, 1e-12);

  // The limb pair attached nearest the root (the hips for a usual hierarchy): a left joint whose
  // parent is unpaired, of least depth. Shoulders are deliberately not used: their rest positions
  // depend on spine joints whose rest frames need not match the root's (Bandai-Namco).
  int left = -1;
  for (int j = 1; j < n; ++j)
    if (side[j] > 0 && side[skeleton.parents[j]] == 0 && (left < 0 || depth[j] < depth[left])) left = j;
  if (left < 0) return fallback;
  const int pelvis = skeleton.parents[left];

  // Walk down the pair while it coincides (CMU's LHipJoint/RHipJoint sit on Hips).
  int a = left, b = map[left];
  while ((rest[a] - rest[b]).norm() <= eps) {
    int next = -1;
    for (int c : skeleton.children(a))
      if (map[c] != c && skeleton.parents[map[c]] == b) {
        next = c;
        break;
      }
    if (next < 0) return fallback;
    a = next;
    b = map[next];
  }
  const Eigen::Vector3d across = rest[a] - rest[b];  // left minus right

  // Body up: from the pelvis along its unpaired child chain (the spine) to the first point away
  // from it; the skeleton's up axis when there is none.
  Eigen::Vector3d up = axis_vector(skeleton.up_axis);
  int cur = pelvis;
  for (int guard = 0; guard < n; ++guard) {
    int next = -1;
    for (int c : skeleton.children(cur))
      if (side[c] == 0) {
        next = c;
        break;
      }
    if (next < 0) break;
    if ((rest[next] - rest[pelvis]).norm() > eps) {
      up = (rest[next] - rest[pelvis]).normalized();
      break;
    }
    cur = next;
  }

  // Right-handed: facing +Z with up +Y puts the character's left at +X, so forward = left x up.
  Eigen::Vector3d forward = across.cross(up);
  if (forward.norm() <= 1e-9 * across.norm()) return fallback;
  return forward.normalized();
}

Eigen::Quaterniond heading_rotation(const Skeleton& skeleton, double angle_rad) {
  check_up_axis(skeleton);
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, axis_vector(skeleton.up_axis)));
}

double heading_of(const Skeleton& skeleton, const Eigen::Vector3d& direction) {
  check_up_axis(skeleton);
  return std::atan2(direction[sideways_axis(skeleton)], direction[forward_axis(skeleton)]);
}

GroundTrajectory ground_trajectory(const Skeleton& skeleton, const Motion& motion, int root_joint,
                                   const Eigen::Vector3d& forward_in_root) {
  check_up_axis(skeleton);
  const int n = skeleton.num_joints();
  if (root_joint < 0 || root_joint >= n) throw Error("ground_trajectory: root joint index out of range");
  if (motion.num_joints != n) throw Error("ground_trajectory: motion and skeleton joint counts differ");
  // The chain from the skeleton root down to root_joint, root first.
  std::vector<int> chain;
  for (int j = root_joint; j >= 0; j = skeleton.parents[j]) chain.insert(chain.begin(), j);

  GroundTrajectory out;
  out.positions.resize(motion.num_frames);
  out.headings_rad.resize(motion.num_frames);
  for (int t = 0; t < motion.num_frames; ++t) {
    Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    for (int j : chain) {
      position += rotation * motion.translation(t, j);
      rotation = rotation * motion.rotation(t, j);
    }
    position[skeleton.up_axis] = 0;
    out.positions[t] = position;
    double heading = heading_of(skeleton, rotation * forward_in_root);
    if (t > 0) {
      // Unwrap: choose the 2 pi multiple nearest the previous heading.
      const double prev = out.headings_rad[t - 1];
      heading += 2 * kPi * std::round((prev - heading) / (2 * kPi));
    }
    out.headings_rad[t] = heading;
  }
  return out;
}

GroundTrajectory smooth_ground_trajectory(const GroundTrajectory& trajectory, double sigma_frames) {
  const int n = static_cast<int>(trajectory.positions.size());
  if (static_cast<int>(trajectory.headings_rad.size()) != n)
    throw Error("smooth_ground_trajectory: positions and headings differ in length");
  if (!(sigma_frames > 0) || n < 2) return trajectory;
  if (!(sigma_frames <= 1e4)) throw Error("smooth_ground_trajectory: sigma must be at most 10000 frames");
  // Truncated at 4 sigma.
  const int radius = static_cast<int>(std::ceil(4.0 * sigma_frames));
  std::vector<double> kernel(2 * radius + 1);
  double total = 0;
  for (int k = -radius; k <= radius; ++k)
    total += kernel[k + radius] = std::exp(-0.5 * k * k / (sigma_frames * sigma_frames));
  for (double& w : kernel) w /= total;
  const auto& positions = trajectory.positions;
  const auto& headings = trajectory.headings_rad;
  GroundTrajectory out;
  out.positions.assign(n, Eigen::Vector3d::Zero());
  out.headings_rad.assign(n, 0.0);
  for (int t = 0; t < n; ++t) {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    double h = 0;
    for (int k = -radius; k <= radius; ++k) {
      const double w = kernel[k + radius];
      p += w * extend_by_reflection(positions, t + k);
      h += w * extend_by_reflection(headings, t + k);
    }
    out.positions[t] = p;
    out.headings_rad[t] = h;
  }
  return out;
}

std::vector<RootDelta> root_deltas(const Skeleton& skeleton, const GroundTrajectory& trajectory) {
  check_up_axis(skeleton);
  const size_t num_frames = trajectory.positions.size();
  if (trajectory.headings_rad.size() != num_frames) throw Error("root_deltas: positions and headings differ in length");
  const int fa = forward_axis(skeleton), sa = sideways_axis(skeleton);
  std::vector<RootDelta> deltas(num_frames);
  for (size_t t = 1; t < num_frames; ++t) {
    const Eigen::Vector3d d = trajectory.positions[t] - trajectory.positions[t - 1];
    const double theta = trajectory.headings_rad[t - 1];
    const double c = std::cos(theta), s = std::sin(theta);
    // Facing (s, c) and sideways (c, -s) in (sideways axis, forward axis) coordinates.
    deltas[t].forward = s * d[sa] + c * d[fa];
    deltas[t].sideways = c * d[sa] - s * d[fa];
    deltas[t].turn_rad = trajectory.headings_rad[t] - theta;
  }
  return deltas;
}

GroundTrajectory integrate_root_deltas(const Skeleton& skeleton, const std::vector<RootDelta>& deltas,
                                       const Eigen::Vector3d& start_position, double start_heading_rad) {
  check_up_axis(skeleton);
  const int fa = forward_axis(skeleton), sa = sideways_axis(skeleton);
  GroundTrajectory out;
  const size_t num_frames = deltas.size();
  out.positions.resize(num_frames);
  out.headings_rad.resize(num_frames);
  if (num_frames == 0) return out;
  out.positions[0] = start_position;
  out.headings_rad[0] = start_heading_rad;
  for (size_t t = 1; t < num_frames; ++t) {
    const double theta = out.headings_rad[t - 1];
    const double c = std::cos(theta), s = std::sin(theta);
    Eigen::Vector3d p = out.positions[t - 1];
    p[sa] += s * deltas[t].forward + c * deltas[t].sideways;
    p[fa] += c * deltas[t].forward - s * deltas[t].sideways;
    out.positions[t] = p;
    out.headings_rad[t] = theta + deltas[t].turn_rad;
  }
  return out;
}

}  // namespace mosyn
