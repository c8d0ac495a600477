#include "data/representation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/markers.h"
#include "core/rotation.h"
#include "core/trajectory.h"

namespace mosyn::data {
namespace {

// Below this length (skeleton units, relative to the skeleton's size) a bone carries no direction.
constexpr double kZeroBoneRelative = 1e-9;

Eigen::Vector3d up_vector(const Skeleton& skeleton) { return Eigen::Vector3d::Unit(skeleton.up_axis); }

Eigen::Vector3d floor_projection(const Skeleton& skeleton, Eigen::Vector3d p) {
  p[skeleton.up_axis] = 0.0;
  return p;
}

void check_layout(const Skeleton& skeleton, const FeatureLayout& layout) {
  const int num_joints = skeleton.num_joints();
  if (layout.root_joint < 0 || layout.root_joint >= num_joints)
    throw Error("feature layout: root joint " + std::to_string(layout.root_joint) + " is not a joint of a " +
                std::to_string(num_joints) + "-joint skeleton");
  const int expected = expected_pose_dim(layout.form, num_joints, layout.smoothed_root());
  if (layout.pose_dim != expected)
    throw Error("feature layout: pose_dim " + std::to_string(layout.pose_dim) + " does not match the skeleton (" +
                std::to_string(expected) + " for " + std::to_string(num_joints) + " joints in " + to_string(layout.form) +
                " form)");
  if (layout.control_dim != 3) throw Error("feature layout: control_dim must be 3");
}

double skeleton_size(const Skeleton& skeleton) {
  double total = 0.0;
  for (const Eigen::Vector3d& o : skeleton.offsets) total += o.norm();
  return total > 0 ? total : 1.0;
}

// Rotation R minimising sum |R a_i - b_i|^2 (Kabsch). Needs at least two non-parallel a_i.
Eigen::Matrix3d kabsch(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) h += b[i] * a[i].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) d(2, 2) = -1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// The rest vectors that constrain joint j's rotation: each child's offset, or, for a child at
// distance zero (CMU's LHipJoint, Neck), that child's own children's offsets followed through.
// Each entry pairs the rest vector (in j's frame, children at identity) with the descendant.
void constraining_descendants(const Skeleton& skeleton, const std::vector<std::vector<int>>& children, int j,
                              const Eigen::Vector3d& base, double zero_length, int depth,
                              std::vector<std::pair<Eigen::Vector3d, int>>* out) {
  for (int c : children[j]) {
    const Eigen::Vector3d v = base + skeleton.offsets[c];
    if (v.norm() > zero_length)
      out->emplace_back(v, c);
    else if (depth < 8)
      constraining_descendants(skeleton, children, c, v, zero_length, depth + 1, out);
  }
}

// The two floor axes (not up) in increasing order: x, z for Y-up.
std::array<int, 2> floor_axes(const Skeleton& skeleton) {
  const int a = (skeleton.up_axis + 1) % 3, b = (skeleton.up_axis + 2) % 3;
  return {std::min(a, b), std::max(a, b)};
}

// True when the vectors span at least two directions.
bool spans_plane(const std::vector<Eigen::Vector3d>& v) {
  for (size_t i = 0; i < v.size(); ++i)
    for (size_t k = i + 1; k < v.size(); ++k)
      if (v[i].normalized().cross(v[k].normalized()).norm() > 1e-6) return true;
  return false;
}

}  // namespace

const char* to_string(PoseForm form) {
  switch (form) {
    case PoseForm::kRotations: return "rotations";
    case PoseForm::kPositions: return "positions";
    case PoseForm::kMarkers: return "markers";
  }
  throw Error("invalid pose form " + std::to_string(static_cast<int>(form)));
}

PoseForm parse_pose_form(const std::string& text) {
  for (PoseForm form : kPoseForms)
    if (text == to_string(form)) return form;
  std::string known;
  for (PoseForm form : kPoseForms) known += (known.empty() ? "" : " or ") + std::string(to_string(form));
  throw Error("unknown pose form '" + text + "' (expected " + known + ")");
}

int expected_pose_dim(PoseForm form, int num_joints, bool smoothed_root) {
  switch (form) {
    case PoseForm::kRotations: return 1 + 6 * num_joints + (smoothed_root ? 2 : 0);
    case PoseForm::kPositions: return 3 * num_joints;
    case PoseForm::kMarkers: return 3 * static_cast<int>(cmu41_marker_names().size());
  }
  throw Error("invalid pose form " + std::to_string(static_cast<int>(form)));
}

