// Retargeting with known answers: onto the same rig (the input back), a scaled rig (scaled path,
// same local rotations), rigs that differ only by rest pose (A-pose, Maya-style joint orients:
// same world bone directions), other names and proportions (planted feet), round trips, and
// rigs that cannot be mapped.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/foot_lock.h"
#include "core/joint_names.h"
#include "core/kinematics.h"
#include "core/retarget.h"
#include "core/rotation.h"
#include "core/synthetic.h"

namespace mosyn {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

Motion walk(const Skeleton& s, int frames = 90) {
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.3;
  o.noise_rad = 0.02;
  o.seed = 3;
  return make_synthetic_walk(s, frames, 30.0, o);
}

// Mixamo's names for the synthetic biped's joints, in its order.
const std::vector<std::string> kMixamoNames = {
    "mixamorig:Hips",         "mixamorig:Spine",        "mixamorig:Spine1",      "mixamorig:Neck",
    "mixamorig:Head",         "mixamorig:LeftShoulder", "mixamorig:LeftArm",     "mixamorig:LeftForeArm",
    "mixamorig:LeftHand",     "mixamorig:RightShoulder", "mixamorig:RightArm",   "mixamorig:RightForeArm",
    "mixamorig:RightHand",    "mixamorig:LeftUpLeg",    "mixamorig:LeftLeg",     "mixamorig:LeftFoot",
    "mixamorig:LeftToeBase",  "mixamorig:RightUpLeg",   "mixamorig:RightLeg",    "mixamorig:RightFoot",
    "mixamorig:RightToeBase"};

// World direction of the bone from joint a to joint b at frame t.
Vector3d bone(const WorldPoses& w, int t, int a, int b) { return (w.position(t, b) - w.position(t, a)).normalized(); }

// The biped's limb and spine bones (joint, child) that must keep their world direction.
const std::vector<std::pair<int, int>> kBones = {{1, 2},   {2, 3},   {3, 4},   {6, 7},   {7, 8},  {10, 11},
                                                 {11, 12}, {13, 14}, {14, 15}, {17, 18}, {18, 19}, {15, 16}};

double max_bone_angle(const WorldPoses& a, const WorldPoses& b, size_t num_bones = kBones.size()) {
  double worst = 0;
  for (int t = 0; t < a.num_frames; ++t)
    for (size_t i = 0; i < num_bones; ++i)
      for (const auto& [j, k] : {kBones[i]})
      worst = std::max(worst, std::acos(std::clamp(bone(a, t, j, k).dot(bone(b, t, j, k)), -1.0, 1.0)));
  return worst;
}

TEST(Retarget, SameRigGivesTheInputBack) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = walk(s);
  RetargetReport report;
  RetargetOptions options;
  options.plant_feet = false;  // planting pins the input's own gliding contacts (below)
  const Motion out = retarget(s, m, RetargetRig{s, {}, {}, {}}, options, &report);
  EXPECT_NEAR(report.scale, 1.0, 1e-12);
  EXPECT_TRUE(report.input_rest_reference);
  EXPECT_EQ(report.pairs.size(), 21u);
  ASSERT_EQ(out.num_frames, m.num_frames);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      EXPECT_LT(geodesic_angle(out.rotation(t, j), m.rotation(t, j)), 1e-6) << "frame " << t << " joint " << j;
      EXPECT_LT((out.translation(t, j) - m.translation(t, j)).norm(), 1e-6);
    }
}

// With planting, the same rig pins the input's own (gliding) contacts: only the legs change.
TEST(Retarget, PlantingOnTheSameRigTouchesOnlyTheLegs) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = walk(s);
  RetargetReport report;
  const Motion out = retarget(s, m, RetargetRig{s, {}, {}, {}}, {}, &report);
  EXPECT_GT(report.contacts, 0);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      const bool leg = j >= 13;
      EXPECT_LT(geodesic_angle(out.rotation(t, j), m.rotation(t, j)), leg ? 0.3 : 1e-6) << "frame " << t << " joint " << j;
    }
}

