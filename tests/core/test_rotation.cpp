#include "core/rotation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace mosyn {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr EulerOrder kAllOrders[] = {EulerOrder::kXYZ, EulerOrder::kXZY, EulerOrder::kYXZ,
                                     EulerOrder::kYZX, EulerOrder::kZXY, EulerOrder::kZYX};

std::vector<Eigen::Quaterniond> random_rotations(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  std::vector<Eigen::Quaterniond> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
    out.push_back(q.normalized());
  }
  return out;
}

// Same rotation: q and -q both count.
double rotation_distance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return std::min((a.coeffs() - b.coeffs()).norm(), (a.coeffs() + b.coeffs()).norm());
}

Eigen::Matrix3d axis_matrix(int axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  Eigen::Matrix3d m;
  if (axis == 0) m << 1, 0, 0, 0, c, -s, 0, s, c;
  if (axis == 1) m << c, 0, s, 0, 1, 0, -s, 0, c;
  if (axis == 2) m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}

TEST(Rotation, ParseAndNameEulerOrders) {
  for (EulerOrder order : kAllOrders) EXPECT_EQ(parse_euler_order(to_string(order)), order);
  EXPECT_EQ(parse_euler_order("zxy"), EulerOrder::kZXY);
  EXPECT_FALSE(parse_euler_order("XYX").has_value());
  EXPECT_FALSE(parse_euler_order("").has_value());
  EXPECT_EQ(euler_axis(EulerOrder::kZXY, 0), 2);
  EXPECT_EQ(euler_axis(EulerOrder::kZXY, 1), 0);
  EXPECT_EQ(euler_axis(EulerOrder::kZXY, 2), 1);
}

TEST(Rotation, AxisRotationMatchesHandWrittenMatrix) {
  for (int axis = 0; axis < 3; ++axis)
    for (double a : {-2.0, -0.3, 0.0, 0.7, 3.0})
      EXPECT_LT((quat_about_axis(axis, a).toRotationMatrix() - axis_matrix(axis, a)).norm(), 1e-14);
  // 90 degrees about Z takes +X to +Y.
  EXPECT_LT((quat_about_axis(2, kPi / 2) * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-15);
}

TEST(Rotation, EulerIsProductInListedOrder) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (EulerOrder order : kAllOrders)
    for (int i = 0; i < 100; ++i) {
      const Eigen::Vector3d a(u(rng), u(rng) / 2, u(rng));
      const Eigen::Matrix3d expected = axis_matrix(euler_axis(order, 0), a[0]) *
                                       axis_matrix(euler_axis(order, 1), a[1]) *
                                       axis_matrix(euler_axis(order, 2), a[2]);
      EXPECT_LT((quat_from_euler(a, order).toRotationMatrix() - expected).norm(), 1e-12);
    }
}

TEST(Rotation, EulerRoundTripOnRandomRotationsAllOrders) {
  for (EulerOrder order : kAllOrders)
    for (const Eigen::Quaterniond& q : random_rotations(1000, 11)) {
      const Eigen::Vector3d a = euler_from_quat(q, order);
      EXPECT_LE(std::abs(a[1]), kPi / 2 + 1e-12);
      EXPECT_LE(std::abs(a[0]), kPi + 1e-12);
      EXPECT_LE(std::abs(a[2]), kPi + 1e-12);
      EXPECT_LT(rotation_distance(quat_from_euler(a, order), q), 1e-9) << to_string(order);
      const Eigen::Vector3d b = euler_from_matrix(q.toRotationMatrix(), order);
      EXPECT_LT((a - b).norm(), 1e-9);
    }
}

TEST(Rotation, EulerGimbalLockKeepsTheRotation) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (EulerOrder order : kAllOrders)
    for (double middle : {kPi / 2, -kPi / 2})
      for (int i = 0; i < 50; ++i) {
        const Eigen::Vector3d a(u(rng), middle, u(rng));
        const Eigen::Quaterniond q = quat_from_euler(a, order);
        const Eigen::Vector3d back = euler_from_quat(q, order);
        EXPECT_NEAR(std::abs(back[1]), kPi / 2, 1e-6);
        EXPECT_EQ(back[2], 0.0);
        EXPECT_LT(geodesic_angle(quat_from_euler(back, order), q), 1e-6) << to_string(order);
      }
}

