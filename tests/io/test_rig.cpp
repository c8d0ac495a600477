// Rigs from BVH and glTF files (io/rig.h): node hierarchies and rest transforms read exactly,
// motions written back on the rig, and retargeting between the shared data's two skeletons
// (Bandai-Namco <-> CMU) with bone directions, path and feet checked.
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"
#include "io/atomic_file.h"
#include "io/gltf.h"
#include "io/rig.h"
#include "io_test_util.h"

namespace mosyn::io {
namespace {

namespace fs = std::filesystem;
using Eigen::Quaterniond;
using Eigen::Vector3d;

TEST(Rig, GltfWrittenByMosynReadsBackAsItsSkeleton) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 20, 30.0);
  const RetargetRig rig = parse_gltf_rig(gltf_bytes(s, {{"walk", m}}, true), true, "walk.glb");
  ASSERT_EQ(rig.skeleton.joint_names, s.joint_names);
  ASSERT_EQ(rig.skeleton.parents, s.parents);
  // The nodes hold the first frame: its local rotations are the rest rotations, metres.
  for (int j = 0; j < s.num_joints(); ++j) {
    const Vector3d expected = 0.01 * (j == 0 ? m.translation(0, 0) : s.offsets[j]);
    EXPECT_LT((rig.skeleton.offsets[j] - expected).norm(), 1e-6) << s.joint_names[j];
    EXPECT_LT(std::abs(rig.rest_rotations[j].dot(m.rotation(0, j))), 1.0 + 1e-9);
    EXPECT_GT(std::abs(rig.rest_rotations[j].dot(m.rotation(0, j))), 1.0 - 1e-6) << s.joint_names[j];
  }
}

// A glTF rig as DCC tools export them: an "Armature" node (turned and scaled to centimetres) above
// the root joint, every joint oriented with its x axis along its bone (Maya-style joint orients).
std::string maya_style_glb(const Skeleton& s, const Quaterniond& armature_turn, double armature_scale) {
  const WorldPoses w = forward_kinematics(s, Motion::rest(s, 1, 30.0));
  std::vector<Quaterniond> orient(s.num_joints());
  for (int j = 0; j < s.num_joints(); ++j) {
    const std::vector<int> children = s.children(j);
    const Vector3d along = children.empty() ? Vector3d(s.offsets[j]) : Vector3d(w.position(0, children[0]) - w.position(0, j));
    orient[j] = Quaterniond::FromTwoVectors(Vector3d::UnitX(), along.normalized());
  }
  tinygltf::Model model;
  model.asset.version = "2.0";
  tinygltf::Node armature;
  armature.name = "Armature";
  armature.rotation = {armature_turn.x(), armature_turn.y(), armature_turn.z(), armature_turn.w()};
  armature.scale = {armature_scale, armature_scale, armature_scale};
  armature.children = {1};
  model.nodes.push_back(armature);
  tinygltf::Skin skin;
  for (int j = 0; j < s.num_joints(); ++j) {
    const int p = s.parents[j];
    const Quaterniond parent = p < 0 ? Quaterniond::Identity() : orient[p];
    const Quaterniond local = parent.conjugate() * orient[j];
    const Vector3d offset = parent.conjugate() * s.offsets[j] / armature_scale * 0.01;  // cm -> armature units
    tinygltf::Node node;
    node.name = "DEF-" + s.joint_names[j];
    node.rotation = {local.x(), local.y(), local.z(), local.w()};
    node.translation = {offset.x(), offset.y(), offset.z()};
    for (int c : s.children(j)) node.children.push_back(c + 1);
    model.nodes.push_back(node);
    skin.joints.push_back(j + 1);
  }
  model.skins.push_back(skin);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  EXPECT_TRUE(writer.WriteGltfSceneToStream(&model, out, false, true));
  return out.str();
}