TEST(Retarget, ScaledRigScalesThePathAndKeepsLocalRotations) {
  const Skeleton s = make_synthetic_biped();
  Skeleton big = s;
  for (auto& o : big.offsets) o *= 1.5;
  const Motion m = walk(s);
  RetargetReport report;
  RetargetOptions options;
  options.plant_feet = false;
  const Motion out = retarget(s, m, RetargetRig{big, {}, {}, {}}, options, &report);
  EXPECT_NEAR(report.scale, 1.5, 1e-12);
  for (int t = 0; t < m.num_frames; ++t) {
    EXPECT_LT((out.translation(t, 0) - 1.5 * m.translation(t, 0)).norm(), 1e-6);
    for (int j = 0; j < s.num_joints(); ++j) EXPECT_LT(geodesic_angle(out.rotation(t, j), m.rotation(t, j)), 1e-6);
  }
}

// The biped with Mixamo names and arms hanging 45 degrees down in its rest pose (an A-pose).
Skeleton a_pose_mixamo() {
  Skeleton s = make_synthetic_biped();
  s.joint_names = kMixamoNames;
  for (int j : {7, 8, 11, 12}) {  // the upper arm and forearm bones; the clavicles stay
    const double sign = s.offsets[j].x() > 0 ? -1.0 : 1.0;
    s.offsets[j] = Eigen::AngleAxisd(sign * M_PI / 4, Vector3d::UnitZ()) * s.offsets[j];
  }
  for (auto& e : s.end_sites) e.offset = Vector3d(0, 0, 0);
  return s;
}

TEST(Retarget, APoseRigWithOtherNamesKeepsWorldBoneDirections) {
  const Skeleton s = make_synthetic_biped();
  const Skeleton rig = a_pose_mixamo();
  const Motion m = walk(s);
  RetargetOptions options;
  options.plant_feet = false;  // same proportions: the directions alone decide
  const Motion out = retarget(s, m, RetargetRig{rig, {}, {}, {}}, options);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(rig, out);
  EXPECT_LT(max_bone_angle(a, b), 1e-6);
  for (int t = 0; t < m.num_frames; ++t) EXPECT_LT((a.position(t, 0) - b.position(t, 0)).norm(), 1e-6);
  // The upper arms' local rotations differ from the input's by the rest pose's 45 degrees.
  for (int t = 0; t < m.num_frames; ++t) EXPECT_NEAR(geodesic_angle(out.rotation(t, 6), m.rotation(t, 6)), M_PI / 4, 1e-6);
}

// The biped re-expressed Maya-style: every joint's frame has its x axis along its bone, so the
// rest pose (identity rotations) is a stick along x; frame 0 of the rig's file stands in a T-pose.
RetargetRig maya_style_rig(std::vector<Quaterniond>* orients_out = nullptr) {
  const Skeleton s = make_synthetic_biped();
  const Motion rest = Motion::rest(s, 1, 30.0);
  const WorldPoses w = forward_kinematics(s, rest);
  std::vector<Quaterniond> orient(s.num_joints());
  for (int j = 0; j < s.num_joints(); ++j) {
    const std::vector<int> children = s.children(j);
    const int toward = children.empty() ? -1 : children[0];
    Vector3d along = toward >= 0 ? Vector3d(w.position(0, toward) - w.position(0, j)) : Vector3d(s.offsets[j]);
    if (j == 0) along = w.position(0, 1) - w.position(0, 0);
    orient[j] = Quaterniond::FromTwoVectors(Vector3d::UnitX(), along.normalized());
  }
  RetargetRig rig;
  rig.skeleton = s;
  rig.skeleton.joint_names[2] = "spine_03";  // other names as well (Unreal)
  rig.frames = Motion::rest(s, 1, 30.0);
  for (int j = 0; j < s.num_joints(); ++j) {
    const int p = s.parents[j];
    const Quaterniond parent = p < 0 ? Quaterniond::Identity() : orient[p];
    rig.skeleton.offsets[j] = parent.conjugate() * s.offsets[j];
    rig.frames.rotation(0, j) = parent.conjugate() * orient[j];
    rig.frames.translation(0, j) = rig.skeleton.offsets[j];
  }
  for (auto& e : rig.skeleton.end_sites) e.offset = orient[e.parent].conjugate() * e.offset;
  if (orients_out) *orients_out = orient;
  return rig;
}

TEST(Retarget, MayaStyleRigAlignsByItsFirstFrame) {
  const Skeleton s = make_synthetic_biped();
  const RetargetRig rig = maya_style_rig();
  const Motion m = walk(s);
  RetargetOptions options;
  options.plant_feet = false;
  RetargetReport report;
  const Motion out = retarget(s, m, rig, options, &report);
  EXPECT_FALSE(report.rig_rest_reference);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(rig.skeleton, out);
  EXPECT_LT(max_bone_angle(a, b), 1e-6);
  for (int t = 0; t < m.num_frames; ++t) EXPECT_LT((a.position(t, 15) - b.position(t, 15)).norm(), 1e-6);
}

