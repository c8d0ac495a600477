#include "data/augment.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/foot_lock.h"
#include "core/kinematics.h"
#include "core/mirror.h"
#include "core/rotation.h"
#include "core/subset.h"

namespace mosyn::data {
namespace {

double skeleton_size(const Skeleton& skeleton) {
  double total = 0.0;
  for (const Eigen::Vector3d& o : skeleton.offsets) total += o.norm();
  return total > 0 ? total : 1.0;
}

Eigen::Matrix3d reflection(int axis) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  s(axis, axis) = -1.0;
  return s;
}

Eigen::Vector3d reflect(int axis, Eigen::Vector3d v) {
  v[axis] = -v[axis];
  return v;
}

// Mean and max geodesic angle between two frames' non-root local rotations.
std::pair<double, double> pose_change(const Motion& m, int a, int b) {
  double sum = 0, worst = 0;
  for (int j = 1; j < m.num_joints; ++j) {
    const double angle = geodesic_angle(m.rotation(a, j), m.rotation(b, j));
    sum += angle;
    worst = std::max(worst, angle);
  }
  return {m.num_joints > 1 ? sum / (m.num_joints - 1) : 0.0, worst};
}

}  // namespace

Motion slice_frames(const Motion& m, int first, int count) {
  Motion out = m;
  out.num_frames = count;
  const size_t begin = static_cast<size_t>(first) * m.num_joints, n = static_cast<size_t>(count) * m.num_joints;
  out.rotations.assign(m.rotations.begin() + begin, m.rotations.begin() + begin + n);
  out.translations.assign(m.translations.begin() + begin, m.translations.begin() + begin + n);
  return out;
}

// ---- Static root ----

bool has_static_root(const Clip& clip) {
  const Skeleton& s = clip.skeleton;
  const Motion& m = clip.motion;
  if (s.num_joints() < 2 || s.children(0).size() != 1 || m.num_frames == 0) return false;
  for (int t = 0; t < m.num_frames; ++t)
    if (geodesic_angle(m.rotation(t, 0), Eigen::Quaterniond::Identity()) > 1e-6) return false;
  return true;
}

Clip collapse_static_root(const Clip& clip) {
  if (!has_static_root(clip)) return clip;
  std::vector<int> keep;
  for (int j = 1; j < clip.skeleton.num_joints(); ++j) keep.push_back(j);
  // subset_clip requires joint 0; the static root's single child takes its place, so build the
  // reduced clip directly (its transform is constant identity plus a fixed translation).
  Clip out;
  const Skeleton& s = clip.skeleton;
  const int num_joints = s.num_joints();
  out.skeleton.meters_per_unit = s.meters_per_unit;
  out.skeleton.up_axis = s.up_axis;
  for (int j = 1; j < num_joints; ++j) {
    out.skeleton.joint_names.push_back(s.joint_names[j]);
    out.skeleton.parents.push_back(s.parents[j] <= 0 ? -1 : s.parents[j] - 1);
    out.skeleton.offsets.push_back(s.parents[j] == 0 ? s.offsets[0] + s.offsets[j] : s.offsets[j]);
  }
  for (const EndSite& e : s.end_sites)
    if (e.parent > 0) out.skeleton.end_sites.push_back({e.parent - 1, e.offset});
  const Motion& m = clip.motion;
  out.motion = m;
  out.motion.num_joints = num_joints - 1;
  out.motion.rotations.clear();
  out.motion.translations.clear();
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 1; j < num_joints; ++j) {
      out.motion.rotations.push_back(m.rotation(t, j));
      // The root's rotation is identity, so only its translation composes (dataset 1 moves it).
      out.motion.translations.push_back(s.parents[j] == 0 ? m.translation(t, 0) + m.translation(t, j)
                                                          : m.translation(t, j));
    }
  out.skeleton.validate();
  return out;
}

// ---- T-pose ----

constexpr int kMaxTposeFrames = 10;

const char* to_string(TposeMode mode) {
  switch (mode) {
    case TposeMode::kAuto: return "auto";
    case TposeMode::kOn: return "on";
    case TposeMode::kOff: return "off";
  }
  return "auto";
}

TposeMode parse_tpose_mode(const std::string& text) {
  if (text == "auto") return TposeMode::kAuto;
  if (text == "on") return TposeMode::kOn;
  if (text == "off") return TposeMode::kOff;
  throw Error("unknown T-pose mode '" + text + "' (expected auto, on or off)");
}

