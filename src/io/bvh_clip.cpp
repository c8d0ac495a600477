// BVH <-> Clip: quaternions from the Euler channels, and back with Euler angles chosen
// continuous over time.
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "core/error.h"
#include "core/rotation.h"
#include "io/bvh.h"
#include "io/bvh_detail.h"

namespace mosyn::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;
constexpr double kRadPerDeg = kPi / 180.0;

// 2 pi multiple that brings angle closest to reference.
double unwrap_near(double angle, double reference) {
  return angle + 2 * kPi * std::round((reference - angle) / (2 * kPi));
}

// How one joint's rotation is written: the Euler order used for decomposition; its first
// num_rotation_channels axes are the joint's rotation channels in file order.
struct RotationPlan {
  int num_rotation_channels = 0;
  EulerOrder order = EulerOrder::kZYX;
};

RotationPlan plan_rotation(const BvhChannelLayout& layout) {
  RotationPlan plan;
  std::string axes;
  for (BvhChannel c : layout)
    if (is_rotation(c)) axes += static_cast<char>('X' + channel_axis(c));
  plan.num_rotation_channels = static_cast<int>(axes.size());
  // Fewer than three axes: complete the order with the missing ones (their angles are dropped).
  for (char a : std::string("XYZ"))
    if (axes.find(a) == std::string::npos) axes += a;
  plan.order = *parse_euler_order(axes);
  return plan;
}

// Euler angles (radians, in plan.order) of q nearest to `reference` (Euclidean distance): every
// equivalent triple is a shift by multiples of 2 pi of one of the two solutions (a0, a1, a2) and
// (a0 + pi, pi - a1, a2 + pi), so unwrapping each angle of both near `reference` and keeping the
// closer gives the nearest of all. With the previous frame's angles as reference, the written
// angles hence change by at most what following the rotation continuously would (at most
// sqrt(2) times the turned angle over the cosine of the middle angle).
Eigen::Vector3d nearest_euler(const Eigen::Quaterniond& q, const RotationPlan& plan, const Eigen::Vector3d& reference) {
  Eigen::Vector3d angles = euler_from_quat(q, plan.order);
  if (plan.num_rotation_channels == 3 && std::abs(std::sin(angles[1])) >= 1.0 - 1e-12) {
    // Gimbal lock: only a0 + a2 or a0 - a2 is determined. Its change from the reference is split
    // evenly between the two (the nearest such pair), so neither angle lurches and the next
    // frame, off the lock, continues from both.
    const int last_axis = euler_axis(plan.order, 2);
    Eigen::Vector3d kept = euler_from_quat(q * quat_about_axis(last_axis, -reference[2]), plan.order);
    const double change = unwrap_near(kept[0], reference[0]) - reference[0];
    const Eigen::Vector3d sum(reference[0] + change / 2, kept[1], reference[2] + change / 2);
    const Eigen::Vector3d difference(reference[0] + change / 2, kept[1], reference[2] - change / 2);
    angles = geodesic_angle(quat_from_euler(sum, plan.order), q) <= geodesic_angle(quat_from_euler(difference, plan.order), q)
                 ? sum
                 : difference;
  }
  // The other triple is the same rotation only when all three angles are kept.
  Eigen::Vector3d candidates[2] = {angles, Eigen::Vector3d(angles[0] + kPi, kPi - angles[1], angles[2] + kPi)};
  const int num_candidates = plan.num_rotation_channels == 3 ? 2 : 1;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < num_candidates; ++k) {
    Eigen::Vector3d& c = candidates[k];
    for (int i = 0; i < 3; ++i) c[i] = unwrap_near(c[i], reference[i]);
    const double distance = (c - reference).squaredNorm();
    if (distance < best) {
      best = distance;
      angles = c;
    }
  }
  return angles;
}

// A joint turning more than this between two frames is not moving in a way its angles can
// follow smoothly (CMU takes open with a T-pose frame; capture glitches flip a foot by 60 to 180
// degrees): the angles jump whichever triple is taken, and the one nearest the previous frame's
// is often on the other branch (01_01.bvh's left forearm: 0 -> -143.2 degrees where the source
// has 0 -> -36.8), which the rest of the take would then keep. Real motion seldom turns this
// fast (50 of 8.2 million joint steps in the shared 30 fps Bandai-Namco takes, at most 67 degrees,
// a punching forearm); there the source's steps, when known, are what following it gives anyway.
constexpr double kFreshStartTurn = kPi / 4;

