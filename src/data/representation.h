// Feature representations of motion: how a clip becomes per-frame vectors for learning and how
// vectors become a clip again. Both forms use the same control signal, the per-frame root
// deltas of core/trajectory.h: control[t] = (dx, dz, dtheta) in metres and radians, of the
// floor-projected hip trajectory, Gaussian-filtered (MoGlow Sec. 4.1) when the layout says so.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"
#include "core/trajectory.h"

namespace mosyn::data {

enum class PoseForm {
  // Local joint rotations (6D, Zhou et al.) of every joint; the root's rotation relative to
  // its heading frame; plus the root's height above the floor (metres).
  kRotations,
  // Joint positions relative to the floor-projected root, in the root's heading frame (metres).
  // Back to rotations through an inverse-kinematics fit onto the skeleton.
  kPositions,
  // Virtual surface markers (core/markers.h: the CMU 41-marker layout rigidly attached to the
  // bones, as MOJO, Zhang et al. 2021) relative to the floor-projected root, in the root's heading
  // frame (metres). Back to rotations through a Levenberg-Marquardt fit of the skeleton to them.
  kMarkers,
};

// Every form, for tables and messages. Code that depends on the form switches over it without a
// default, so a new form (e.g. markers) is a compile warning everywhere it needs handling.
constexpr PoseForm kPoseForms[] = {PoseForm::kRotations, PoseForm::kPositions, PoseForm::kMarkers};

const char* to_string(PoseForm form);
// "rotations", "positions" or "markers"; throws mosyn::Error otherwise.
PoseForm parse_pose_form(const std::string& text);

// How a feature vector is laid out, written into dataset.json and run directories.
struct FeatureLayout {
  PoseForm form = PoseForm::kRotations;
  int root_joint = 0;       // index of the trajectory joint (Bandai-Namco: Hips once joint_Root is dropped)
  Eigen::Vector3d forward_in_root{0, 0, 1};  // rest facing in the root's frame (core/trajectory.h)
  int pose_dim = 0;
  int control_dim = 3;
  std::vector<std::string> pose_names;     // [pose_dim] human-readable names, e.g. "Hips.r6d0"
  std::vector<std::string> control_names;  // {"dx_m", "dz_m", "dtheta_rad"}
  // Standard deviation (seconds) of the Gaussian filter applied to the hip's floor trajectory
  // and heading before they become the control (core/trajectory.h smooth_ground_trajectory).
  // 0 = the raw hip trajectory (datasets made before this option). With smoothing, the control
  // carries the path but not the gait's rhythm; what the hips do around the smoothed path (sway,
  // bob, yaw oscillation) is in the pose features instead (layouts below).
  double root_smoothing_s = 0.0;
  bool smoothed_root() const { return root_smoothing_s > 0; }
};

// Exact layouts (J joints, r = root_joint, headings and deltas from core/trajectory.h):
//   Trajectory (position p_t on the floor, heading theta_t): the hip joint r's floor projection
//               and heading (core/trajectory.h ground_trajectory), Gaussian-filtered with
//               sigma = root_smoothing_s * fps frames when root_smoothing_s > 0.
//   kRotations  pose[t] = [height of joint r above the floor in metres (1),
//                          6D of joint r's world rotation relative to the trajectory heading,
//                          i.e. heading_rotation(theta_t)^-1 * R_world(r) (6),
//                          6D local rotation of every other joint, in joint order (6 (J - 1)),
//                          only when smoothed: joint r's floor position minus p_t, rotated by
//                          heading_rotation(theta_t)^-1, its two floor coordinates in axis order
//                          (x, z for Y-up), metres (2)]
//               pose_dim = 1 + 6 J (+ 2 when smoothed). Joints other than the skeleton's root whose translations
//               are animated lose that animation: decode uses their rest offsets (Bandai-Namco's
//               non-Hips position channels equal their offsets, so nothing is lost there).
//   kPositions  pose[t] = [world position of joint j minus the trajectory position p_t,
//                          rotated by heading_rotation(theta_t)^-1, metres (3)] for
//                          j = 0..J-1; joint r's own entry is (0, height, 0) for Y-up on the raw
//                          trajectory, (sway, height, forward offset) on a smoothed one.
//               pose_dim = 3 J.
//   kMarkers    pose[t] = [world position of marker m (core/markers.h cmu41_markers) minus p_t,
//                          rotated by heading_rotation(theta_t)^-1, metres (3)] for the 41 markers
//               in cmu41_marker_names() order; pose_dim = 123 whatever the skeleton (which must
//               have the body parts find_body_parts looks for).
//   control[t] = (dx, dz in metres, dtheta in radians): RootDelta of the trajectory moving
//                frame t-1 to frame t in the ground frame of t-1; control[0] = 0.
// 6D vectors are rot6d_from_quat (core/rotation.h): the first two matrix columns.
//
// Layout for a skeleton in a given form. Names: "<joint>.height_m", "<joint>.heading_r6d<k>",
// "<joint>.r6d<k>", "<joint>.x_m" / ".y_m" / ".z_m", "<joint>.offset_x_m" / ".offset_z_m".
// Throws mosyn::Error for a root_joint out of range, a zero forward_in_root (normalised
// otherwise) or a root_smoothing_s outside [0, 10] seconds.
FeatureLayout make_layout(const Skeleton& skeleton, PoseForm form, int root_joint,
                          const Eigen::Vector3d& forward_in_root, double root_smoothing_s = 0.0);

// Pose dimensions of a layout's form on a skeleton of num_joints joints (kMarkers: 3 x 41, any skeleton).
int expected_pose_dim(PoseForm form, int num_joints, bool smoothed_root);

// The trajectory a layout encodes a motion against (see the layouts above): the hip joint's
// floor path and heading, smoothed with the layout's root_smoothing_s at motion.fps.
GroundTrajectory control_trajectory(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout);

// Encodes a clip: pose [T, pose_dim] and control [T, control_dim], row-major float32, raw (not
// standardised). Uses skeleton.meters_per_unit for metres. Throws mosyn::Error when the motion,
// skeleton and layout disagree.
void encode(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout,
            std::vector<float>* pose, std::vector<float>* control);

// Pose features only, of a motion against a given trajectory ([T] floor positions in skeleton
// units and headings; normally control_trajectory's): what encode writes as pose, for callers
// that hold the trajectory themselves (the real-time generator, whose root comes from the
// control). Throws mosyn::Error when the motion, skeleton, layout and trajectory disagree.
void encode_pose_against(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout,
                         const GroundTrajectory& trajectory, std::vector<float>* pose);

// Decodes features back to a motion on the skeleton, integrating the control from the given
// start position (skeleton units, up coordinate ignored) and heading. For kPositions this fits
// joint rotations by inverse kinematics.
// Inverse kinematics (kPositions), top-down from joint 0 in world space, given the parent's
// already-fitted world rotation:
//   - a joint whose children (followed through zero-length bones such as CMU's LHipJoint) give
//     two or more non-parallel directions: best-fit rotation of the rest child offsets onto the
//     target child vectors (Kabsch / SVD); the root this way also recovers the heading;
//   - a joint with one direction: the minimal rotation taking the rest bone direction onto the
//     target direction. Twist about such a bone is not recoverable from positions, so it is 0;
//   - a joint with no non-zero bone (a leaf, an end site of length 0): identity.
// Marker fit (kMarkers): frame 0 starts from the canonical pose placed at the waist markers
// (core/markers.h initialise_from_markers), every later frame from the previous frame's fit;
// fit_markers (50 iterations) with a pose prior of 1e-7 that only holds what the markers do not
// see. Close for markers of a motion on the same skeleton (the fit's tolerance, float32 features).
// Bone lengths always come from the skeleton, not from the features; joints above the
// trajectory joint (a static root) keep identity rotations. Results are world-position exact
// (up to float32 rounding) for features of a motion on the same skeleton.
// Throws mosyn::Error when the layout does not fit the skeleton. pose and control hold
// num_frames rows of layout.pose_dim and layout.control_dim floats.
Motion decode(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose, const float* control,
              int num_frames, double fps, const Eigen::Vector3d& start_position = Eigen::Vector3d::Zero(),
              double start_heading_rad = 0.0);

}  // namespace mosyn::data
