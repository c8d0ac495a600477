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

torch::Tensor joint_ground_speed_mps(const torch::Tensor& positions_m, const torch::Tensor& control,
                                     const std::vector<int>& joints, double fps) {
  if (positions_m.dim() != 3 || control.dim() != 3 || control.size(2) < 3 || positions_m.size(0) != control.size(0) ||
      positions_m.size(1) != control.size(1) || positions_m.size(1) < 2)
    throw Error("joint_ground_speed_mps: positions [B, T >= 2, D] and control [B, T, >= 3] expected");
  std::vector<int64_t> x_index, z_index;
  for (int j : joints) {
    if (j < 0 || 3 * j + 2 >= positions_m.size(2)) throw Error("joint_ground_speed_mps: joint index out of range");
    x_index.push_back(3 * j);
    z_index.push_back(3 * j + 2);
  }
  const auto device = positions_m.device();
  const auto xi = torch::tensor(x_index, torch::kLong).to(device), zi = torch::tensor(z_index, torch::kLong).to(device);
  const int64_t t = positions_m.size(1);
  auto x = positions_m.index_select(2, xi), z = positions_m.index_select(2, zi);  // [B, T, K]
  auto x0 = x.narrow(1, 0, t - 1), z0 = z.narrow(1, 0, t - 1), x1 = x.narrow(1, 1, t - 1), z1 = z.narrow(1, 1, t - 1);
  auto step = control.narrow(1, 1, t - 1);  // [B, T-1, C]
  auto turn = step.select(2, 2).unsqueeze(-1), c = torch::cos(turn), s = torch::sin(turn);
  // R_y(a) (x, z) = (x cos a + z sin a, -x sin a + z cos a): heading a's axes in the frame before.
  auto dx = step.select(2, 0).unsqueeze(-1) + x1 * c + z1 * s - x0;
  auto dz = step.select(2, 1).unsqueeze(-1) - x1 * s + z1 * c - z0;
  return torch::sqrt(dx * dx + dz * dz + 1e-12) * fps;
}

}  // namespace mosyn::nn
