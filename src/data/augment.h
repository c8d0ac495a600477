// Clip operations used while preparing a dataset: cleaning (static roots, converter T-poses,
// joint subsets, frame rate) and augmentation (mirroring, time reversal, retiming). All work on
// mosyn::Clip in skeleton units and never change the skeleton's units or up axis.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::data {

// ---- Static root -------------------------------------------------------------------------

// True when joint 0 has exactly one child joint and identity rotation (within 1e-6 rad) in
// every frame: a placeholder root like Bandai-Namco's `joint_Root` above `Hips`. Its translation
// may move (constant zero in Bandai-Namco dataset 2, partly carrying the forward motion in
// dataset 1): collapsing folds it into the child exactly.
bool has_static_root(const Clip& clip);

// The clip without its placeholder root, so its single child (Hips) becomes joint 0 with
// unchanged world transforms (the child's offset and per-frame translations absorb the root's
// translation); the clip unchanged when has_static_root is false. prepare applies this
// automatically, so Bandai-Namco datasets are rooted at Hips.
Clip collapse_static_root(const Clip& clip);

// ---- Converter T-pose ---------------------------------------------------------------------

enum class TposeMode {
  kAuto,  // drop frame 0 when looks_like_tpose says so (CMU's converter adds one to every file)
  kOn,    // always drop frame 0
  kOff,   // never drop anything
};
const char* to_string(TposeMode mode);
// "auto", "on" or "off"; throws mosyn::Error otherwise.
TposeMode parse_tpose_mode(const std::string& text);

// Number of leading frames that are a rest pose glued in front of the motion (0 if none): the
// first f <= 10 frames all have non-root local rotations close to identity (mean geodesic angle
// < 0.15 rad, none above 0.5 rad), frame f does not, and the jump from frame f-1 to f (mean
// non-root angle > 0.1 rad) is more than five times the change from f to f+1. Usually 1 (CMU's
// converter T-pose); CMU 07_12 has 2 and 09_10 has 5 (a T-pose, then all-zero frames at the
// origin).
int count_leading_rest_frames(const Motion& motion);
// count_leading_rest_frames(motion) > 0.
bool looks_like_tpose(const Motion& motion);

// kOn drops frame 0; kAuto drops count_leading_rest_frames frames; kOff and motions of fewer
// than 2 frames are returned unchanged.
Motion remove_tpose(const Motion& motion, TposeMode mode);

// ---- Joint subsets ------------------------------------------------------------------------

// Joints kept by glob patterns (core/subset.h glob_match, '*' and '?'): when keep_patterns is
// non-empty only matching joints are candidates; then joints matching any drop pattern are
// removed. The root (joint 0) is always kept. Ascending indices.
std::vector<int> select_joints(const Skeleton& skeleton, const std::vector<std::string>& drop_patterns,
                               const std::vector<std::string>& keep_patterns);

// The clip on select_joints(...), world transforms of kept joints unchanged (core/subset.h).
// Throws mosyn::Error when a drop pattern would remove the root.
Clip subset_by_patterns(const Clip& clip, const std::vector<std::string>& drop_patterns,
                        const std::vector<std::string>& keep_patterns);

// Frames [first, first + count) of a motion (the caller keeps them inside it).
Motion slice_frames(const Motion& motion, int first, int count);

// ---- Frame rate ---------------------------------------------------------------------------

// The motion resampled at fps_out (e.g. CMU 120 -> 30): frame k lies at time k / fps_out, for
// every k with k / fps_out <= duration; rotations are slerped and translations interpolated
// linearly between the two nearest source frames. When fps_out equals the motion's fps within
// 1e-5 relative (a rounded frame time), returns the same frames labelled fps_out. Throws
// mosyn::Error for fps_out <= 0.
Motion resample(const Motion& motion, double fps_out);

// ---- Augmentation -------------------------------------------------------------------------

// Frames in reverse order (a walk played backwards). Features computed from the result have
// consistent root deltas because they are recomputed from the reversed motion.
Motion reverse_frames(const Motion& motion);