namespace {

// Non-root local rotations close to identity: mean geodesic angle < 0.15 rad, none above 0.5.
bool near_identity(const Motion& motion, int t) {
  double sum = 0, worst = 0;
  for (int j = 1; j < motion.num_joints; ++j) {
    const double angle = geodesic_angle(motion.rotation(t, j), Eigen::Quaterniond::Identity());
    sum += angle;
    worst = std::max(worst, angle);
  }
  return sum / (motion.num_joints - 1) < 0.15 && worst <= 0.5;
}

}  // namespace

int count_leading_rest_frames(const Motion& motion) {
  if (motion.num_frames < 3 || motion.num_joints < 2) return 0;
  int f = 0;
  while (f < kMaxTposeFrames && f + 2 < motion.num_frames && near_identity(motion, f)) ++f;
  if (f == 0 || f + 1 >= motion.num_frames) return 0;
  const double jump = pose_change(motion, f - 1, f).first;
  const double next = pose_change(motion, f, f + 1).first;
  return jump > 0.1 && jump > 5.0 * next ? f : 0;
}

bool looks_like_tpose(const Motion& motion) { return count_leading_rest_frames(motion) > 0; }

Motion remove_tpose(const Motion& motion, TposeMode mode) {
  if (motion.num_frames < 2 || mode == TposeMode::kOff) return motion;
  const int drop = mode == TposeMode::kOn ? 1 : count_leading_rest_frames(motion);
  return drop == 0 ? motion : slice_frames(motion, drop, motion.num_frames - drop);
}

// ---- Joint subsets ----

std::vector<int> select_joints(const Skeleton& skeleton, const std::vector<std::string>& drop_patterns,
                               const std::vector<std::string>& keep_patterns) {
  std::vector<int> keep;
  for (int j = 0; j < skeleton.num_joints(); ++j) {
    bool kept = keep_patterns.empty() || j == 0;
    for (const std::string& p : keep_patterns) kept = kept || glob_match(p, skeleton.joint_names[j]);
    for (const std::string& p : drop_patterns)
      if (j != 0 && glob_match(p, skeleton.joint_names[j])) kept = false;
    if (kept) keep.push_back(j);
  }
  return keep;
}

Clip subset_by_patterns(const Clip& clip, const std::vector<std::string>& drop_patterns,
                        const std::vector<std::string>& keep_patterns) {
  for (const std::string& p : drop_patterns)
    if (glob_match(p, clip.skeleton.joint_names.at(0)))
      throw Error("joint pattern '" + p + "' would drop the root joint '" + clip.skeleton.joint_names[0] + "'");
  const std::vector<int> keep = select_joints(clip.skeleton, drop_patterns, keep_patterns);
  if (static_cast<int>(keep.size()) == clip.skeleton.num_joints()) return clip;
  return subset_clip(clip, keep);
}

// ---- Frame rate ----

namespace {

// The pose at fractional source frame `frame` (clamped into the motion), rotations slerped and
// translations interpolated linearly between the two nearest frames, written into frame k of out.
void pose_at(const Motion& motion, double frame, Motion* out, int k) {
  const double s = std::clamp(frame, 0.0, static_cast<double>(motion.num_frames - 1));
  const int a = std::min(static_cast<int>(std::floor(s)), motion.num_frames - 1);
  const int b = std::min(a + 1, motion.num_frames - 1);
  const double w = std::clamp(s - a, 0.0, 1.0);
  for (int j = 0; j < motion.num_joints; ++j) {
    const Eigen::Quaterniond qa = motion.rotation(a, j);
    const Eigen::Quaterniond qb = align_hemisphere(motion.rotation(b, j), qa);
    out->rotation(k, j) = qa.slerp(w, qb).normalized();
    out->translation(k, j) = (1.0 - w) * motion.translation(a, j) + w * motion.translation(b, j);
  }
}

}  // namespace

