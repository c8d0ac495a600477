// Control signals for synthesis: the per-frame root deltas (dx, dz metres, dtheta radians, the
// delta from frame t-1 to t in the character's own ground frame; see data/representation.h) that
// MoGlow and the recurrent VAE follow. Three sources: a path of waypoints on the ground, the root
// motion of any BVH clip, and a CSV of deltas.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::data {

// A point of a ground path: position on the floor in metres (x and z for a Y-up world) and the
// time to stand still on arriving there.
struct Waypoint {
  double x_m = 0;
  double z_m = 0;
  double pause_s = 0;
};

// Parses "x,z x,z,pause ..." (spaces or semicolons between points; a third number is the pause
// in seconds at that point). Throws mosyn::Error quoting the offending point.
std::vector<Waypoint> parse_path(const std::string& text);

struct PathOptions {
  double speed_mps = 1.3;       // walking speed along the path
  double fps = 30.0;            // frames per second of the control
  double seconds = 0;           // total duration; 0 = as long as the path takes (+ 1 s standing),
                                // longer = stand at the end, shorter = cut off
  double accel_s = 0.6;         // time to reach full speed from standing, and to stop again
  double corner_radius_m = 0.6; // corners are rounded with arcs of this radius at most
  double standing_s = 10.0;     // duration when the path is a single point (standing still)
};

// Control [T, 3] row-major for walking a path: the polyline through the waypoints with rounded
// corners, walked at speed_mps with smooth starts and stops (and at every pause), facing along
// the path. The character starts at the first waypoint facing the second (heading 0 = +Z; the
// returned start_heading_rad tells the world heading of frame 0). A single waypoint means
// standing still. Throws mosyn::Error for an empty path or non-positive speed or fps.
std::vector<float> control_from_path(const std::vector<Waypoint>& path, const PathOptions& options,
                                     double* start_heading_rad = nullptr);

// Control [T, 3] from a clip's root motion (any skeleton: a placeholder root such as
// Bandai-Namco's joint_Root is folded away, the units are the skeleton's meters_per_unit, or
// guessed when it is 1 and the body is clearly not in metres), resampled to fps.
std::vector<float> control_from_clip(const Clip& clip, double fps, double* start_heading_rad = nullptr);

// Control [T, 3] at fps from a CSV with columns dx, dz, dtheta (io/csv.h read_control_csv). A file
// with a t_s column is resampled by its times (resample_control); one without is taken to hold
// frames at csv_fps and resampled from it, or, when csv_fps is 0, frames at fps already. Throws
// mosyn::Error naming the file for fewer than 2 frames, or for csv_fps > 0 on a file that has times.
std::vector<float> control_from_csv(const std::string& path, double fps, double csv_fps = 0.0);

// The control [T, 3] whose frame t lies at times_s[t] (seconds, increasing), at fps: integrated to
// its ground path (integrate_control, heading 0), the positions and unwrapped headings interpolated
// linearly at times_s[0] + k / fps for every k that stays within times_s.back() (plus 1e-6 s), and
// differentiated again, so the path passes through the same points at the same times. Equal times
// and rate return the control (to float rounding). Throws mosyn::Error for a size mismatch, fewer
// than 2 frames, times that do not increase, or fps <= 0.
std::vector<float> resample_control(const std::vector<float>& control, const std::vector<double>& times_s, double fps);

// The control re-shaped like the controls of a dataset prepared with root smoothing sigma_s
// (seconds; FeatureLayout::root_smoothing_s): integrated to a ground trajectory, Gaussian-filtered
// (core/trajectory.h smooth_ground_trajectory) at fps, and differentiated again. A path of corners
// and sudden stops becomes one that turns and stops as the smoothed hip trajectories of motion
// capture do; a control that is already smooth barely changes. The filter keeps the first and
// last positions and headings, so the path starts and ends where it did. sigma_s <= 0 returns
// the control unchanged. Throws mosyn::Error when control does not hold whole [3] rows.
std::vector<float> smooth_control(const std::vector<float>& control, double fps, double sigma_s);

// The ground path (metres, [T] points with the up coordinate 0, Y-up) that a control traces from
// the origin with the given start heading; used to draw and check paths. headings_rad, when given,
// receives the heading at every frame [T] (radians, unwrapped).
std::vector<Eigen::Vector3d> integrate_control(const std::vector<float>& control, double start_heading_rad = 0.0,
                                               std::vector<double>* headings_rad = nullptr);

}  // namespace mosyn::data