TEST(Retarget, RestRotationsOfGltfStyleRigsAreHonoured) {
  // The same Maya-style skeleton, its orients as rest rotations (as a glTF rig holds them).
  std::vector<Quaterniond> orient;
  RetargetRig rig = maya_style_rig(&orient);
  rig.rest_rotations = rig.frames.rotations;
  rig.frames = Motion{};
  const Skeleton s = make_synthetic_biped();
  const Motion m = walk(s);
  RetargetOptions options;
  options.plant_feet = false;
  RetargetReport report;
  const Motion out = retarget(s, m, rig, options, &report);
  EXPECT_TRUE(report.rig_rest_reference);
  EXPECT_LT(max_bone_angle(forward_kinematics(s, m), forward_kinematics(rig.skeleton, out)), 1e-6);
}

// Other proportions: longer shins, shorter thighs, wider hips, a longer spine.
Skeleton other_proportions() {
  Skeleton s = make_synthetic_biped();
  for (int k : {13, 17}) s.offsets[k].x() *= 1.6;
  for (int k : {14, 18}) s.offsets[k] *= 0.85;
  for (int k : {15, 19}) s.offsets[k] *= 1.25;
  s.offsets[2] *= 1.4;
  return s;
}

TEST(Retarget, FeetStayPlantedOnRigsOfOtherProportions) {
  const Skeleton s = make_synthetic_biped();
  const Skeleton rig = other_proportions();
  const Motion m = walk(s, 120);
  RetargetOptions options;
  options.contacts.contact_height_m = 0.06;  // the synthetic walk's stance feet glide a little
  options.contacts.contact_speed_mps = 1.0;
  RetargetReport report;
  const Motion out = retarget(s, m, RetargetRig{rig, {}, {}, {}}, options, &report);
  const double leg_s = 42 + 43, leg_r = 42 * 0.85 + 43 * 1.25;
  EXPECT_NEAR(report.scale, leg_r / leg_s, 1e-9);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(rig, out);
  // Within the input's toe contacts the rig's toe stays put horizontally: exactly where the leg
  // reaches, within 1 cm where the wider hips leave the straight leg short.
  Skeleton metres = s;
  int checked = 0, contacts = 0, exact = 0;
  for (int ankle : {15, 19}) contacts += static_cast<int>(find_contacts(metres, a, ankle, options.contacts, m.fps).size());
  for (int toe : {16, 20})
    for (const auto& [begin, end] : find_contacts(metres, a, toe, options.contacts, m.fps))
      for (int t = begin + 1; t < end; ++t, ++checked) {
        Vector3d moved = b.position(t, toe) - b.position(t - 1, toe);
        moved.y() = 0;
        EXPECT_LT(moved.norm(), 1.0) << "frame " << t;
        exact += moved.norm() < 1e-6;
      }
  EXPECT_EQ(report.contacts, contacts);
  EXPECT_GE(contacts, 4);
  EXPECT_GT(checked, 20);
  EXPECT_GT(exact, checked / 2);
  // The hip sockets' path scaled by the leg-length ratio, raised by the difference of the ankles'
  // heights above the toes.
  EXPECT_NEAR(report.lift, 6 - report.scale * 6, 1e-9);  // toes 6 cm below the ankles in both rest poses
  // (and by the constant that levels the feet onto the input's floor, scaled).
  auto sockets_offset = [&](int t) {
    return Vector3d(0.5 * (b.position(t, 13) + b.position(t, 17)) - report.scale * 0.5 * (a.position(t, 13) + a.position(t, 17)));
  };
  const Vector3d level = sockets_offset(0);
  EXPECT_LT(std::hypot(level.x(), level.z()), 1e-6);
  EXPECT_LT(std::abs(level.y() - report.lift), 1.0);
  for (int t = 0; t < m.num_frames; ++t) EXPECT_LT((sockets_offset(t) - level).norm(), 1e-6);
}

