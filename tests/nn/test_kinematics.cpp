// Torch FK and rotation helpers against the double-precision core reference, and gradients
// against central finite differences.
#include <gtest/gtest.h>
#include <torch/autograd.h>
#include <torch/utils.h>

#include <random>

#include "core/kinematics.h"
#include "core/error.h"
#include "core/rotation.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "nn/kinematics.h"

using namespace mosyn;

namespace {

torch::Tensor quat_tensor(const Eigen::Quaterniond& q) {
  return torch::tensor({q.w(), q.x(), q.y(), q.z()}, torch::kFloat64);
}

Eigen::Quaterniond random_quat(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

}  // namespace

TEST(TorchRotation, QuatAndRot6dMatchCore) {
  std::mt19937 rng(1);
  for (int i = 0; i < 20; ++i) {
    auto q = random_quat(rng);
    Eigen::Matrix3d m = q.toRotationMatrix();
    auto mt = nn::matrix_from_quat(quat_tensor(q) * 2.5);
    auto r6 = nn::rot6d_from_matrix(mt);
    Vector6d ref6 = rot6d_from_matrix(m);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(mt[r][c].item<double>(), m(r, c), 1e-12);
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(r6[k].item<double>(), ref6(k), 1e-12);
    // Gram-Schmidt of a perturbed 6D vector matches core.
    Vector6d noisy = ref6 * 1.7 + Vector6d::Constant(0.1);
    auto noisy_t = torch::from_blob(noisy.data(), {6}, torch::kFloat64).clone();
    auto back = nn::matrix_from_rot6d(noisy_t);
    Eigen::Matrix3d ref_back = matrix_from_rot6d(noisy);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(back[r][c].item<double>(), ref_back(r, c), 1e-12);
    auto q2 = random_quat(rng);
    auto angle = nn::geodesic_angle(mt, nn::matrix_from_quat(quat_tensor(q2)), 0.0).item<double>();
    EXPECT_NEAR(angle, q.angularDistance(q2), 1e-6);
  }
}

TEST(TorchKinematics, MatchesCoreForwardKinematics) {
  std::mt19937 rng(2);
  std::normal_distribution<double> n;
  Skeleton sk;
  sk.joint_names = {"root", "spine", "head", "arm", "hand", "leg"};
  sk.parents = {-1, 0, 1, 1, 3, 0};
  for (size_t j = 0; j < sk.parents.size(); ++j) sk.offsets.emplace_back(n(rng), n(rng), n(rng));
  const int t = 4, j = 6;
  Motion m = Motion::rest(sk, t, 30);
  for (int f = 0; f < t; ++f) {
    for (int k = 0; k < j; ++k) m.rotation(f, k) = random_quat(rng);
    m.translation(f, 0) = Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  const auto ref = forward_kinematics(sk, m);
  auto rots = torch::empty({1, t, j, 3, 3}, torch::kFloat64);
  auto root = torch::empty({1, t, 3}, torch::kFloat64);
  auto offsets = torch::empty({j, 3}, torch::kFloat64);
  for (int k = 0; k < j; ++k)
    for (int c = 0; c < 3; ++c) offsets[k][c] = sk.offsets[k](c);
  for (int f = 0; f < t; ++f) {
    for (int c = 0; c < 3; ++c) root[0][f][c] = m.translation(f, 0)(c);
    for (int k = 0; k < j; ++k) rots[0][f][k] = nn::matrix_from_quat(quat_tensor(m.rotation(f, k)));
  }
  torch::Tensor world_rot;
  auto pos = nn::forward_kinematics(rots, root, offsets, sk.parents, &world_rot);
  ASSERT_EQ(pos.sizes(), (std::vector<int64_t>{1, t, j, 3}));
  for (int f = 0; f < t; ++f) {
    for (int k = 0; k < j; ++k) {
      Eigen::Matrix3d rw = ref.rotation(f, k).toRotationMatrix();
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pos[0][f][k][c].item<double>(), ref.position(f, k)(c), 1e-6);
        for (int r = 0; r < 3; ++r) EXPECT_NEAR(world_rot[0][f][k][r][c].item<double>(), rw(r, c), 1e-6);
      }
    }
  }
}

