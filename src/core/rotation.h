// Rotation parameterisations and conversions. All angles are in radians; quaternions are unit
// Eigen::Quaterniond (w, x, y, z); matrices are 3x3 rotation matrices acting on column vectors.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>

namespace mosyn {

// Order of an Euler-angle triple. EulerOrder::kZXY means R = Rz(a0) * Rx(a1) * Ry(a2): the
// angles are listed in the order of the axes, and the rotation is the product in that order
// (the BVH convention: "Zrotation Xrotation Yrotation").
enum class EulerOrder { kXYZ, kXZY, kYXZ, kYZX, kZXY, kZYX };

// "XYZ", "ZXY", ... (case-insensitive) to an order; std::nullopt for anything else.
std::optional<EulerOrder> parse_euler_order(const std::string& text);
// The three-letter name, e.g. "ZXY".
std::string to_string(EulerOrder order);
// Axis index (0 = X, 1 = Y, 2 = Z) of the i-th angle of an order.
int euler_axis(EulerOrder order, int i);

// Rotation about one principal axis (0 = X, 1 = Y, 2 = Z).
Eigen::Quaterniond quat_about_axis(int axis, double angle_rad);

// Euler angles (a0, a1, a2) in the given order to a quaternion.
Eigen::Quaterniond quat_from_euler(const Eigen::Vector3d& angles_rad, EulerOrder order);
// A quaternion to Euler angles in the given order, with the middle angle in [-pi/2, pi/2] and
// the others in (-pi, pi]. At gimbal lock the last angle is set to 0.
Eigen::Vector3d euler_from_quat(const Eigen::Quaterniond& q, EulerOrder order);
Eigen::Vector3d euler_from_matrix(const Eigen::Matrix3d& m, EulerOrder order);

// 6D rotation representation of Zhou et al. 2019: the first two columns of the matrix,
// stacked (m00, m10, m20, m01, m11, m21).
using Vector6d = Eigen::Matrix<double, 6, 1>;
Vector6d rot6d_from_matrix(const Eigen::Matrix3d& m);
Vector6d rot6d_from_quat(const Eigen::Quaterniond& q);
// Gram-Schmidt back to a rotation matrix; works for any 6-vector whose two halves are not
// parallel (network outputs need not be orthonormal).
Eigen::Matrix3d matrix_from_rot6d(const Vector6d& v);
Eigen::Quaterniond quat_from_rot6d(const Vector6d& v);

// Axis-angle / exponential map: the rotation axis scaled by the angle in radians.
// expmap_from_quat returns an angle in [0, pi].
Eigen::Quaterniond quat_from_expmap(const Eigen::Vector3d& axis_angle);
Eigen::Vector3d expmap_from_quat(const Eigen::Quaterniond& q);

// Geodesic angle between two rotations, in [0, pi] radians.
double geodesic_angle(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);
double geodesic_angle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// q or -q, whichever lies in the same hemisphere as reference (dot product >= 0). Used to keep
// quaternion sequences continuous over time.
Eigen::Quaterniond align_hemisphere(const Eigen::Quaterniond& q, const Eigen::Quaterniond& reference);

}  // namespace mosyn