TEST(Rig, GltfArmatureTransformAndJointOrientsAreFolded) {
  const Skeleton s = make_synthetic_biped();
  const Quaterniond turn(Eigen::AngleAxisd(0.7, Vector3d::UnitY()));
  const RetargetRig rig = parse_gltf_rig(maya_style_glb(s, turn, 0.01), true, "maya.glb");
  ASSERT_EQ(rig.skeleton.num_joints(), s.num_joints());
  EXPECT_EQ(rig.skeleton.joint_names[15], "DEF-Foot_L");
  // World rest positions: the biped's, in metres, turned by the armature.
  Motion rest = Motion::rest(rig.skeleton, 1, 30.0);
  rest.rotations = rig.rest_rotations;
  const WorldPoses got = forward_kinematics(rig.skeleton, rest);
  const WorldPoses want = forward_kinematics(s, Motion::rest(s, 1, 30.0));
  for (int j = 0; j < s.num_joints(); ++j)
    EXPECT_LT((got.position(0, j) - turn * (0.01 * want.position(0, j))).norm(), 1e-6) << s.joint_names[j];

  // Retargeting the biped's walk onto it: the same world bone directions, turned.
  const Motion m = make_synthetic_walk(s, 40, 30.0);
  RetargetOptions options;
  options.plant_feet = false;
  const Motion out = retarget(s, m, rig, options);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(rig.skeleton, out);
  for (int t = 0; t < m.num_frames; ++t)
    for (const auto& [j, k] : std::vector<std::pair<int, int>>{{13, 14}, {14, 15}, {6, 7}, {7, 8}, {1, 2}}) {
      const Vector3d da = (a.position(t, k) - a.position(t, j)).normalized();
      const Vector3d db = (b.position(t, k) - b.position(t, j)).normalized();
      EXPECT_LT((da - db).norm(), 1e-6) << "frame " << t;
    }
}

TEST(Rig, WritesTheMotionOnTheRigAndReadsErrors) {
  const fs::path dir = testing::make_temp_dir("rig");
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 20, 30.0);
  write_bvh((dir / "rig.bvh").string(), from_clip(Clip{s, Motion::rest(s, 1, 30.0)}));
  const RigFile rig = read_rig((dir / "rig.bvh").string());
  ASSERT_TRUE(rig.bvh.has_value());
  EXPECT_NEAR(rig.meters_per_unit, 0.01, 1e-12);
  for (const std::string ext : {"bvh", "glb"}) {
    const std::string path = (dir / ("out." + ext)).string();
    write_on_rig(path, rig, retarget(s, m, rig.rig), "walk");
    const RigFile back = read_rig(path);
    EXPECT_EQ(back.rig.skeleton.joint_names, s.joint_names) << ext;
    EXPECT_EQ(back.rig.skeleton.parents, s.parents) << ext;
  }
  EXPECT_EQ(read_bvh((dir / "out.bvh").string()).num_frames, 20);
  EXPECT_THROW(read_rig((dir / "rig.fbx").string()), Error);
  write_file_atomically((dir / "bad.glb").string(), "glTF not really");
  try {
    read_rig((dir / "bad.glb").string());
    FAIL() << "expected a ParseError";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.glb"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// --- The shared data: Bandai-Namco (cm, Maya-style rest along x) <-> CMU (T-pose, CMU units) ---

const fs::path kDataCache = MOSYN_DATA_CACHE;

fs::path first_file(const fs::path& dir, const std::string& part) {
  if (!fs::is_directory(dir)) return {};
  std::vector<fs::path> found;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().extension() == ".bvh" && e.path().filename().string().find(part) != std::string::npos)
      found.push_back(e.path());
  std::sort(found.begin(), found.end());
  return found.empty() ? fs::path() : found.front();
}

// (Bandai-Namco joint, CMU joint) at both ends of the thigh, shin, upper arm, forearm and spine.
const std::vector<std::array<std::string, 4>> kLimbs = {
    {"UpperLeg_L", "LowerLeg_L", "LeftUpLeg", "LeftLeg"},   {"LowerLeg_L", "Foot_L", "LeftLeg", "LeftFoot"},
    {"UpperLeg_R", "LowerLeg_R", "RightUpLeg", "RightLeg"}, {"LowerLeg_R", "Foot_R", "RightLeg", "RightFoot"},
    {"UpperArm_L", "LowerArm_L", "LeftArm", "LeftForeArm"}, {"LowerArm_L", "Hand_L", "LeftForeArm", "LeftHand"},
    {"UpperArm_R", "LowerArm_R", "RightArm", "RightForeArm"}, {"LowerArm_R", "Hand_R", "RightForeArm", "RightHand"},
    {"Spine", "Neck", "LowerBack", "Neck"}};

