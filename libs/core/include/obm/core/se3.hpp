#pragma once
/// \file se3.hpp
/// SE(3) / SE(2) helpers with the `T_a_b` convention: T_a_b maps points of frame b into frame a,
/// p_a = T_a_b · p_b, and T_a_c = T_a_b · T_b_c.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <random>

namespace obm {

using Isometry3d = Eigen::Isometry3d;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Builds T from a rotation and a translation.
Isometry3d makeIsometry(const Eigen::Matrix3d& R, const Eigen::Vector3d& t);

/// Builds T from a unit quaternion (normalised here) and a translation.
Isometry3d makeIsometry(const Eigen::Quaterniond& q, const Eigen::Vector3d& t);

/// T from the 12 numbers of a row-major 3×4 matrix [R|t] (KITTI pose / calib layout).
Isometry3d fromRowMajor3x4(const std::array<double, 12>& v);

/// The 12 numbers of the row-major 3×4 matrix [R|t].
std::array<double, 12> toRowMajor3x4(const Isometry3d& T);

/// The nearest rotation to R in the Frobenius norm (det = +1): its orthogonal polar factor by
/// Newton's iteration, or the SVD for reflections and nearly singular input.
Eigen::Matrix3d orthonormalize(const Eigen::Matrix3d& R);

/// Geodesic rotation angle of R in radians, in [0, π] (robust to round-off).
double rotationAngle(const Eigen::Matrix3d& R);

/// Euler angles (z, y, x) in radians such that R = Rz(z)·Ry(y)·Rx(x) — scipy's
/// `Rotation.as_euler('zyx')`, the decomposition RIENet's MAE(R) uses.
Eigen::Vector3d eulerZYX(const Eigen::Matrix3d& R);

/// R = Rz(z)·Ry(y)·Rx(x) from (z, y, x) in radians.
Eigen::Matrix3d fromEulerZYX(const Eigen::Vector3d& zyx);

/// so(3) exponential / logarithm (axis-angle vector, radians).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& w);
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);

/// SE(3) exponential / logarithm with twist ordered (v, w) — translation part first.
Isometry3d expSE3(const Vector6d& xi);
Vector6d logSE3(const Isometry3d& T);

/// Relative pose T_a_b = T_w_a⁻¹ · T_w_b.
inline Isometry3d relative(const Isometry3d& T_w_a, const Isometry3d& T_w_b) {
  return T_w_a.inverse() * T_w_b;
}

/// Random rigid transform of the RIENet/DCP protocol: each Euler angle ~ U[0, max_angle_deg],
/// R = Rx·Ry·Rz, t ~ U[−max_translation, max_translation]³.
Isometry3d randomRienetTransform(std::mt19937_64& rng, double max_angle_deg = 45.0,
                                 double max_translation = 0.5);

/// Random rotation with axis uniform on the sphere and angle ~ U[0, max_angle_deg]; translation with
/// uniform direction and norm ~ U[0, max_translation] (ICL-NUIM protocol).
Isometry3d randomAxisAngleTransform(std::mt19937_64& rng, double max_angle_deg,
                                    double max_translation);

constexpr double kDegToRad = 0.017453292519943295;
constexpr double kRadToDeg = 57.29577951308232;

// ---------------------------------------------------------------------------------------------
// SE(2)

/// Planar pose (x, y, θ) with θ in radians wrapped to (−π, π]. Same `T_a_b` convention.
struct Pose2 {
  double x = 0.0, y = 0.0, theta = 0.0;
  Pose2() = default;
  Pose2(double x_, double y_, double theta_);
  Pose2 operator*(const Pose2& other) const;  ///< composition T_a_b · T_b_c
  Pose2 inverse() const;
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const;
  Eigen::Matrix3d matrix() const;  ///< homogeneous 3×3
  /// Lift to SE(3) (z = 0, rotation about z).
  Isometry3d toIsometry3d() const;
};

/// Wraps an angle to (−π, π].
double wrapAngle(double a);

}  // namespace obm