TEST(Retarget, RoundTripThroughOtherRigsGivesTheInputBack) {
  const Skeleton s = make_synthetic_biped();
  const Skeleton mixamo = a_pose_mixamo(), other = other_proportions();
  const Motion m = walk(s);
  RetargetOptions options;
  options.plant_feet = false;
  const Motion onto_mixamo = retarget(s, m, RetargetRig{mixamo, {}, {}, {}}, options);
  const Motion onto_other = retarget(mixamo, onto_mixamo, RetargetRig{other, {}, {}, {}}, options);
  const Motion back = retarget(other, onto_other, RetargetRig{s, {}, {}, {}}, options);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      EXPECT_LT(geodesic_angle(back.rotation(t, j), m.rotation(t, j)), 1e-6) << "frame " << t << " joint " << j;
      EXPECT_LT((back.translation(t, j) - m.translation(t, j)).norm(), 1e-6);
    }
}

// Through a rig without a standing rest pose, the input's walking first frame is the reference
// of the second step: limb and spine directions still come back exactly; a limb's twist about its
// own axis only as closely as the two reference poses agree (up to 16 degrees for the synthetic
// walk, whose feet are never flat at once), and the feet, which turn as from flat, not at all.
TEST(Retarget, RoundTripThroughMayaStyleRigKeepsBoneDirections) {
  const Skeleton s = make_synthetic_biped();
  const RetargetRig maya = maya_style_rig();
  const Motion m = walk(s);
  RetargetOptions options;
  options.plant_feet = false;
  const Motion there = retarget(s, m, maya, options);
  RetargetReport report;
  const Motion back = retarget(maya.skeleton, there, RetargetRig{s, {}, {}, {}}, options, &report);
  EXPECT_FALSE(report.input_rest_reference);
  EXPECT_LT(max_bone_angle(forward_kinematics(s, m), forward_kinematics(s, back), kBones.size() - 1), 1e-6);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j)
      if (j != 15 && j != 16 && j != 19 && j != 20) {
        EXPECT_LT(geodesic_angle(back.rotation(t, j), m.rotation(t, j)), 0.35);
      }
}

// Frame by frame (as a generator streams), the same frames as the whole take without planting,
// with the input aligned by a standing frame given up front.
TEST(Retarget, StreamingGivesTheTakesFrames) {
  const RetargetRig maya = maya_style_rig();
  const Skeleton mixamo = a_pose_mixamo();
  const Motion m = retarget(make_synthetic_biped(), walk(make_synthetic_biped()), maya);  // input: rest along x
  RetargetOptions options;
  options.plant_feet = false;
  const Motion whole = retarget(maya.skeleton, m, RetargetRig{mixamo, {}, {}, {}}, options);
  const StreamingRetarget stream(maya.skeleton, m, RetargetRig{mixamo, {}, {}, {}}, options);
  EXPECT_EQ(stream.rig_skeleton().joint_names, mixamo.joint_names);
  for (int t = 0; t < m.num_frames; ++t) {
    Motion frame = Motion::rest(maya.skeleton, 1, m.fps);
    for (int j = 0; j < m.num_joints; ++j) {
      frame.rotation(0, j) = m.rotation(t, j);
      frame.translation(0, j) = m.translation(t, j);
    }
    const Motion out = stream.apply(frame);
    for (int j = 0; j < mixamo.num_joints(); ++j) {
      EXPECT_LT(geodesic_angle(out.rotation(0, j), whole.rotation(t, j)), 1e-9);
      EXPECT_LT((out.translation(0, j) - whole.translation(t, j)).norm(), 1e-9);
    }
  }
  EXPECT_THROW(stream.apply(m), Error);  // many frames at once
}