GroundTrajectory control_trajectory(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout) {
  const GroundTrajectory raw = ground_trajectory(skeleton, motion, layout.root_joint, layout.forward_in_root);
  if (!layout.smoothed_root()) return raw;
  return smooth_ground_trajectory(raw, layout.root_smoothing_s * motion.fps);
}

FeatureLayout make_layout(const Skeleton& skeleton, PoseForm form, int root_joint,
                          const Eigen::Vector3d& forward_in_root, double root_smoothing_s) {
  skeleton.validate();
  if (!(root_smoothing_s >= 0 && root_smoothing_s <= 10))
    throw Error("feature layout: root smoothing must be between 0 and 10 seconds, not " +
                std::to_string(root_smoothing_s));
  if (root_joint < 0 || root_joint >= skeleton.num_joints())
    throw Error("feature layout: root joint " + std::to_string(root_joint) + " is not a joint of a " +
                std::to_string(skeleton.num_joints()) + "-joint skeleton");
  FeatureLayout layout;
  layout.form = form;
  layout.root_joint = root_joint;
  if (!(forward_in_root.norm() > 0)) throw Error("feature layout: forward_in_root must be non-zero");
  layout.forward_in_root = forward_in_root.normalized();
  const int num_joints = skeleton.num_joints();
  switch (form) {
    case PoseForm::kRotations: {
      layout.pose_names.push_back(skeleton.joint_names[root_joint] + ".height_m");
      auto add_r6d = [&](int j, const std::string& tag) {
        for (int k = 0; k < 6; ++k) layout.pose_names.push_back(skeleton.joint_names[j] + tag + std::to_string(k));
      };
      add_r6d(root_joint, ".heading_r6d");
      for (int j = 0; j < num_joints; ++j)
        if (j != root_joint) add_r6d(j, ".r6d");
      if (root_smoothing_s > 0)
        for (int axis : floor_axes(skeleton))
          layout.pose_names.push_back(skeleton.joint_names[root_joint] + ".offset_" + "xyz"[axis] + "_m");
      break;
    }
    case PoseForm::kPositions: {
      static const char* kAxes[3] = {".x_m", ".y_m", ".z_m"};
      for (int j = 0; j < num_joints; ++j)
        for (int k = 0; k < 3; ++k) layout.pose_names.push_back(skeleton.joint_names[j] + kAxes[k]);
      break;
    }
    case PoseForm::kMarkers: {
      static const char* kAxes[3] = {".x_m", ".y_m", ".z_m"};
      for (const Marker& m : cmu41_markers(skeleton).markers)  // throws for a skeleton without the body parts
        for (int k = 0; k < 3; ++k) layout.pose_names.push_back(m.name + kAxes[k]);
      break;
    }
  }
  layout.pose_dim = static_cast<int>(layout.pose_names.size());
  layout.control_dim = 3;
  layout.control_names = {"dx_m", "dz_m", "dtheta_rad"};
  layout.root_smoothing_s = root_smoothing_s;
  check_layout(skeleton, layout);
  return layout;
}

