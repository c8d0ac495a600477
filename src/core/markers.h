// Virtual surface markers: points rigidly attached to a skeleton's bones, in the layout of the
// CMU motion-capture database's 41 markers (the layout MOJO predicts, Zhang et al. 2021, Sec. 3.2),
// and the fit of a pose to markers (the inverse: joint rotations and root position from marker
// positions). No LibTorch.
//
// How a marker is defined once per skeleton: the skeleton's body parts are found by joint name
// (Bandai-Namco: Hips, Spine, Chest, Neck, Head, Shoulder_L, UpperArm_L, ...; CMU: Hips,
// LowerBack, Spine, Spine1, Neck, Neck1, Head, LeftShoulder, LeftArm, ...); the skeleton is put
// into a canonical T-pose (canonical_pose: spine and neck up, arms out sideways, legs down, feet
// forward; body facing +forward with its left on +left in the axes of canonical_body_axes); each
// marker is placed anatomically in that pose (a point between two joints plus an offset off the
// bone in metres, e.g. LELB 4.5 cm behind and 2 cm above the elbow) and stored as an offset in its
// bone's local frame. From then on marker m of a pose is p_w(joint_m) + R_w(joint_m) offset_m:
// markers off the bone axis (arm, forearm, wrist, thigh and shin markers) make twist visible.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "core/kinematics.h"
#include "core/skeleton.h"

namespace mosyn {

struct Marker {
  std::string name;                 // CMU name, e.g. "LFHD"
  int joint = -1;                   // the joint whose frame carries it
  Eigen::Vector3d offset{0, 0, 0};  // in that joint's local frame, skeleton units
};

struct MarkerSet {
  std::vector<Marker> markers;  // in kCmu41MarkerNames order
  int num_markers() const { return static_cast<int>(markers.size()); }
  // Index of the marker with this name, or -1.
  int find(const std::string& name) const;
};

// The 41 CMU marker names, in the order markers are stored and written (SOMA's "cmu_41" order).
const std::vector<std::string>& cmu41_marker_names();

// The body parts a marker layout needs, as joint indices (-1 = absent).
struct BodyParts {
  int pelvis = -1, spine = -1, chest = -1, neck = -1, head = -1;
  int clavicle[2] = {-1, -1}, upper_arm[2] = {-1, -1}, forearm[2] = {-1, -1}, hand[2] = {-1, -1};
  int thigh[2] = {-1, -1}, shin[2] = {-1, -1}, foot[2] = {-1, -1}, toe[2] = {-1, -1};  // [0] left, [1] right
};

// Finds the body parts by joint name (Bandai-Namco and CMU names; see the file comment). spine may
// be absent (-1); every other part must exist, otherwise mosyn::Error names the first missing one.
BodyParts find_body_parts(const Skeleton& skeleton);

// Body axes of the canonical pose in the skeleton's world frame: up = the up axis, forward and
// left = the two other axes, right-handed (left = up x forward): Y-up gives forward +Z, left +X.
struct BodyAxes {
  Eigen::Vector3d up, forward, left;
};
BodyAxes canonical_body_axes(const Skeleton& skeleton);

// A one-frame motion of the skeleton in the canonical T-pose: every body part's bone points along
// its canonical direction (the pelvis and chest take two directions: up to the next spine joint
// and left across the hips / shoulders); joints that are no body part keep identity local
// rotations; the pelvis sits at the origin. Bone swing is minimal from the parent, so twist about
// a limb follows the skeleton's rest frames.
Motion canonical_pose(const Skeleton& skeleton, const BodyParts& parts);

// The CMU 41-marker layout on this skeleton (placed in canonical_pose, offsets in metres converted
// with skeleton.meters_per_unit). Throws mosyn::Error when a body part is missing.
MarkerSet cmu41_markers(const Skeleton& skeleton);

// World positions [M] of the markers at frame t of the forward kinematics, skeleton units.
std::vector<Eigen::Vector3d> marker_positions(const MarkerSet& markers, const WorldPoses& world, int t);

// World positions [T, M] (row-major) of every frame of a motion, skeleton units.
std::vector<Eigen::Vector3d> marker_positions(const Skeleton& skeleton, const MarkerSet& markers, const Motion& motion);

// Options of fit_markers.
struct MarkerFitOptions {
  int max_iterations = 30;       // Levenberg-Marquardt iterations
  double pose_prior = 1e-5;      // weight (metres^2 per radian^2) of the squared change of every
                                 // local rotation away from the start pose, against the squared
                                 // marker errors in metres: keeps what the markers do not see (twist
                                 // of a marker-less joint) where it was; 1e-5 makes 1 rad cost as
                                 // much as 3 mm of marker error
  double tolerance = 1e-7;       // stop when the step's largest rotation (rad) and translation
                                 // (skeleton units, divided by the skeleton's size) fall below
};

// What one fit reached.
struct MarkerFitResult {
  int iterations = 0;
  double rms_error = 0.0;  // root mean squared marker distance after the fit, skeleton units
  std::vector<Eigen::Vector3d> fitted;  // [M] the markers of the fitted frame (world, skeleton units)
};

// Fits frame t of `motion` (local rotations of every joint and the root's translation; other
// translations stay) so that its markers match targets [M] (world, skeleton units), starting from
// the frame's current values (a warm start: the previous frame's fit). Levenberg-Marquardt on
// the exact Jacobian of the markers w.r.t. small world-axis rotations of each joint's subtree about
// the joint and the root's translation, plus the pose prior. Throws mosyn::Error when targets do
// not have one entry per marker.
MarkerFitResult fit_markers(const Skeleton& skeleton, const MarkerSet& markers,
                            const std::vector<Eigen::Vector3d>& targets, Motion* motion, int t,
                            const MarkerFitOptions& options = {});

// A start for fitting a frame from nothing: the canonical pose, turned about the up axis to the
// heading of the waist markers and with the pelvis at their centre. targets [M] as for fit_markers.
void initialise_from_markers(const Skeleton& skeleton, const MarkerSet& markers,
                             const std::vector<Eigen::Vector3d>& targets, Motion* motion, int t);

}  // namespace mosyn
