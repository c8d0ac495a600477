// Root planting: a generated frame's floor step taken from the foot it stands on.
//
// Families that make their own root motion (hvrnn, DFN, MOJO) predict a pose and the root's step
// into it side by side. Measured on held-out walks, the two agree on average (a walk's pelvis
// keeps its speed when the step is taken from the feet) but not frame to frame, and a foot on the
// floor slides with every disagreement. Here each frame's step is replaced, in proportion to how
// firmly a foot is planted, by the step that keeps that foot where it was the frame before:
//
//   planted step = q(t-1) - R(dtheta) q(t)   (floor components, the previous frame's ground frame)
//
// with q the foot point in the character's ground frame (heading 0 at the floor origin) and
// dtheta the model's own turn. The pose and the turn stay the model's; only the floor path
// changes, and with no foot near the floor (a run's flight) the model's step is kept. Causal:
// frame t reads frames t-1 and t and the lowest heights of the last floor_window_s, so a stream
// and offline sampling give the same motion.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

struct RootPlantingOptions {
  double contact_height_m = 0.02;  // a foot point this close to its floor is planted (weight 1)
  double release_height_m = 0.05;  // and this far above it free (weight 0); linear between
  double floor_window_s = 2.0;     // a point's floor: its lowest height over the last window
  double keep_weight = 0.3;        // the chosen foot stays chosen while its weight exceeds this
  double switch_ratio = 3.0;       // unless the other foot is this many times more firmly planted
  // Throws mosyn::Error naming the field when a value is out of range.
  void validate() const;
};

// The foot points of each leg: the ankle (core/foot_lock.h find_legs) and its child joints (toes).
// Joint indices; empty when the skeleton has no legs find_legs recognises.
std::vector<std::vector<int>> foot_points(const Skeleton& skeleton);

class RootPlanter {
 public:
  // Throws mosyn::Error for invalid options or fps <= 0.
  RootPlanter(const Skeleton& skeleton, double fps, const RootPlantingOptions& options = {});

  // One frame. ground_frame_positions [J]: every joint of the frame in the character's ground
  // frame (skeleton units; heading 0, floor origin, the up coordinate is the height above the
  // floor). step_m: the model's step into this frame, (sideways, forward) metres in the previous
  // frame's ground frame (the control's dx, dz); turn_rad its dtheta. Returns the planted step.
  // The first frame after construction or reset() only records the feet and returns step_m.
  Eigen::Vector2d step(const std::vector<Eigen::Vector3d>& ground_frame_positions, const Eigen::Vector2d& step_m,
                       double turn_rad);
  // Forgets the feet (a new motion).
  void reset();
  // False when the skeleton has no legs: step() returns step_m unchanged.
  bool has_feet() const { return !legs_.empty(); }
  // Frames of the floor window (options.floor_window_s at fps): the history step() reads.
  int window_frames() const { return window_frames_; }

 private:
  struct Point {
    int joint = -1;
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();  // last frame's ground-frame position
    std::deque<double> heights_m;                        // recent heights, newest last
  };
  Skeleton skeleton_;
  RootPlantingOptions options_;
  int window_frames_ = 1;
  std::vector<std::vector<Point>> legs_;
  bool has_previous_ = false;
  int chosen_ = -1;  // the leg whose foot gives the step, -1 before the first choice
};

}  // namespace mosyn
