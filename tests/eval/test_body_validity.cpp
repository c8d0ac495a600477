// Body validity on raw predicted features (metrics/metrics.h feature_points_world, the body_validity
// protocol's placement of marker and joint features in the world).
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/markers.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "metrics/metrics.h"

using namespace mosyn;

// Marker features of a synthetic walk placed back in the world by feature_points_world are the
// markers of the walk itself, seen from its trajectory's start (origin, heading 0); rigid parts of
// them do not deform.
TEST(BodyValidity, FeaturePointsWorldRebuildsTheMarkersOfAWalk) {
  const Skeleton s = make_synthetic_biped();
  const Motion walk = make_synthetic_walk(s, 40, 15.0);
  const data::FeatureLayout layout = data::make_layout(s, data::PoseForm::kMarkers, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  data::encode(s, walk, layout, &pose, &control);
  const GroundTrajectory traj = data::control_trajectory(s, walk, layout);
  const MarkerSet set = cmu41_markers(s);
  const auto& names = cmu41_marker_names();
  const eval::MotionPositions m = eval::feature_points_world(pose, control, 123, 5, 40, names, 15.0);
  ASSERT_EQ(m.num_frames, 35);
  ASSERT_EQ(m.num_joints, 41);
  const WorldPoses world = forward_kinematics(s, walk);
  const Eigen::Quaterniond undo = heading_rotation(s, -traj.headings_rad[0]);
  double worst = 0.0;
  for (int t = 5; t < 40; ++t) {
    const auto markers = marker_positions(set, world, t);
    for (int i = 0; i < 41; ++i) {
      const Eigen::Vector3d expected = undo * (markers[i] - traj.positions[0]) * s.meters_per_unit;
      worst = std::max(worst, (m.position(t - 5, i) - expected).norm());
    }
  }
  EXPECT_LT(worst, 1e-4);
  eval::RigidPart head{"head", {}};
  for (const char* name : {"LFHD", "RFHD", "RBHD", "LBHD"}) head.joints.push_back(set.find(name));
  EXPECT_LT(eval::rigid_part_deformation_m(m, head), 1e-5);
  EXPECT_THROW(eval::feature_points_world(pose, control, 123, 5, 41, names, 15.0), Error);
  EXPECT_THROW(eval::feature_points_world(pose, control, 120, 0, 4, names, 15.0), Error);
}
