// The points of a body the foot objectives read (heels, toes, pelvis), in metres, from a model's
// standardised poses in any pose form that gives joint positions (data/representation.h):
//
//   positions  the joints' features: heels = the two ankles of core find_legs, toes = each ankle's
//              first child, pelvis = the layout's root joint;
//   markers    the CMU markers (core/markers.h): heels LHEE / RHEE, toes LTOE / RTOE, pelvis the
//              mean of the four waist markers (LFWT, RFWT, LBWT, RBWT);
//   rotations  differentiable forward kinematics (nn/kinematics.h) of the joints from the root down
//              to the ankles and toes: the root at (its floor offset x, height, floor offset z), or
//              (0, height, 0) on an unsmoothed root path, turned by its 6D relative to the heading;
//              every other joint by its local 6D; joints above the root at rest.
//
// Every form gives the points in each frame's heading frame (x sideways, y up, z forward, relative
// to the root path's floor point), as the positions form holds them, so the objectives' ground
// speeds (nn/kinematics.h joint_ground_speed_mps) read them alike.
#pragma once

#include <torch/types.h>

#include <string>
#include <utility>
#include <vector>

#include "nn/context.h"

namespace mosyn::nn {

class BodyPoints {
 public:
  BodyPoints() = default;
  // From a context with the dataset's skeleton, layout and statistics (a model built by mosyn
  // train or load_run). family names the caller in errors. Throws mosyn::Error when the form or the
  // skeleton cannot give two heels and the pelvis (a Y-up skeleton with exactly two legs), or the
  // statistics are missing.
  BodyPoints(const ModelContext& context, const std::string& family);

  bool valid() const { return num_points_ > 0; }
  // Standardised poses [..., D] -> the points [..., P, 3] in metres: heels (left, right), then the
  // toes (left, right) when has_toes(), then the pelvis. Differentiable.
  torch::Tensor points_m(const torch::Tensor& pose) const;
  int num_points() const { return num_points_; }
  bool has_toes() const { return has_toes_; }
  std::vector<int> heel_points() const { return {0, 1}; }
  std::vector<int> toe_points() const { return has_toes_ ? std::vector<int>{2, 3} : std::vector<int>{}; }
  int pelvis_point() const { return num_points_ - 1; }
  // The skeleton joint of each point (positions and rotations forms; empty for markers).
  const std::vector<int>& point_joints() const { return point_joints_; }

  // Lengths (m) of the body's rigid pairs in standardised poses [..., D] -> [..., N]: every bone
  // of the positions form (parent and child joint, rest length above 1 mm) or every pair of
  // markers carried by the same bone; none in the rotations form (forward kinematics keeps them).
  torch::Tensor pair_lengths_m(const torch::Tensor& pose) const;
  // Their rest lengths [N] (metres, float64 on the CPU), from the skeleton.
  const torch::Tensor& rest_lengths_m() const { return rest_lengths_; }
  int num_pairs() const { return static_cast<int>(pairs_.size()); }

 private:
  // The constructor's work for each form; who starts the errors.
  void init_positions(const ModelContext& context, const std::string& who);
  void init_markers(const ModelContext& context, const std::string& who);
  void init_rotations(const ModelContext& context, const std::string& who);
  // Standardised poses [..., D] -> raw features (metres, radians).
  torch::Tensor raw(const torch::Tensor& pose) const;
  torch::Tensor fk_points_m(const torch::Tensor& raw_pose) const;

  data::PoseForm form_ = data::PoseForm::kPositions;
  int num_points_ = 0;
  bool has_toes_ = false;
  // positions and markers: each point's feature triples (index k: features 3k..3k+2), averaged.
  std::vector<std::vector<int64_t>> point_triples_;
  std::vector<int> point_joints_;
  // rotations: the chain from the root joint to every point's joint, in skeleton order (the root
  // first); its parents (indices into the chain), bone offsets (m) and feature slots.
  std::vector<int> chain_parents_;
  std::vector<int64_t> chain_slots_;  // first feature of each chain joint's 6D
  std::vector<int> point_chain_index_;  // [P] the chain joint of each point
  torch::Tensor chain_offsets_;        // [K, 3] float64, metres
  int64_t height_feature_ = 0, offset_feature_ = -1;  // offset_feature_: x, then z; -1 unsmoothed
  std::vector<std::pair<int64_t, int64_t>> pairs_;  // rigid pairs as feature triples
  torch::Tensor rest_lengths_;
  torch::Tensor pose_mean_, pose_std_;  // [D]
};

}  // namespace mosyn::nn
