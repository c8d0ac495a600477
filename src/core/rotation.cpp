#include "core/rotation.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace mosyn {
namespace {

constexpr const char* kOrderNames[] = {"XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"};
constexpr int kOrderAxes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

}  // namespace

std::optional<EulerOrder> parse_euler_order(const std::string& text) {
  std::string upper = text;
  std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return std::toupper(c); });
  for (int i = 0; i < 6; ++i)
    if (upper == kOrderNames[i]) return static_cast<EulerOrder>(i);
  return std::nullopt;
}

std::string to_string(EulerOrder order) { return kOrderNames[static_cast<int>(order)]; }

int euler_axis(EulerOrder order, int i) { return kOrderAxes[static_cast<int>(order)][i]; }

Eigen::Quaterniond quat_about_axis(int axis, double angle_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::Unit(axis)));
}

Eigen::Quaterniond quat_from_euler(const Eigen::Vector3d& angles_rad, EulerOrder order) {
  const int* ax = kOrderAxes[static_cast<int>(order)];
  return (quat_about_axis(ax[0], angles_rad[0]) * quat_about_axis(ax[1], angles_rad[1]) *
          quat_about_axis(ax[2], angles_rad[2]))
      .normalized();
}

Eigen::Vector3d euler_from_matrix(const Eigen::Matrix3d& m, EulerOrder order) {
  // R = R_i(a) R_j(b) R_k(c). With s = +1 for cyclic orders (XYZ, YZX, ZXY) and -1 otherwise:
  // R(i,k) = s sin b, R(j,k) = -s sin a cos b, R(k,k) = cos a cos b,
  // R(i,j) = -s cos b sin c, R(i,i) = cos b cos c.
  const int* ax = kOrderAxes[static_cast<int>(order)];
  const int i = ax[0], j = ax[1], k = ax[2];
  const double s = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  const double sin_b = std::clamp(s * m(i, k), -1.0, 1.0);
  const double b = std::asin(sin_b);
  double a, c;
  if (std::abs(sin_b) < 1.0 - 1e-12) {
    a = std::atan2(-s * m(j, k), m(k, k));
    c = std::atan2(-s * m(i, j), m(i, i));
  } else {
    // Gimbal lock: only a + c (or a - c) is determined; put it all in a.
    c = 0.0;
    a = std::atan2(s * m(k, j), m(j, j));
  }
  return {a, b, c};
}

Eigen::Vector3d euler_from_quat(const Eigen::Quaterniond& q, EulerOrder order) {
  return euler_from_matrix(q.normalized().toRotationMatrix(), order);
}

Vector6d rot6d_from_matrix(const Eigen::Matrix3d& m) {
  Vector6d v;
  v << m.col(0), m.col(1);
  return v;
}

Vector6d rot6d_from_quat(const Eigen::Quaterniond& q) { return rot6d_from_matrix(q.normalized().toRotationMatrix()); }

Eigen::Matrix3d matrix_from_rot6d(const Vector6d& v) {
  Eigen::Vector3d a = v.head<3>(), b = v.tail<3>();
  Eigen::Vector3d c0 = a.normalized();
  Eigen::Vector3d c1 = (b - c0.dot(b) * c0).normalized();
  Eigen::Matrix3d m;
  m.col(0) = c0;
  m.col(1) = c1;
  m.col(2) = c0.cross(c1);
  return m;
}

Eigen::Quaterniond quat_from_rot6d(const Vector6d& v) { return Eigen::Quaterniond(matrix_from_rot6d(v)).normalized(); }

Eigen::Quaterniond quat_from_expmap(const Eigen::Vector3d& axis_angle) {
  const double angle = axis_angle.norm();
  if (angle < 1e-12) {
    // First-order expansion keeps the map smooth at zero.
    Eigen::Quaterniond q(1.0, 0.5 * axis_angle.x(), 0.5 * axis_angle.y(), 0.5 * axis_angle.z());
    return q.normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis_angle / angle));
}

Eigen::Vector3d expmap_from_quat(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double sin_half = q.vec().norm();
  if (sin_half < 1e-12) return 2.0 * q.vec();
  const double angle = 2.0 * std::atan2(sin_half, q.w());
  return q.vec() * (angle / sin_half);
}

double geodesic_angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Eigen::Quaterniond d = a.normalized().conjugate() * b.normalized();
  // atan2 is accurate near 0 and pi, unlike acos of the dot product.
  return 2.0 * std::atan2(d.vec().norm(), std::abs(d.w()));
}

double geodesic_angle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return geodesic_angle(Eigen::Quaterniond(a), Eigen::Quaterniond(b));
}

Eigen::Quaterniond align_hemisphere(const Eigen::Quaterniond& q, const Eigen::Quaterniond& reference) {
  if (q.coeffs().dot(reference.coeffs()) < 0) return Eigen::Quaterniond(-q.coeffs());
  return q;
}

}  // namespace mosyn
