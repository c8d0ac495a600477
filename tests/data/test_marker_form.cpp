// The marker pose form (PoseForm::kMarkers): layout, encoding against hand-placed markers, and
// decoding back to a motion through the marker fit.
#include <gtest/gtest.h>

#include <cmath>

#include "core/kinematics.h"
#include "core/markers.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "core/units.h"
#include "data/representation.h"

namespace mosyn::data {
namespace {

TEST(MarkerForm, LayoutDimsAndNames) {
  const Skeleton s = make_synthetic_biped();
  const FeatureLayout layout = make_layout(s, PoseForm::kMarkers, 0, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(layout.pose_dim, 123);
  EXPECT_EQ(layout.pose_names[0], "C7.x_m");
  EXPECT_EQ(layout.pose_names[122], "T10.z_m");
  EXPECT_EQ(parse_pose_form("markers"), PoseForm::kMarkers);
  EXPECT_EQ(expected_pose_dim(PoseForm::kMarkers, 5, false), 123);
}

TEST(MarkerForm, EncodesMarkersInTheHeadingFrame) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 20, 30.0);
  const FeatureLayout layout = make_layout(s, PoseForm::kMarkers, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  encode(s, m, layout, &pose, &control);
  const MarkerSet set = cmu41_markers(s);
  const auto world = marker_positions(s, set, m);
  const GroundTrajectory g = control_trajectory(s, m, layout);
  for (int t = 0; t < m.num_frames; t += 7)
    for (int i = 0; i < set.num_markers(); ++i) {
      const Eigen::Vector3d expect =
          heading_rotation(s, g.headings_rad[t]).conjugate() * (world[static_cast<size_t>(t) * 41 + i] - g.positions[t]) * 0.01;
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(pose[static_cast<size_t>(t) * 123 + 3 * i + k], expect[k], 1e-5);
    }
}

TEST(MarkerForm, RoundTripGivesTheJointPositionsBack) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 40, 30.0);
  const FeatureLayout layout = make_layout(s, PoseForm::kMarkers, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  encode(s, m, layout, &pose, &control);
  const GroundTrajectory g = ground_trajectory(s, m, 0, layout.forward_in_root);
  const Motion back = decode(s, layout, pose.data(), control.data(), m.num_frames, m.fps, g.positions[0], g.headings_rad[0]);
  EXPECT_NO_THROW(back.validate());
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(s, back);
  double worst = 0;
  for (size_t i = 0; i < a.positions.size(); ++i) worst = std::max(worst, (a.positions[i] - b.positions[i]).norm());
  EXPECT_LT(worst * s.meters_per_unit, 2e-3);  // metres: float32 features, the fit's tolerance
}

}  // namespace
}  // namespace mosyn::data