// The motion played `factor` times as fast (factor > 1: faster, fewer frames), at its own frame
// rate: frame k is the source at time k * factor / fps, resampled as `resample` does. Planted
// feet stay planted, so a faster walk keeps clean contacts; its cadence scales with the speed
// and the stride stays the same (real people lengthen both). Throws mosyn::Error unless factor
// is positive and finite.
Motion retime(const Motion& motion, double factor);

// ---- Starts and stops ----------------------------------------------------------------------

// Which end of a motion comes to rest (come_to_rest).
enum class RestEnd { kStart, kEnd };

// The frame in the motion's first (kStart) or last (kEnd) half where both feet are slowest, i.e.
// double support: the larger of the two ankles' (core find_legs) horizontal speeds into the frame
// is least. Only frames with at least min_moving_s seconds of motion on their moving side (before
// the frame for kEnd, after it for kStart: what come_to_rest's ramp needs) are searched. -1 when
// the skeleton has not two legs, the motion has fewer than 4 frames, or no frame qualifies.
int double_support_frame(const Skeleton& skeleton, const Motion& motion, RestEnd end, double min_moving_s = 0.0);

// The motion brought to rest at one end, a walk (or run) stopping in, or starting from, its
// stance at rest_frame. kEnd: it plays at its own rate until ramp_s / 2 seconds of source time
// before rest_frame, then slows linearly to a standstill at rest_frame over ramp_s seconds and
// holds that pose for hold_s (its frames after rest_frame are dropped). kStart, the same reversed
// in time: rest_frame held for hold_s, then speeding up linearly over ramp_s to its own rate (its
// frames before rest_frame dropped). A planted foot stays planted through the ramp, the swing
// slows, the body's ground speed falls (rises) linearly: a stop in one or two slowing steps, as
// people stop, where the Bandai-Namco locomotion takes begin and end in stride, so a model trained
// on them glides to a halt at the end of a drawn path. Frames at the motion's rate, interpolated
// as resample does. Throws mosyn::Error when ramp_s or hold_s is negative or not finite,
// rest_frame lies outside the motion, or less than ramp_s / 2 of motion lies on its moving side.
Motion come_to_rest(const Motion& motion, int rest_frame, RestEnd end, double ramp_s, double hold_s);

// How a skeleton mirrors: the left/right partner of every joint (core/mirror.h mirror_map), the
// world reflection axis (core default_mirror_axis: X for Y-up) and, per joint, the axis of the
// reflection P_j in that joint's own frame that maps its partner's child offsets onto its own.
// P_j is the world axis for skeletons whose rest pose is symmetric (the synthetic biped, CMU),
// but Bandai-Namco's rest frames differ per joint (body along +X, legs split along Y, arms
// pointing along +-X), which core's mirror_motion does not handle.
struct MirrorPlan {
  std::vector<int> map;        // [J] partner joint, itself when unpaired
  int world_axis = 0;          // 0, 1, 2
  std::vector<int> joint_axes;  // [J] axis of P_j, equal for partners
  double asymmetry = 0;        // largest |P_j offset(partner child) - offset(child)|, skeleton units
};

// Chooses each joint's axis as the one that best maps the partner's child offsets (and end
// sites) onto the joint's own; ties (a single child on an axis, a leaf) take the parent's axis,
// the root's ties the world axis.
MirrorPlan plan_mirror(const Skeleton& skeleton);

// The motion reflected left/right: joint j takes partner m's motion,
//   root:      R' = S R(m) P_root,  t' = S t(m)        (S = reflection of world_axis)
//   others:    R' = P_parent R(m) P_j,  t' = P_parent (t(m) - offset(m)) + offset(j)
// so world positions are the reflected positions of the partners (exact for a skeleton whose
// asymmetry is 0, otherwise up to that asymmetry). Mirroring twice gives the input back.
Motion mirror(const Skeleton& skeleton, const Motion& motion, const MirrorPlan& plan);
Clip mirror(const Clip& clip);

}  // namespace mosyn::data
