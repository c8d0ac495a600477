#include "nn/kinematics.h"

#include <string>

#include "core/error.h"

namespace mosyn::nn {

torch::Tensor matrix_from_rot6d(const torch::Tensor& r6) {
  if (r6.size(-1) != 6) throw Error("matrix_from_rot6d: last dimension must be 6");
  auto a = r6.narrow(-1, 0, 3), b = r6.narrow(-1, 3, 3);
  auto c0 = a / a.norm(2, -1, true);
  auto c1 = b - (c0 * b).sum(-1, true) * c0;
  c1 = c1 / c1.norm(2, -1, true);
  auto c2 = torch::cross(c0, c1, -1);
  return torch::stack({c0, c1, c2}, -1);  // columns
}

torch::Tensor rot6d_from_matrix(const torch::Tensor& m) {
  return torch::cat({m.select(-1, 0), m.select(-1, 1)}, -1);
}

torch::Tensor matrix_from_quat(const torch::Tensor& q_in) {
  if (q_in.size(-1) != 4) throw Error("matrix_from_quat: last dimension must be 4");
  auto q = q_in / q_in.norm(2, -1, true);
  auto w = q.select(-1, 0), x = q.select(-1, 1), y = q.select(-1, 2), z = q.select(-1, 3);
  auto r0 = torch::stack({1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)}, -1);
  auto r1 = torch::stack({2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)}, -1);
  auto r2 = torch::stack({2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}, -1);
  return torch::stack({r0, r1, r2}, -2);
}

torch::Tensor geodesic_angle(const torch::Tensor& a, const torch::Tensor& b, double eps) {
  // trace(A^T B) = sum of elementwise products.
  auto cos = ((a * b).sum({-2, -1}) - 1) * 0.5;
  return torch::acos(torch::clamp(cos, -1 + eps, 1 - eps));
}

torch::Tensor forward_kinematics(const torch::Tensor& local_rotations, const torch::Tensor& root_positions,
                                 const torch::Tensor& offsets, const std::vector<int>& parents,
                                 torch::Tensor* world_rotations) {
  const int64_t j = static_cast<int64_t>(parents.size());
  if (local_rotations.dim() != 5 || local_rotations.size(2) != j || local_rotations.size(3) != 3 ||
      local_rotations.size(4) != 3)
    throw Error("forward_kinematics: local_rotations must be [B, T, " + std::to_string(j) + ", 3, 3]");
  const int64_t b = local_rotations.size(0), t = local_rotations.size(1);
  if (root_positions.dim() != 3 || root_positions.size(0) != b || root_positions.size(1) != t ||
      root_positions.size(2) != 3)
    throw Error("forward_kinematics: root_positions must be [B, T, 3]");
  const bool per_frame_offsets = offsets.dim() == 4;
  if (!((offsets.dim() == 2 && offsets.size(0) == j && offsets.size(1) == 3) ||
        (per_frame_offsets && offsets.size(0) == b && offsets.size(1) == t && offsets.size(2) == j &&
         offsets.size(3) == 3)))
    throw Error("forward_kinematics: offsets must be [J, 3] or [B, T, J, 3]");
  std::vector<torch::Tensor> rot(j), pos(j);
  for (int64_t k = 0; k < j; ++k) {
    const int p = parents[k];
    auto local = local_rotations.select(2, k);  // [B, T, 3, 3]
    if (p < 0) {
      if (k != 0) throw Error("forward_kinematics: the root must be joint 0");
      rot[k] = local;
      pos[k] = root_positions;
      continue;
    }
    if (p >= k) throw Error("forward_kinematics: parents[j] must be < j");
    auto off = per_frame_offsets ? offsets.select(2, k) : offsets[k].expand({b, t, 3});
    rot[k] = torch::matmul(rot[p], local);
    pos[k] = pos[p] + torch::matmul(rot[p], off.unsqueeze(-1)).squeeze(-1);
  }
  if (world_rotations) *world_rotations = torch::stack(rot, 2);
  return torch::stack(pos, 2);
}

}  // namespace mosyn::nn
