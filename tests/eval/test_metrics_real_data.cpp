// Metrics on real motion capture (skipped when the shared archives are not unpacked): the feet are
// found by name, bones come out exact after collapsing placeholder roots, and a natural walk has
// the footstep profile of a walk.
#include <gtest/gtest.h>

#include <fstream>

#include "metrics/metrics.h"
#include "io/bvh.h"

namespace mosyn::eval {
namespace {

std::string data_file(const std::string& relative) {
  const std::string path = std::string(MOSYN_DATA_CACHE) + "/" + relative;
  return std::ifstream(path).good() ? path : std::string();
}

MotionPositions load(const std::string& path) { return motion_positions(io::to_clip(io::read_bvh(path)), 0.0, path); }

TEST(MetricsRealDataTest, BandaiNamcoWalk) {
  const std::string path =
      data_file("bandai-namco/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk_normal_001.bvh");
  if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
  const MotionPositions m = load(path);
  EXPECT_EQ(m.joint_names[0], "Hips");  // joint_Root collapsed
  const FootJoints f = find_foot_joints(m);
  EXPECT_EQ(m.joint_names[f.left_heel], "Foot_L");
  EXPECT_EQ(m.joint_names[f.right_toe], "Toes_R");
  EXPECT_LT(bone_length_rmse_m(m), 1e-6);
  // 6.5 s of walking at about two steps per second: 13 contacts, found crisply (natural motion).
  const FootstepAnalysis a = analyse_footsteps({m}, {f});
  EXPECT_GE(a.max_steps, 10);
  EXPECT_LE(a.max_steps, 16);
  EXPECT_LE(a.v_tol95_mps, 0.15);
  EXPECT_GT(a.step_duration_mean_s, 0.15);
  EXPECT_LT(a.step_duration_mean_s, 0.8);
  // The independent check's toe sliding: about a tenth of a real walk's frames (a toe rolling off
  // at push-off); the same walk dragged along at 0.3 m/s slides on most of them.
  const double toes = toe_slide_ratio(m, f);
  EXPECT_GT(toes, 0.02);
  EXPECT_LT(toes, 0.2);
  MotionPositions dragged = m;
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < m.num_joints; ++j)
      dragged.positions_m[static_cast<size_t>(t) * m.num_joints + j].x() += 0.3 * t / m.fps;
  EXPECT_GT(toe_slide_ratio(dragged, f), 0.6);
}

TEST(MetricsRealDataTest, CmuWalk) {
  const std::string path = data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  if (path.empty()) GTEST_SKIP() << "CMU data not unpacked";
  const MotionPositions m = load(path);
  const FootJoints f = find_foot_joints(m);
  EXPECT_EQ(m.joint_names[f.left_heel], "LeftFoot");
  EXPECT_EQ(m.joint_names[f.right_toe], "RightToeBase");
  // CMU units guessed: the hips stand about a metre high.
  double hips_y = 0;
  for (int t = 0; t < m.num_frames; ++t) hips_y += m.position(t, 0).y() / m.num_frames;
  EXPECT_GT(hips_y, 0.7);
  EXPECT_LT(hips_y, 1.2);
  const FootstepAnalysis a = analyse_footsteps({m}, {f});
  EXPECT_GE(a.max_steps, 4);
  EXPECT_LE(a.max_steps, 9);
  EXPECT_LT(foot_skating_ratio(m, f), 0.1);
}

}  // namespace
}  // namespace mosyn::eval