// The source file's own angles (radians, plan order) of joint j at frame t, when the layout
// template carries the very motion being written (as `mosyn convert` passes it) and its triple
// there is the clip's rotation; nullopt otherwise (resampled, edited or generated motion).
std::optional<Eigen::Vector3d> source_angles(const BvhFile* source, const RotationPlan& plan, int j, int t,
                                             const Eigen::Quaterniond& q) {
  if (source == nullptr || plan.num_rotation_channels != 3 || t >= source->num_frames) return std::nullopt;
  const size_t num_channels = static_cast<size_t>(source->num_channels());
  if (source->values.size() != static_cast<size_t>(source->num_frames) * num_channels) return std::nullopt;
  const double* value = source->values.data() + static_cast<size_t>(t) * num_channels + source->first_channel(j);
  Eigen::Vector3d angles;
  int i = 0;
  for (BvhChannel c : source->channels[static_cast<size_t>(j)]) {
    if (is_rotation(c)) angles[i++] = *value * kRadPerDeg;
    ++value;
  }
  if (!angles.allFinite() || geodesic_angle(quat_from_euler(angles, plan.order), q) > 1e-6) return std::nullopt;
  return angles;
}

// Whether two triples are equal up to multiples of 2 pi per angle.
bool same_angles(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  for (int i = 0; i < 3; ++i)
    if (std::abs(unwrap_near(a[i], b[i]) - b[i]) > 1e-6) return false;
  return true;
}

// The angles written for joint j at frame t: the triple nearest the previous frame's, except at
// frame 0 and after a turn of more than kFreshStartTurn, where the angles cannot follow:
// - frame 0 takes the source file's own angles where known, else the principal solution (middle
//   angle within +-90 degrees);
// - a jump takes the source's step where the source is known at both frames: each angle changes
//   as the source's does (taken within +-180 degrees), the middle one mirrored when the written
//   angles are on the source's other branch, so no channel jumps further than in the source;
// - otherwise the principal solution, each angle unwrapped near the previous frame's.
Eigen::Vector3d written_euler(const Eigen::Quaterniond& q, const RotationPlan& plan, const Eigen::Vector3d* previous,
                              const Eigen::Quaterniond& previous_q, const BvhFile* source, int j, int t) {
  if (previous != nullptr && geodesic_angle(previous_q, q) <= kFreshStartTurn) return nearest_euler(q, plan, *previous);
  const std::optional<Eigen::Vector3d> own = source_angles(source, plan, j, t, q);
  if (previous == nullptr) return own ? nearest_euler(q, plan, *own) : euler_from_quat(q, plan.order);
  const std::optional<Eigen::Vector3d> own_before = own ? source_angles(source, plan, j, t - 1, previous_q) : std::nullopt;
  if (own_before) {
    Eigen::Vector3d step = *own - *own_before;
    for (int i = 0; i < 3; ++i) step[i] = unwrap_near(step[i], 0.0);
    const Eigen::Vector3d other_before((*own_before)[0] + kPi, kPi - (*own_before)[1], (*own_before)[2] + kPi);
    if (same_angles(*previous, *own_before)) return nearest_euler(q, plan, *previous + step);
    if (same_angles(*previous, other_before)) return nearest_euler(q, plan, *previous + Eigen::Vector3d(step[0], -step[1], step[2]));
  }
  Eigen::Vector3d start = own ? *own : euler_from_quat(q, plan.order);
  for (int i = 0; i < 3; ++i) start[i] = unwrap_near(start[i], (*previous)[i]);
  return nearest_euler(q, plan, start);  // start itself, recomputed from q
}

// The channel layouts for a clip written without a template: CMU-like (see from_clip).
std::vector<BvhChannelLayout> default_layouts(const Clip& clip) {
  const Skeleton& sk = clip.skeleton;
  const Motion& m = clip.motion;
  const BvhChannelLayout kPosition = {BvhChannel::kXposition, BvhChannel::kYposition, BvhChannel::kZposition};
  const BvhChannelLayout kRotation = {BvhChannel::kZrotation, BvhChannel::kYrotation, BvhChannel::kXrotation};
  std::vector<BvhChannelLayout> layouts(static_cast<size_t>(sk.num_joints()));
  for (int j = 0; j < sk.num_joints(); ++j) {
    bool animated = j == 0;
    const Eigen::Vector3d& offset = sk.offsets[static_cast<size_t>(j)];
    for (int t = 0; t < m.num_frames && !animated; ++t)
      animated = (m.translation(t, j) - offset).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + offset.cwiseAbs().maxCoeff());
    BvhChannelLayout& layout = layouts[static_cast<size_t>(j)];
    if (animated) layout = kPosition;
    layout.insert(layout.end(), kRotation.begin(), kRotation.end());
  }
  return layouts;
}