Motion resample(const Motion& motion, double fps_out) {
  if (!(fps_out > 0) || !std::isfinite(fps_out)) throw Error("resample: target fps must be positive");
  if (std::abs(fps_out - motion.fps) <= 1e-5 * motion.fps) {
    // The same frames: a rounded frame time (Bandai-Namco's 0.0333333 s) is not a new rate.
    Motion same = motion;
    same.fps = fps_out;
    return same;
  }
  Motion out;
  out.fps = fps_out;
  out.num_joints = motion.num_joints;
  if (motion.num_frames == 0) return out;
  const double ratio = motion.fps / fps_out;  // source frames per output frame
  out.num_frames = static_cast<int>(std::floor((motion.num_frames - 1) / ratio + 1e-9)) + 1;
  out.rotations.resize(static_cast<size_t>(out.num_frames) * out.num_joints);
  out.translations.resize(out.rotations.size());
  for (int k = 0; k < out.num_frames; ++k) pose_at(motion, k * ratio, &out, k);
  return out;
}

// ---- Augmentation ----

Motion reverse_frames(const Motion& motion) {
  Motion out = motion;
  for (int t = 0; t < motion.num_frames; ++t)
    for (int j = 0; j < motion.num_joints; ++j) {
      out.rotation(t, j) = motion.rotation(motion.num_frames - 1 - t, j);
      out.translation(t, j) = motion.translation(motion.num_frames - 1 - t, j);
    }
  return out;
}

Motion retime(const Motion& motion, double factor) {
  if (!(factor > 0) || !std::isfinite(factor)) throw Error("retime: the speed factor must be positive");
  Motion faster = motion;
  faster.fps = motion.fps * factor;  // the same frames, played at factor times the rate
  return resample(faster, motion.fps);
}

int double_support_frame(const Skeleton& skeleton, const Motion& motion, RestEnd end, double min_moving_s) {
  const auto legs = find_legs(skeleton);
  if (legs.size() != 2 || motion.num_frames < 4) return -1;
  const int half = motion.num_frames / 2, margin = static_cast<int>(std::ceil(min_moving_s * motion.fps - 1e-9));
  const int first = end == RestEnd::kStart ? 1 : std::max(half, margin);
  const int last = end == RestEnd::kStart ? std::min(half, motion.num_frames - 1 - margin) : motion.num_frames - 1;
  if (first > last) return -1;
  const WorldPoses world = forward_kinematics(skeleton, motion);
  int best = -1;
  double best_speed = std::numeric_limits<double>::infinity();
  for (int t = first; t <= last; ++t) {
    double speed = 0;  // skeleton units per frame; the larger of the two ankles'
    for (const LegChain& leg : legs) {
      Eigen::Vector3d step = world.position(t, leg.ankle) - world.position(t - 1, leg.ankle);
      step[skeleton.up_axis] = 0;
      speed = std::max(speed, step.norm());
    }
    if (speed < best_speed) best_speed = speed, best = t;
  }
  return best;
}

Motion come_to_rest(const Motion& motion, int rest_frame, RestEnd end, double ramp_s, double hold_s) {
  if (!(ramp_s >= 0) || !std::isfinite(ramp_s) || !(hold_s >= 0) || !std::isfinite(hold_s))
    throw Error("come_to_rest: ramp and hold must be non-negative seconds");
  if (rest_frame < 0 || rest_frame >= motion.num_frames)
    throw Error("come_to_rest: rest frame " + std::to_string(rest_frame) + " outside the motion's " +
                std::to_string(motion.num_frames) + " frames");
  const double fps = motion.fps, rest_s = rest_frame / fps;
  const double moving_s = end == RestEnd::kEnd ? rest_s : motion.duration_s() - rest_s;  // source time on the moving side
  if (moving_s < ramp_s / 2 - 1e-9)
    throw Error("come_to_rest: " + std::to_string(moving_s) + " s of motion beside the rest frame, the ramp needs " +
                std::to_string(ramp_s / 2));
  // Output time u -> source time, for kEnd: free until u0, the ramp (rate 1 -> 0), then held.
  const double u0 = moving_s - ramp_s / 2, total_s = u0 + ramp_s + hold_s;
  const auto source_s = [&](double u) {
    if (u <= u0) return u;
    const double v = std::min(u - u0, ramp_s);
    return u0 + v - (ramp_s > 0 ? v * v / (2 * ramp_s) : 0.0);
  };
  Motion out;
  out.fps = fps;
  out.num_joints = motion.num_joints;
  out.num_frames = static_cast<int>(std::floor(total_s * fps + 1e-9)) + 1;
  out.rotations.resize(static_cast<size_t>(out.num_frames) * out.num_joints);
  out.translations.resize(out.rotations.size());
  for (int k = 0; k < out.num_frames; ++k) {
    if (end == RestEnd::kEnd) {
      pose_at(motion, source_s(k / fps) * fps, &out, k);
    } else {  // the kEnd mapping run backwards from the motion's last frame
      pose_at(motion, (motion.duration_s() - source_s(total_s - k / fps)) * fps, &out, k);
    }
  }
  return out;
}

