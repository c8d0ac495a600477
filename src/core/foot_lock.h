// Foot locking: an optional post-process for users who need clean feet (off by default; the
// models' raw output is what mosyn evaluates). Contacts are detected from the motion's own feet
// (an ankle near its floor and slow), each contact is pinned to one floor position, and the leg
// reaches it by two-bone inverse kinematics (hip and knee rotations; the foot keeps its world
// orientation), blending in and out around the contact so nothing pops.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>
#include <utility>
#include <vector>

#include "core/kinematics.h"
#include "core/skeleton.h"

namespace mosyn {

struct FootLockOptions {
  double contact_height_m = 0.04;  // ankle within this of its floor (its 5th-percentile height)
  double contact_speed_mps = 0.4;  // and its horizontal speed below this: in contact
  double min_contact_s = 0.08;     // shorter runs are not contacts
  double blend_s = 0.1;            // ramp from free to pinned before a contact and back after it
};

// A leg found by name: the ankle ("foot"/"ankle" in its name), its parent (knee) and
// grandparent (hip). Joint indices into the skeleton.
struct LegChain {
  int hip = -1, knee = -1, ankle = -1;
};

// Every leg of the skeleton (usually two). Empty when none is found.
std::vector<LegChain> find_legs(const Skeleton& skeleton);

// Contact intervals [begin, end) of one ankle (joint index) in `world` (FK of a motion at fps):
// runs of at least min_contact_s in which the ankle is within contact_height_m of its floor (its
// 5th-percentile height) and slower than contact_speed_mps horizontally. Units from
// skeleton.meters_per_unit, up from skeleton.up_axis. Throws mosyn::Error for invalid options.
std::vector<std::pair<int, int>> find_contacts(const Skeleton& skeleton, const WorldPoses& world, int ankle,
                                               const FootLockOptions& options, double fps);

// blend_s in frames at fps (rounded, >= 0).
int contact_blend_frames(const FootLockOptions& options, double fps);

// Weight of a contact [begin, end) at frame t: 1 inside, a raised-cosine ramp over blend_frames
// frames on either side, 0 beyond.
double contact_weight(int t, int begin, int end, int blend_frames);

// Two-bone IK in world space: the knee position that puts the ankle at target with upper and
// lower bone lengths kept, bending in the plane of the hip, the target and the current knee
// (pole). A target out of reach is approached along the hip-target line as far as the bones go.
Eigen::Vector3d two_bone_knee(const Eigen::Vector3d& hip, const Eigen::Vector3d& knee, const Eigen::Vector3d& target,
                              double upper_length, double lower_length);

// Moves one leg of frame t of `world` (FK of a motion) so its ankle lands on target: hip and knee
// rotations from two_bone_knee, the foot keeping its world orientation; writes the three local
// rotations into frame motion_frame of *motion.
void reach_with_leg(const Skeleton& skeleton, const WorldPoses& world, int t, const LegChain& leg,
                    const Eigen::Vector3d& target, Motion* motion, int motion_frame);

struct FootLockReport {
  int contacts = 0;                // contact intervals pinned over all legs
  double max_correction_m = 0.0;   // largest horizontal ankle move
};

// The motion with its feet pinned during contacts (see the top of this file). Units come from
// skeleton.meters_per_unit; the up axis from skeleton.up_axis. Only the leg joints' local
// rotations change; bone lengths and every other joint stay as they were. Returns the motion
// unchanged when the skeleton has no legs. Throws mosyn::Error for invalid options or a motion
// that does not fit the skeleton.
Motion foot_lock(const Skeleton& skeleton, const Motion& motion, const FootLockOptions& options = {},
                 FootLockReport* report = nullptr);

// The causal form for frame-by-frame generation (nn::GeneratorOptions::foot_lock): a contact
// starts when an ankle comes within contact_height_m of its floor (its lowest height over the
// last 2 s) below contact_speed_mps, and pins the ankle where it is; it ends when the ankle rises
// above 1.5 contact_height_m or the body pulls it more than kMaxStretchM from the pin. The pin
// blends in and out over blend_s. min_contact_s does not apply (the future is unknown).
class StreamingFootLock {
 public:
  static constexpr double kMaxStretchM = 0.25;

  // Throws mosyn::Error for invalid options or fps.
  StreamingFootLock(const Skeleton& skeleton, double fps, const FootLockOptions& options = {});
  // The next frame (a one-frame motion in world placement) with its feet pinned.
  Motion apply(const Motion& frame);
  // Forgets every contact (a new stream).
  void reset();
  // False when the skeleton has no legs find_legs recognises: apply() changes nothing.
  bool has_legs() const { return !legs_.empty(); }

 private:
  struct LegState {
    bool contact = false;
    double weight = 0;             // 0 free .. 1 pinned
    Eigen::Vector3d pin = Eigen::Vector3d::Zero();
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();  // last frame's own (unpinned) ankle
    bool has_previous = false;
    std::deque<double> heights;    // recent ankle heights, skeleton units
  };
  Skeleton skeleton_;
  FootLockOptions options_;
  double fps_;
  std::vector<LegChain> legs_;
  std::vector<LegState> states_;
};

}  // namespace mosyn
