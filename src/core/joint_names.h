// Body parts from joint names, for retargeting between skeletons that name their joints by
// different conventions: Mixamo ("mixamorig:LeftUpLeg"), the Unreal mannequin ("thigh_l",
// "calf_l", "ball_l"), CMU ("LeftUpLeg", "LHipJoint"), Bandai-Namco ("UpperLeg_L", "Toes_L"),
// Blender's rigs ("thigh.L", "DEF-shin.L", "upper_arm.L"), and the like.
//
// A name is split into words (at '_', '.', ':', '-', spaces, digits and camelCase), side words
// ("l", "left", "r", "right", as prefix or suffix) are taken out, and the remaining words, joined,
// name the part ("upleg", "thigh" and "upperleg" are all kBodyThigh). Twist, roll, end and finger
// joints are never parts. Spine and neck joints form chains (hips to neck, neck to head) that are
// matched by their position along the chain, not by name, because rigs have one to five of them.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

enum class BodyPart {
  kNone,
  kHips,
  kSpine,  // any joint of the spine chain (spine, chest, lower back, ...)
  kNeck,   // any joint of the neck chain
  kHead,
  kShoulder,  // clavicle
  kUpperArm,
  kForearm,
  kHand,
  kThigh,
  kShin,
  kFoot,  // ankle
  kToe,
};

enum class BodySide { kCentre, kLeft, kRight };

struct JointPart {
  BodyPart part = BodyPart::kNone;
  BodySide side = BodySide::kCentre;
};

// The body part a joint name stands for (kNone when it names none of the parts above).
JointPart classify_joint_name(const std::string& name);

// "left thigh", "hips", "spine": a part as words, for error messages.
std::string describe(const JointPart& part);

// Which source joint drives each target joint: [J_target] source joint index, -1 where the
// target joint keeps its rest rotation. Parts are matched by name (classify_joint_name), spine
// and neck chains by position along the chain; `explicit_map` (target joint name -> source joint
// name) is applied first and wins over names. Throws mosyn::Error naming the joints when an
// explicit name is not in its skeleton, or when the hips, a thigh, shin or foot, an upper arm or
// forearm, or the spine of the target finds no source joint: the parts the source lacks and its
// joints not recognised, else the parts the target lacks and its joints that could not be placed.
std::vector<int> match_joints(const Skeleton& source, const Skeleton& target,
                              const std::map<std::string, std::string>& explicit_map = {});

}  // namespace mosyn