MirrorPlan plan_mirror(const Skeleton& skeleton) {
  skeleton.validate();
  MirrorPlan plan;
  plan.map = mirror_map(skeleton);
  plan.world_axis = default_mirror_axis(skeleton);
  const int num_joints = skeleton.num_joints();
  plan.joint_axes.assign(num_joints, -1);
  const double size = skeleton_size(skeleton);
  std::vector<std::vector<Eigen::Vector3d>> sites(num_joints);
  for (const EndSite& e : skeleton.end_sites) sites[e.parent].push_back(e.offset);
  std::vector<std::vector<int>> children(num_joints);
  for (int j = 1; j < num_joints; ++j) children[skeleton.parents[j]].push_back(j);

  // Cost of mapping partner m's child offsets onto j's with the reflection of `axis`.
  auto cost = [&](int j, int m, int axis) {
    double c = 0;
    for (int child : children[j]) c += (reflect(axis, skeleton.offsets[plan.map[child]]) - skeleton.offsets[child]).norm();
    const size_t n = std::min(sites[j].size(), sites[m].size());
    for (size_t k = 0; k < n; ++k) c += (reflect(axis, sites[m][k]) - sites[j][k]).norm();
    return c;
  };
  for (int j = 0; j < num_joints; ++j) {
    const int m = plan.map[j];
    if (plan.joint_axes[j] >= 0) continue;  // set with its partner
    const int preferred = j == 0 ? plan.world_axis : plan.joint_axes[skeleton.parents[j]];
    int best = preferred;
    double best_cost = cost(j, m, preferred) + cost(m, j, preferred);
    for (int axis = 0; axis < 3; ++axis) {
      const double c = cost(j, m, axis) + cost(m, j, axis);
      if (c < best_cost - 1e-4 * size) {
        best = axis;
        best_cost = c;
      }
    }
    plan.joint_axes[j] = plan.joint_axes[m] = best;
  }
  for (int j = 0; j < num_joints; ++j) {
    for (int child : children[j])
      plan.asymmetry = std::max(
          plan.asymmetry,
          (reflect(plan.joint_axes[j], skeleton.offsets[plan.map[child]]) - skeleton.offsets[child]).norm());
  }
  return plan;
}

Motion mirror(const Skeleton& skeleton, const Motion& motion, const MirrorPlan& plan) {
  const int num_joints = skeleton.num_joints();
  if (motion.num_joints != num_joints || static_cast<int>(plan.map.size()) != num_joints ||
      static_cast<int>(plan.joint_axes.size()) != num_joints)
    throw Error("mirror: motion, skeleton and mirror plan disagree in joint count");
  std::vector<Eigen::Matrix3d> p(num_joints);
  for (int j = 0; j < num_joints; ++j) p[j] = reflection(plan.joint_axes[j]);
  const Eigen::Matrix3d s = reflection(plan.world_axis);
  Motion out = motion;
  for (int t = 0; t < motion.num_frames; ++t)
    for (int j = 0; j < num_joints; ++j) {
      const int m = plan.map[j];
      const int parent = skeleton.parents[j];
      const Eigen::Matrix3d& left = parent < 0 ? s : p[parent];
      Eigen::Quaterniond q(Eigen::Matrix3d(left * motion.rotation(t, m).toRotationMatrix() * p[j]));
      q.normalize();
      if (t > 0) q = align_hemisphere(q, out.rotation(t - 1, j));
      out.rotation(t, j) = q;
      out.translation(t, j) = parent < 0 ? Eigen::Vector3d(s * motion.translation(t, m))
                                         : Eigen::Vector3d(left * (motion.translation(t, m) - skeleton.offsets[m]) +
                                                           skeleton.offsets[j]);
    }
  return out;
}

Clip mirror(const Clip& clip) {
  Clip out = clip;
  out.motion = mirror(clip.skeleton, clip.motion, plan_mirror(clip.skeleton));
  return out;
}

}  // namespace mosyn::data
