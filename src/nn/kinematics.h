// Batched, differentiable forward kinematics and rotation helpers in LibTorch, matching the
// double-precision reference in core/kinematics.h and core/rotation.h. Works for any floating
// dtype and device; gradients flow through every input tensor.
#pragma once

#include <torch/types.h>

#include <vector>

namespace mosyn::nn {

// 6D representation (Zhou et al. 2019; core/rotation.h layout: first two matrix columns
// stacked, (m00, m10, m20, m01, m11, m21)) [..., 6] -> rotation matrices [..., 3, 3] by
// Gram-Schmidt. The two halves must not be parallel.
torch::Tensor matrix_from_rot6d(const torch::Tensor& r6);
// Rotation matrices [..., 3, 3] -> 6D [..., 6].
torch::Tensor rot6d_from_matrix(const torch::Tensor& m);
// Quaternions [..., 4] as (w, x, y, z), any norm (normalised here) -> matrices [..., 3, 3].
torch::Tensor matrix_from_quat(const torch::Tensor& q);
// Geodesic angle (radians, [0, pi]) between rotation matrices a, b [..., 3, 3] -> [...].
// Clamped away from the acos singularities at 0 and pi by eps so gradients stay finite.
torch::Tensor geodesic_angle(const torch::Tensor& a, const torch::Tensor& b, double eps = 1e-7);

// World transforms of a skeleton (parents[j] < j, one root with parent -1):
//   R_w(root) = R_local(root), p_w(root) = root_positions;
//   R_w(c) = R_w(p) R_local(c), p_w(c) = p_w(p) + R_w(p) offsets(c).
// local_rotations [B, T, J, 3, 3]; root_positions [B, T, 3]; offsets [J, 3] (or [B, T, J, 3])
// in skeleton units. Returns world positions [B, T, J, 3]; world_rotations (optional output)
// receives [B, T, J, 3, 3]. Throws mosyn::Error on inconsistent shapes or parents.
torch::Tensor forward_kinematics(const torch::Tensor& local_rotations, const torch::Tensor& root_positions,
                                 const torch::Tensor& offsets, const std::vector<int>& parents,
                                 torch::Tensor* world_rotations = nullptr);

// Horizontal world speed (m/s) of chosen joints from frame t-1 to t, for the positions form
// (data/representation.h): joint positions in metres relative to the root path in its heading
// frame (x sideways, y up, z forward), and the control's per-frame root step (sideways, forward in
// metres in the previous frame's heading frame; turn in radians). Between frames, in the heading
// frame of t-1, a joint moves by step_t + R_y(turn_t) p_t - p_{t-1}.
// positions_m [B, T, D] (raw, not standardised), control [B, T, >= 3] (raw); joints: the joint
// indices j (features 3j..3j+2). Returns [B, T-1, joints.size()]; differentiable.
torch::Tensor joint_ground_speed_mps(const torch::Tensor& positions_m, const torch::Tensor& control,
                                     const std::vector<int>& joints, double fps);

}  // namespace mosyn::nn