TEST(Retarget, UnmappableRigNamesTheJointsItCannotPlace) {
  const Skeleton s = make_synthetic_biped();
  Skeleton rig = s;
  rig.joint_names[13] = "Bone13";
  rig.joint_names[14] = "Bone14";
  try {
    retarget(s, walk(s, 10), RetargetRig{rig, {}, {}, {}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("left thigh"), std::string::npos) << what;
    EXPECT_NE(what.find("Bone13"), std::string::npos) << what;
    EXPECT_NE(what.find("Bone14"), std::string::npos) << what;
    EXPECT_NE(what.find("--map"), std::string::npos) << what;
  }
  // The explicit map places them.
  RetargetOptions options;
  options.joint_map = {{"Bone13", "UpperLeg_L"}, {"Bone14", "LowerLeg_L"}};
  const Motion m = walk(s, 10);
  const Motion out = retarget(s, m, RetargetRig{rig, {}, {}, {}}, options);
  EXPECT_LT(geodesic_angle(out.rotation(5, 13), m.rotation(5, 13)), 1e-6);
  // An input with its own names, paired by the map with a rig named by convention.
  Skeleton custom_source = s;
  custom_source.joint_names[13] = "thingA";
  custom_source.joint_names[14] = "thingB";
  options.joint_map = {{"UpperLeg_L", "thingA"}, {"LowerLeg_L", "thingB"}};
  const Motion custom = retarget(custom_source, m, RetargetRig{s, {}, {}, {}}, options);
  EXPECT_LT(geodesic_angle(custom.rotation(5, 14), m.rotation(5, 14)), 1e-6);
  // Neither side's name says what the joints are: an error naming them.
  options.joint_map = {{"Bone13", "thingA"}, {"Bone14", "thingB"}};
  EXPECT_THROW(retarget(custom_source, m, RetargetRig{rig, {}, {}, {}}, options), Error);
  options.joint_map = {{"Bone13", "NoSuchJoint"}};
  EXPECT_THROW(retarget(s, m, RetargetRig{rig, {}, {}, {}}, options), Error);
}

TEST(Retarget, RejectsBadInput) {
  const Skeleton s = make_synthetic_biped();
  Motion m = walk(s, 10);
  m.rotation(3, 4).w() = std::nan("");
  EXPECT_THROW(retarget(s, m, RetargetRig{s, {}, {}, {}}), Error);
  RetargetRig rig{s, {Quaterniond::Identity()}, {}, {}};
  EXPECT_THROW(retarget(s, walk(s, 10), rig), Error);  // rest rotations of the wrong size
  // A rig lying down in its rest pose with no frame to stand in.
  RetargetRig lying{s, std::vector<Quaterniond>(21, Quaterniond::Identity()), {}, {}};
  lying.rest_rotations[0] = Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()));
  EXPECT_THROW(retarget(s, walk(s, 10), lying), Error);
}

TEST(JointNames, CommonConventions) {
  auto is = [](const std::string& name, BodyPart part, BodySide side) {
    const JointPart p = classify_joint_name(name);
    return p.part == part && p.side == side;
  };
  EXPECT_TRUE(is("mixamorig:LeftUpLeg", BodyPart::kThigh, BodySide::kLeft));
  EXPECT_TRUE(is("thigh_r", BodyPart::kThigh, BodySide::kRight));
  EXPECT_TRUE(is("calf_l", BodyPart::kShin, BodySide::kLeft));
  EXPECT_TRUE(is("ball_l", BodyPart::kToe, BodySide::kLeft));
  EXPECT_TRUE(is("DEF-shin.L", BodyPart::kShin, BodySide::kLeft));
  EXPECT_TRUE(is("upper_arm.R", BodyPart::kUpperArm, BodySide::kRight));
  EXPECT_TRUE(is("LeftForeArm", BodyPart::kForearm, BodySide::kLeft));
  EXPECT_TRUE(is("UpperLeg_L", BodyPart::kThigh, BodySide::kLeft));
  EXPECT_TRUE(is("LowerArm_R", BodyPart::kForearm, BodySide::kRight));
  EXPECT_TRUE(is("Toes_L", BodyPart::kToe, BodySide::kLeft));
  EXPECT_TRUE(is("clavicle_l", BodyPart::kShoulder, BodySide::kLeft));
  EXPECT_TRUE(is("Bip01 R Thigh", BodyPart::kThigh, BodySide::kRight));
  EXPECT_TRUE(is("spine_02", BodyPart::kSpine, BodySide::kCentre));
  EXPECT_TRUE(is("LowerBack", BodyPart::kSpine, BodySide::kCentre));
  EXPECT_TRUE(is("pelvis", BodyPart::kHips, BodySide::kCentre));
  EXPECT_TRUE(is("Neck1", BodyPart::kNeck, BodySide::kCentre));
  EXPECT_TRUE(is("LHipJoint", BodyPart::kNone, BodySide::kCentre));
  EXPECT_TRUE(is("LThumb", BodyPart::kNone, BodySide::kCentre));
  EXPECT_TRUE(is("upperarm_twist_01_l", BodyPart::kNone, BodySide::kCentre));
  EXPECT_TRUE(is("mixamorig:LeftToe_End", BodyPart::kNone, BodySide::kCentre));
  EXPECT_TRUE(is("joint_Root", BodyPart::kNone, BodySide::kCentre));
}

}  // namespace
}  // namespace mosyn