void encode_pose_against(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout,
                         const GroundTrajectory& ground, std::vector<float>* pose) {
  check_layout(skeleton, layout);
  if (motion.num_joints != skeleton.num_joints())
    throw Error("encode: motion has " + std::to_string(motion.num_joints) + " joints, skeleton " +
                std::to_string(skeleton.num_joints()));
  const int num_frames = motion.num_frames;
  if (static_cast<int>(ground.positions.size()) != num_frames || static_cast<int>(ground.headings_rad.size()) != num_frames)
    throw Error("encode: the trajectory has " + std::to_string(ground.positions.size()) + " frames, the motion " +
                std::to_string(num_frames));
  const int num_joints = skeleton.num_joints();
  const int root = layout.root_joint;
  const double mpu = skeleton.meters_per_unit;
  const WorldPoses world = forward_kinematics(skeleton, motion);
  const std::array<int, 2> floor = floor_axes(skeleton);
  const MarkerSet markers = layout.form == PoseForm::kMarkers ? cmu41_markers(skeleton) : MarkerSet{};
  pose->assign(static_cast<size_t>(num_frames) * layout.pose_dim, 0.0f);
  for (int t = 0; t < num_frames; ++t) {
    const Eigen::Quaterniond heading_inv = heading_rotation(skeleton, ground.headings_rad[t]).conjugate();
    float* p = pose->data() + static_cast<size_t>(t) * layout.pose_dim;
    switch (layout.form) {
      case PoseForm::kRotations: {
      p[0] = static_cast<float>(world.position(t, root)[skeleton.up_axis] * mpu);
      const Vector6d r = rot6d_from_quat(heading_inv * world.rotation(t, root));
      for (int k = 0; k < 6; ++k) p[1 + k] = static_cast<float>(r[k]);
      int slot = 7;
      for (int j = 0; j < num_joints; ++j) {
        if (j == root) continue;
        const Vector6d lr = rot6d_from_quat(motion.rotation(t, j));
        for (int k = 0; k < 6; ++k) p[slot + k] = static_cast<float>(lr[k]);
        slot += 6;
      }
      if (layout.smoothed_root()) {
        const Eigen::Vector3d offset = heading_inv * (world.position(t, root) - ground.positions[t]) * mpu;
        p[slot] = static_cast<float>(offset[floor[0]]);
        p[slot + 1] = static_cast<float>(offset[floor[1]]);
      }
        break;
      }
      case PoseForm::kPositions: {
      const Eigen::Vector3d origin = ground.positions[t];
      for (int j = 0; j < num_joints; ++j) {
        const Eigen::Vector3d local = heading_inv * (world.position(t, j) - origin) * mpu;
        for (int k = 0; k < 3; ++k) p[3 * j + k] = static_cast<float>(local[k]);
      }
        break;
      }
      case PoseForm::kMarkers: {
        const std::vector<Eigen::Vector3d> at = marker_positions(markers, world, t);
        for (size_t i = 0; i < at.size(); ++i) {
          const Eigen::Vector3d local = heading_inv * (at[i] - ground.positions[t]) * mpu;
          for (int k = 0; k < 3; ++k) p[3 * i + k] = static_cast<float>(local[k]);
        }
        break;
      }
    }
  }
}

void encode(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout, std::vector<float>* pose,
            std::vector<float>* control) {
  check_layout(skeleton, layout);
  if (motion.num_joints != skeleton.num_joints())
    throw Error("encode: motion has " + std::to_string(motion.num_joints) + " joints, skeleton " +
                std::to_string(skeleton.num_joints()));
  const GroundTrajectory ground = control_trajectory(skeleton, motion, layout);
  encode_pose_against(skeleton, motion, layout, ground, pose);
  const std::vector<RootDelta> deltas = root_deltas(skeleton, ground);
  const double mpu = skeleton.meters_per_unit;
  control->assign(static_cast<size_t>(motion.num_frames) * layout.control_dim, 0.0f);
  for (int t = 1; t < motion.num_frames; ++t) {  // delta[0] is zero by definition
    float* c = control->data() + static_cast<size_t>(t) * layout.control_dim;
    c[0] = static_cast<float>(deltas[t].sideways * mpu);
    c[1] = static_cast<float>(deltas[t].forward * mpu);
    c[2] = static_cast<float>(deltas[t].turn_rad);
  }
}