struct LimbAngles {
  double mean_deg = 0;        // over limbs and frames
  double worst_limb_deg = 0;  // the largest of the limbs' means
  double largest_deg = 0;     // the largest in any frame
};

// Angles between the world directions of the limbs in two clips; each clip's joints are named as
// Bandai-Namco's (true) or CMU's.
LimbAngles limb_angles(const Clip& a, bool a_bandai, const Clip& b, bool b_bandai) {
  const WorldPoses wa = forward_kinematics(a.skeleton, a.motion), wb = forward_kinematics(b.skeleton, b.motion);
  LimbAngles out;
  for (const auto& l : kLimbs) {
    const int oa = a_bandai ? 0 : 2, ob = b_bandai ? 0 : 2;
    const int a0 = a.skeleton.find(l[oa]), a1 = a.skeleton.find(l[oa + 1]);
    const int b0 = b.skeleton.find(l[ob]), b1 = b.skeleton.find(l[ob + 1]);
    double sum = 0;
    for (int t = 0; t < a.motion.num_frames; ++t) {
      const Vector3d da = (wa.position(t, a1) - wa.position(t, a0)).normalized();
      const Vector3d db = (wb.position(t, b1) - wb.position(t, b0)).normalized();
      const double angle = std::acos(std::clamp(da.dot(db), -1.0, 1.0)) * 180 / M_PI;
      sum += angle;
      out.largest_deg = std::max(out.largest_deg, angle);
    }
    out.mean_deg += sum / a.motion.num_frames / kLimbs.size();
    out.worst_limb_deg = std::max(out.worst_limb_deg, sum / a.motion.num_frames);
  }
  return out;
}

// What issue 60 asks of held-out takes (mean within 8 degrees, no limb beyond 15), with margin.
void expect_close_limbs(const LimbAngles& l) {
  EXPECT_LT(l.mean_deg, 2.0);
  EXPECT_LT(l.worst_limb_deg, 5.0);
  EXPECT_LT(l.largest_deg, 25.0);
}

TEST(RigRealData, BandaiNamcoAndCmuRetargetEachOther) {
  const fs::path bandai = first_file(kDataCache / "bandai-namco", "dataset-2_walk_normal");
  const fs::path cmu = first_file(kDataCache / "cmu-mocap-subset", "02_01");
  if (bandai.empty() || cmu.empty()) GTEST_SKIP() << "no unpacked data under " << kDataCache;
  const Clip b = to_clip(read_bvh(bandai.string())), c = to_clip(read_bvh(cmu.string()));
  const RigFile cmu_rig = read_rig(cmu.string()), bandai_rig = read_rig(bandai.string());

  RetargetReport report;
  const Clip on_cmu{c.skeleton, retarget(b.skeleton, b.motion, cmu_rig.rig, {}, &report)};
  EXPECT_FALSE(report.input_rest_reference);  // Bandai-Namco's rest lies along x
  EXPECT_GT(report.contacts, 4);
  expect_close_limbs(limb_angles(b, true, on_cmu, false));
  // The hips travel Bandai-Namco's path scaled by the leg-length ratio (cm -> CMU units).
  const WorldPoses wb = forward_kinematics(b.skeleton, b.motion), wc = forward_kinematics(c.skeleton, on_cmu.motion);
  const int hb = b.skeleton.find("Hips"), hc = c.skeleton.find("Hips"), last = b.motion.num_frames - 1;
  Vector3d path_b = wb.position(last, hb) - wb.position(0, hb), path_c = wc.position(last, hc) - wc.position(0, hc);
  path_b.y() = path_c.y() = 0;
  EXPECT_LT((path_c - report.scale * path_b).norm(), 0.03 * report.scale * path_b.norm());

  // And back: the round trip returns Bandai-Namco's limb directions.
  const Clip back{b.skeleton, retarget(c.skeleton, on_cmu.motion, bandai_rig.rig)};
  expect_close_limbs(limb_angles(b, true, back, true));

  // CMU onto Bandai-Namco's rig, aligned by the rig file's first frame.
  const Clip on_bandai{b.skeleton, retarget(c.skeleton, c.motion, bandai_rig.rig, {}, &report)};
  EXPECT_FALSE(report.rig_rest_reference);
  expect_close_limbs(limb_angles(c, false, on_bandai, true));
}

}  // namespace
}  // namespace mosyn::io