// The template's layouts, checked against the clip's skeleton.
std::vector<BvhChannelLayout> template_layouts(const Skeleton& sk, const BvhFile& layout_template) {
  const int num_joints = sk.num_joints();
  const Skeleton& tk = layout_template.skeleton;
  if (tk.joint_names != sk.joint_names)
    throw Error("from_clip: the layout template's joints (" + std::to_string(tk.num_joints()) +
                ") differ from the clip's (" + std::to_string(num_joints) + ") in number, names or order");
  if (layout_template.channels.size() != static_cast<size_t>(num_joints))
    throw Error("from_clip: the layout template has " + std::to_string(layout_template.channels.size()) +
                " channel layouts for " + std::to_string(num_joints) + " joints");
  for (int j = 0; j < num_joints; ++j)
    detail::check_layout(layout_template.channels[static_cast<size_t>(j)], sk.joint_names[static_cast<size_t>(j)]);
  return layout_template.channels;
}

}  // namespace

Clip to_clip(const BvhFile& bvh) {
  detail::check_consistent(bvh);
  Clip clip;
  clip.skeleton = bvh.skeleton;
  Motion& m = clip.motion;
  const int num_joints = bvh.skeleton.num_joints();
  m.fps = 1.0 / bvh.frame_time_s;
  m.num_frames = bvh.num_frames;
  m.num_joints = num_joints;
  const size_t n = static_cast<size_t>(m.num_frames) * static_cast<size_t>(num_joints);
  m.rotations.assign(n, Eigen::Quaterniond::Identity());
  m.translations.resize(n);
  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  for (int t = 0; t < m.num_frames; ++t) {
    const double* row = bvh.values.data() + static_cast<size_t>(t) * num_channels;
    size_t column = 0;
    for (int j = 0; j < num_joints; ++j) {
      Eigen::Vector3d translation = bvh.skeleton.offsets[static_cast<size_t>(j)];
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      for (BvhChannel c : bvh.channels[static_cast<size_t>(j)]) {
        const double v = row[column++];
        if (is_rotation(c)) {
          q = q * quat_about_axis(channel_axis(c), v * kRadPerDeg);
        } else {
          translation[channel_axis(c)] = v;
        }
      }
      q.normalize();
      if (t > 0 && q.dot(m.rotation(t - 1, j)) < 0) q.coeffs() = -q.coeffs();
      m.rotation(t, j) = q;
      m.translation(t, j) = translation;
    }
  }
  return clip;
}

BvhFile from_clip(const Clip& clip, const BvhFile* layout_template) {
  const Skeleton& sk = clip.skeleton;
  const Motion& m = clip.motion;
  sk.validate();
  const int num_joints = sk.num_joints();
  if (m.num_joints != num_joints)
    throw Error("from_clip: motion has " + std::to_string(m.num_joints) + " joints, skeleton " + std::to_string(num_joints));
  m.validate();

  BvhFile bvh;
  bvh.skeleton = sk;
  bvh.frame_time_s = 1.0 / m.fps;
  bvh.num_frames = m.num_frames;
  bvh.channels = layout_template != nullptr ? template_layouts(sk, *layout_template) : default_layouts(clip);
  std::vector<RotationPlan> plans;
  plans.reserve(static_cast<size_t>(num_joints));
  for (const BvhChannelLayout& layout : bvh.channels) plans.push_back(plan_rotation(layout));

  const size_t num_channels = static_cast<size_t>(bvh.num_channels());
  bvh.values.resize(static_cast<size_t>(m.num_frames) * num_channels);
  std::vector<Eigen::Vector3d> previous(static_cast<size_t>(num_joints), Eigen::Vector3d::Zero());
  for (int t = 0; t < m.num_frames; ++t) {
    double* row = bvh.values.data() + static_cast<size_t>(t) * num_channels;
    size_t column = 0;
    for (int j = 0; j < num_joints; ++j) {
      const RotationPlan& plan = plans[static_cast<size_t>(j)];
      Eigen::Vector3d& angles = previous[static_cast<size_t>(j)];  // radians, in plan.order
      if (plan.num_rotation_channels > 0) {
        const Eigen::Quaterniond q = m.rotation(t, j).normalized();
        const Eigen::Quaterniond previous_q = t > 0 ? m.rotation(t - 1, j).normalized() : q;
        angles = written_euler(q, plan, t > 0 ? &angles : nullptr, previous_q, layout_template, j, t);
      }
      const Eigen::Vector3d& translation = m.translation(t, j);
      int rotation_index = 0;
      for (BvhChannel c : bvh.channels[static_cast<size_t>(j)]) {
        // Rotation channels take the plan's angles in order (the order starts with their axes).
        row[column++] = is_rotation(c) ? angles[rotation_index++] * kDegPerRad : translation[channel_axis(c)];
      }
    }
  }
  return bvh;
}

}  // namespace mosyn::io