namespace {

// The root path of a control [T, 3] (sideways, forward in metres, turn in rad per frame; frame 0's
// ignored) integrated from a start on the floor.
GroundTrajectory decode_ground(const Skeleton& skeleton, const FeatureLayout& layout, const float* control,
                               int num_frames, const Eigen::Vector3d& start_position, double start_heading_rad) {
  const double mpu = skeleton.meters_per_unit;
  std::vector<RootDelta> deltas(static_cast<size_t>(num_frames));
  for (int t = 1; t < num_frames; ++t) {
    const float* c = control + static_cast<size_t>(t) * layout.control_dim;
    deltas[t].sideways = c[0] / mpu;
    deltas[t].forward = c[1] / mpu;
    deltas[t].turn_rad = c[2];
  }
  return integrate_root_deltas(skeleton, deltas, floor_projection(skeleton, start_position), start_heading_rad);
}

// Rotations form: 6D rotations per joint, the trajectory joint's relative to the heading, its
// height and (smoothed root) floor offset in the heading frame.
void decode_rotations(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose,
                      const GroundTrajectory& ground, Motion* motion) {
  const int num_joints = skeleton.num_joints(), root = layout.root_joint;
  const double mpu = skeleton.meters_per_unit;
  const std::array<int, 2> floor = floor_axes(skeleton);
  std::vector<Eigen::Quaterniond> world(num_joints);
  std::vector<Eigen::Vector3d> world_pos(num_joints);
  for (int t = 0; t < motion->num_frames; ++t) {
    const float* p = pose + static_cast<size_t>(t) * layout.pose_dim;
    Vector6d r;
    int slot = 7;
    for (int j = 0; j < num_joints; ++j) {
      if (j == root) continue;
      for (int k = 0; k < 6; ++k) r[k] = p[slot + k];
      motion->rotation(t, j) = quat_from_rot6d(r);
      if (t > 0) motion->rotation(t, j) = align_hemisphere(motion->rotation(t, j), motion->rotation(t - 1, j));
      slot += 6;
    }
    for (int k = 0; k < 6; ++k) r[k] = p[1 + k];
    const Eigen::Quaterniond heading = heading_rotation(skeleton, ground.headings_rad[t]);
    const Eigen::Quaterniond root_world = heading * quat_from_rot6d(r);
    Eigen::Vector3d root_pos = ground.positions[t] + up_vector(skeleton) * (p[0] / mpu);
    if (layout.smoothed_root()) {
      Eigen::Vector3d offset = Eigen::Vector3d::Zero();
      offset[floor[0]] = p[slot] / mpu;
      offset[floor[1]] = p[slot + 1] / mpu;
      root_pos += heading * offset;
    }
    // Joints above the trajectory joint (none once a static root is collapsed) keep their
    // decoded rotations and rest offsets; the trajectory joint is placed in their frame.
    const int parent = skeleton.parents[root];
    if (parent < 0) {
      motion->rotation(t, root) = t > 0 ? align_hemisphere(root_world, motion->rotation(t - 1, root)) : root_world;
      motion->translation(t, root) = root_pos;
      continue;
    }
    for (int j = 0; j < root; ++j) {
      const int pj = skeleton.parents[j];
      world[j] = pj < 0 ? motion->rotation(t, j) : world[pj] * motion->rotation(t, j);
      world_pos[j] = pj < 0 ? motion->translation(t, j) : world_pos[pj] + world[pj] * motion->translation(t, j);
    }
    motion->rotation(t, root) = (world[parent].conjugate() * root_world).normalized();
    motion->translation(t, root) = world[parent].conjugate() * (root_pos - world_pos[parent]);
  }
}

// Positions form: inverse kinematics, top-down from the skeleton's root in world space; each
// joint's rotation best maps its rest offsets to its (non-degenerate) descendants' targets.
void decode_positions(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose,
                      const GroundTrajectory& ground, Motion* motion) {
  const int num_joints = skeleton.num_joints(), root = layout.root_joint;
  const double mpu = skeleton.meters_per_unit;
  std::vector<std::vector<int>> children(num_joints);
  for (int j = 1; j < num_joints; ++j) children[skeleton.parents[j]].push_back(j);
  const double zero_length = kZeroBoneRelative * skeleton_size(skeleton);
  std::vector<std::vector<std::pair<Eigen::Vector3d, int>>> constraints(num_joints);
  for (int j = 0; j < num_joints; ++j)
    constraining_descendants(skeleton, children, j, Eigen::Vector3d::Zero(), zero_length, 0, &constraints[j]);
  std::vector<Eigen::Vector3d> target(num_joints);
  std::vector<Eigen::Quaterniond> world(num_joints);
  std::vector<Eigen::Vector3d> rest_vectors, target_vectors;
  // Joints above the trajectory joint are static placeholders (identity rotation); the chain
  // down to it takes its translations from the targets so the trajectory joint lands exactly.
  std::vector<bool> above_root(num_joints, false);
  for (int a = skeleton.parents[root]; a >= 0; a = skeleton.parents[a]) above_root[a] = true;
  for (int t = 0; t < motion->num_frames; ++t) {
    const float* p = pose + static_cast<size_t>(t) * layout.pose_dim;
    const Eigen::Quaterniond heading = heading_rotation(skeleton, ground.headings_rad[t]);
    for (int j = 0; j < num_joints; ++j)
      target[j] = ground.positions[t] + heading * (Eigen::Vector3d(p[3 * j], p[3 * j + 1], p[3 * j + 2]) / mpu);
    motion->translation(t, 0) = target[0];
    for (int j = 0; j < num_joints; ++j) {
      const int parent = skeleton.parents[j];
      const Eigen::Quaterniond parent_world = parent < 0 ? Eigen::Quaterniond::Identity() : world[parent];
      rest_vectors.clear();
      target_vectors.clear();
      for (const auto& [rest, d] : constraints[j]) {
        const Eigen::Vector3d v = target[d] - target[j];
        if (v.norm() <= zero_length) continue;
        rest_vectors.push_back(rest);
        target_vectors.push_back(v);
      }
      if (parent >= 0 && (above_root[j] || j == root))
        motion->translation(t, j) = parent_world.conjugate() * (target[j] - target[parent]);
      Eigen::Quaterniond local = Eigen::Quaterniond::Identity();
      if (above_root[j]) {
        // keep identity
      } else if (rest_vectors.size() >= 2 && spans_plane(rest_vectors)) {
        const Eigen::Quaterniond w(kabsch(rest_vectors, target_vectors));
        local = parent_world.conjugate() * w;
      } else if (!rest_vectors.empty()) {
        // One direction: the minimal rotation; twist about the bone is not observable.
        const Eigen::Vector3d in_parent = parent_world.conjugate() * target_vectors[0];
        local = Eigen::Quaterniond::FromTwoVectors(rest_vectors[0], in_parent);
      } else if (parent < 0) {
        local = heading;  // nothing to fit: face along the trajectory
      }
      local.normalize();
      if (t > 0) local = align_hemisphere(local, motion->rotation(t - 1, j));
      motion->rotation(t, j) = local;
      world[j] = (parent_world * local).normalized();
    }
  }
}

// Markers form: the CMU 41-marker set fitted frame by frame (warm-started from the last frame).
void decode_markers(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose,
                    const GroundTrajectory& ground, Motion* motion) {
  const int num_joints = skeleton.num_joints();
  const double mpu = skeleton.meters_per_unit;
  const MarkerSet markers = cmu41_markers(skeleton);
  std::vector<Eigen::Vector3d> targets(markers.markers.size());
  for (int t = 0; t < motion->num_frames; ++t) {
    const float* p = pose + static_cast<size_t>(t) * layout.pose_dim;
    const Eigen::Quaterniond heading = heading_rotation(skeleton, ground.headings_rad[t]);
    for (size_t i = 0; i < targets.size(); ++i)
      targets[i] = ground.positions[t] + heading * (Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]) / mpu);
    MarkerFitOptions options;
    options.pose_prior = 1e-7;  // only to hold what the markers do not see
    options.max_iterations = 50;
    if (t == 0) {
      initialise_from_markers(skeleton, markers, targets, motion, 0);
      options.max_iterations = 200;
    } else {
      for (int j = 0; j < num_joints; ++j) motion->rotation(t, j) = motion->rotation(t - 1, j);
      motion->translation(t, 0) = motion->translation(t - 1, 0);
    }
    fit_markers(skeleton, markers, targets, motion, t, options);
    for (int j = 0; j < num_joints; ++j)
      if (t > 0) motion->rotation(t, j) = align_hemisphere(motion->rotation(t, j), motion->rotation(t - 1, j));
  }
}

}  // namespace

Motion decode(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose, const float* control,
              int num_frames, double fps, const Eigen::Vector3d& start_position, double start_heading_rad) {
  check_layout(skeleton, layout);
  if (num_frames < 0) throw Error("decode: negative frame count");
  const GroundTrajectory ground =
      decode_ground(skeleton, layout, control, num_frames, start_position, start_heading_rad);
  Motion motion = Motion::rest(skeleton, num_frames, fps);
  switch (layout.form) {
    case PoseForm::kRotations:
      decode_rotations(skeleton, layout, pose, ground, &motion);
      break;
    case PoseForm::kPositions:
      decode_positions(skeleton, layout, pose, ground, &motion);
      break;
    case PoseForm::kMarkers:
      decode_markers(skeleton, layout, pose, ground, &motion);
      break;
  }
  return motion;
}

}  // namespace mosyn::data