TEST(TorchKinematics, GradientMatchesFiniteDifferences) {
  torch::manual_seed(4);
  const std::vector<int> parents = {-1, 0, 1, 0};
  auto r6 = torch::randn({2, 2, 4, 6}, torch::kFloat64).requires_grad_(true);
  auto root = torch::randn({2, 2, 3}, torch::kFloat64).requires_grad_(true);
  auto offsets = torch::randn({4, 3}, torch::kFloat64).requires_grad_(true);
  auto weights = torch::randn({2, 2, 4, 3}, torch::kFloat64);
  auto f = [&](const torch::Tensor& a, const torch::Tensor& r, const torch::Tensor& o) {
    return (nn::forward_kinematics(nn::matrix_from_rot6d(a), r, o, parents) * weights).sum();
  };
  auto grads = torch::autograd::grad({f(r6, root, offsets)}, {r6, root, offsets});
  // The geodesic angle has finite gradients even for identical rotations.
  auto a = nn::matrix_from_rot6d(torch::randn({3, 6}, torch::kFloat64)).requires_grad_(true);
  auto g = torch::autograd::grad({nn::geodesic_angle(a, a.detach()).sum()}, {a})[0];
  EXPECT_TRUE(torch::isfinite(g).all().item<bool>());
  const double h = 1e-6;
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> inputs = {r6.detach().clone(), root.detach().clone(), offsets.detach().clone()};
  for (size_t which = 0; which < inputs.size(); ++which) {
    auto flat = inputs[which].view({-1});
    for (int64_t i = 0; i < flat.size(0); i += 3) {
      const double v = flat[i].item<double>();
      flat[i] = v + h;
      const double up = f(inputs[0], inputs[1], inputs[2]).item<double>();
      flat[i] = v - h;
      const double down = f(inputs[0], inputs[1], inputs[2]).item<double>();
      flat[i] = v;
      EXPECT_NEAR(grads[which].view({-1})[i].item<double>(), (up - down) / (2 * h), 1e-6) << which << " " << i;
    }
  }
}

// The feet's horizontal world speed from positions-form features and the control, against the
// world positions of core forward kinematics, on a turning, swaying walk whose root path is
// smoothed (so the hips move relative to it).
TEST(TorchKinematics, JointGroundSpeedMatchesWorldPositions) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.6;
  o.sway_rad = 0.1;
  const int frames = 45;
  const double fps = 30.0;
  const Motion m = make_synthetic_walk(s, frames, fps, o);
  const data::FeatureLayout layout = data::make_layout(s, data::PoseForm::kPositions, 0, estimate_forward_in_root(s), 0.3);
  std::vector<float> pose, control;
  data::encode(s, m, layout, &pose, &control);
  const WorldPoses world = forward_kinematics(s, m);
  const std::vector<int> joints = {s.find("Foot_L"), s.find("Foot_R"), s.find("Head")};
  auto pose_t = torch::from_blob(pose.data(), {1, frames, layout.pose_dim}, torch::kFloat).to(torch::kDouble);
  auto control_t = torch::from_blob(control.data(), {1, frames, 3}, torch::kFloat).to(torch::kDouble);
  const auto speed = mosyn::nn::joint_ground_speed_mps(pose_t, control_t, joints, fps);
  ASSERT_EQ(speed.sizes(), (std::vector<int64_t>{1, frames - 1, 3}));
  double largest = 0;
  for (int t = 1; t < frames; ++t)
    for (size_t k = 0; k < joints.size(); ++k) {
      Eigen::Vector3d d = (world.position(t, joints[k]) - world.position(t - 1, joints[k])) * s.meters_per_unit;
      d[1] = 0;
      const double expected = d.norm() * fps;
      largest = std::max(largest, expected);
      EXPECT_NEAR(speed[0][t - 1][static_cast<int64_t>(k)].item<double>(), expected, 2e-3) << t << " " << k;
    }
  EXPECT_GT(largest, 1.0);  // the swinging feet move: the comparison is not of zeros
  EXPECT_THROW(mosyn::nn::joint_ground_speed_mps(pose_t, control_t.narrow(1, 0, 3), joints, fps), mosyn::Error);
}
