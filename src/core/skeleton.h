// Skeleton: the immutable joint hierarchy of a character, and Motion: its animated state.
//
// Conventions used throughout mosyn:
// - Joints are stored in depth-first order: parents[j] < j for every non-root joint, and the
//   single root has parent -1.
// - Lengths are in the skeleton's own units (BVH units); meters_per_unit converts to metres.
// - The up axis is +Y unless up_axis says otherwise (0 = X, 1 = Y, 2 = Z).
// - Rotations are unit quaternions (w, x, y, z), Eigen::Quaterniond; a joint's local rotation
//   maps vectors in the joint's frame to its parent's frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace mosyn {

// A BVH "End Site": a leaf point attached to a joint, kept so files round-trip and so that
// the tips of hands, feet and head can be placed.
struct EndSite {
  int parent = -1;             // joint index
  Eigen::Vector3d offset{0, 0, 0};  // in skeleton units, in the parent's frame
};

struct Skeleton {
  std::vector<std::string> joint_names;
  std::vector<int> parents;               // [J], -1 for the root, parents[j] < j
  std::vector<Eigen::Vector3d> offsets;   // [J] rest translation from the parent, skeleton units
  std::vector<EndSite> end_sites;         // any number, in file order
  double meters_per_unit = 1.0;           // e.g. 0.01 for centimetres
  int up_axis = 1;                        // 0 = X, 1 = Y, 2 = Z

  int num_joints() const { return static_cast<int>(joint_names.size()); }

  // Index of the joint with this exact name, or -1.
  int find(const std::string& name) const;

  // Direct children of joint j, in index order.
  std::vector<int> children(int j) const;

  // Throws mosyn::Error when the arrays disagree in size, a parent index is not smaller than
  // its child, there is not exactly one root, or names repeat.
  void validate() const;
};

// The animated state of a skeleton over time: local rotation and translation of every joint
// at every frame. Arrays are row-major [T, J] (index t * num_joints + j).
struct Motion {
  double fps = 30.0;
  int num_frames = 0;
  int num_joints = 0;
  // [T, J] local rotations relative to the parent, unit quaternions (w, x, y, z).
  std::vector<Eigen::Quaterniond> rotations;
  // [T, J] local translations relative to the parent, skeleton units. Equal to the rest offset
  // for joints without animated position channels; the root's is its position in the world.
  std::vector<Eigen::Vector3d> translations;

  // A motion of num_frames frames in the rest pose: identity rotations, rest offsets.
  static Motion rest(const Skeleton& skeleton, int num_frames, double fps);

  Eigen::Quaterniond& rotation(int t, int j) { return rotations[static_cast<size_t>(t) * num_joints + j]; }
  const Eigen::Quaterniond& rotation(int t, int j) const { return rotations[static_cast<size_t>(t) * num_joints + j]; }
  Eigen::Vector3d& translation(int t, int j) { return translations[static_cast<size_t>(t) * num_joints + j]; }
  const Eigen::Vector3d& translation(int t, int j) const { return translations[static_cast<size_t>(t) * num_joints + j]; }

  double duration_s() const { return num_frames > 0 ? (num_frames - 1) / fps : 0.0; }

  // Throws mosyn::Error when the arrays do not have num_frames * num_joints entries, fps is not
  // positive, or a value is not finite.
  void validate() const;
};

// A skeleton together with one motion of it.
struct Clip {
  Skeleton skeleton;
  Motion motion;
};

}  // namespace mosyn