TEST(Rotation, MatrixQuaternion6dExpmapAgree) {
  for (const Eigen::Quaterniond& q : random_rotations(1000, 21)) {
    const Eigen::Matrix3d m = q.toRotationMatrix();
    // 6D is the first two columns.
    const Vector6d v = rot6d_from_quat(q);
    EXPECT_LT((v.head<3>() - m.col(0)).norm(), 1e-14);
    EXPECT_LT((v.tail<3>() - m.col(1)).norm(), 1e-14);
    EXPECT_LT((rot6d_from_matrix(m) - v).norm(), 1e-14);
    EXPECT_LT((matrix_from_rot6d(v) - m).norm(), 1e-12);
    EXPECT_LT(rotation_distance(quat_from_rot6d(v), q), 1e-12);
    // Expmap: angle in [0, pi], and rotating the axis leaves it fixed.
    const Eigen::Vector3d e = expmap_from_quat(q);
    EXPECT_LE(e.norm(), kPi + 1e-12);
    EXPECT_LT(rotation_distance(quat_from_expmap(e), q), 1e-12);
    EXPECT_LT((m * e - e).norm(), 1e-12);
    EXPECT_NEAR(e.norm(), geodesic_angle(Eigen::Quaterniond::Identity(), q), 1e-12);
  }
}

TEST(Rotation, ExpmapNearZeroAndNearPi) {
  const Eigen::Vector3d tiny(1e-14, -2e-14, 3e-14);
  EXPECT_LT((expmap_from_quat(quat_from_expmap(tiny)) - tiny).norm(), 1e-20);
  EXPECT_LT((expmap_from_quat(Eigen::Quaterniond::Identity())).norm(), 1e-20);
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  const Eigen::Vector3d e = expmap_from_quat(quat_from_expmap(axis * (kPi - 1e-9)));
  EXPECT_NEAR(e.norm(), kPi - 1e-9, 1e-9);
  EXPECT_LT((e.normalized() - axis).norm(), 1e-6);
  // Rotation by more than pi comes back as the shorter one about the opposite axis.
  const Eigen::Vector3d big = expmap_from_quat(quat_from_expmap(axis * 4.0));
  EXPECT_NEAR(big.norm(), 2 * kPi - 4.0, 1e-12);
  EXPECT_LT((big.normalized() + axis).norm(), 1e-12);
}

TEST(Rotation, SixDGramSchmidtOnNonOrthonormalInput) {
  std::mt19937 rng(8);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 1000; ++i) {
    Vector6d v;
    for (int k = 0; k < 6; ++k) v[k] = normal(rng);
    const Eigen::Matrix3d m = matrix_from_rot6d(v);
    EXPECT_LT((m.transpose() * m - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_NEAR(m.determinant(), 1.0, 1e-12);
    // First column is the normalised first half; second lies in the span of both halves,
    // on the same side as the second half.
    EXPECT_LT((m.col(0) - v.head<3>().normalized()).norm(), 1e-12);
    const Eigen::Vector3d normal_of_span = v.head<3>().cross(v.tail<3>()).normalized();
    EXPECT_NEAR(m.col(1).dot(normal_of_span), 0.0, 1e-12);
    EXPECT_GT(m.col(1).dot(v.tail<3>()), 0.0);
    // Scaling either half changes nothing.
    Vector6d scaled = v;
    scaled.head<3>() *= 3.5;
    scaled.tail<3>() *= 0.2;
    EXPECT_LT((matrix_from_rot6d(scaled) - m).norm(), 1e-12);
  }
}

TEST(Rotation, GeodesicAngleIsAngleOfRelativeRotation) {
  const auto a = random_rotations(1000, 31), b = random_rotations(1000, 32);
  for (size_t i = 0; i < a.size(); ++i) {
    const Eigen::AngleAxisd relative(a[i].conjugate() * b[i]);
    const double expected = relative.angle() > kPi ? 2 * kPi - relative.angle() : relative.angle();
    EXPECT_NEAR(geodesic_angle(a[i], b[i]), expected, 1e-9);
    EXPECT_NEAR(geodesic_angle(a[i], b[i]), geodesic_angle(b[i], a[i]), 1e-12);
    EXPECT_NEAR(geodesic_angle(a[i].toRotationMatrix(), b[i].toRotationMatrix()), geodesic_angle(a[i], b[i]), 1e-9);
    // Sign of the quaternion does not matter.
    EXPECT_NEAR(geodesic_angle(a[i], Eigen::Quaterniond(-b[i].coeffs())), geodesic_angle(a[i], b[i]), 1e-12);
  }
  EXPECT_NEAR(geodesic_angle(Eigen::Quaterniond::Identity(), quat_about_axis(1, kPi)), kPi, 1e-12);
  EXPECT_NEAR(geodesic_angle(quat_about_axis(0, 0.3), quat_about_axis(0, 0.3 + 1e-7)), 1e-7, 1e-15);
}

TEST(Rotation, AlignHemisphere) {
  const Eigen::Quaterniond ref = quat_about_axis(2, 0.1);
  const Eigen::Quaterniond q(-quat_about_axis(2, 0.2).coeffs());
  const Eigen::Quaterniond aligned = align_hemisphere(q, ref);
  EXPECT_GE(aligned.coeffs().dot(ref.coeffs()), 0.0);
  EXPECT_LT(rotation_distance(aligned, q), 1e-15);
  EXPECT_EQ(align_hemisphere(ref, ref).coeffs(), ref.coeffs());
}

}  // namespace
}  // namespace mosyn
