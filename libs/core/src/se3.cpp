#include "obm/core/se3.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace obm {

Isometry3d makeIsometry(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

Isometry3d makeIsometry(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  return makeIsometry(q.normalized().toRotationMatrix(), t);
}

Isometry3d fromRowMajor3x4(const std::array<double, 12>& v) {
  Isometry3d T = Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
    T.translation()(r) = v[static_cast<std::size_t>(r * 4 + 3)];
  }
  return T;
}

std::array<double, 12> toRowMajor3x4(const Isometry3d& T) {
  std::array<double, 12> v{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) v[static_cast<std::size_t>(r * 4 + c)] = T.linear()(r, c);
    v[static_cast<std::size_t>(r * 4 + 3)] = T.translation()(r);
  }
  return v;
}

namespace {

// The nearest rotation by SVD, U·Vᵀ with the sign fixed so that det = +1.
Eigen::Matrix3d orthonormalizeSvd(const Eigen::Matrix3d& R) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) *= -1.0;
  return U * V.transpose();
}

}  // namespace

Eigen::Matrix3d orthonormalize(const Eigen::Matrix3d& R) {
  // For det R > 0 the nearest rotation in the Frobenius norm is the orthogonal polar factor of R
  // (= U·Vᵀ of its SVD). Newton's iteration X ← ½(γX + (γX)⁻ᵀ) with Higham's scaling
  // γ = (‖X⁻¹‖_F / ‖X‖_F)^½ converges to it quadratically (Higham, "Computing the polar
  // decomposition — with applications", 1986), a handful of 3×3 inverses instead of a Jacobi SVD;
  // the callers (chordal initialisation, pose averaging, Kabsch) mostly pass near-rotations. A
  // reflection (det ≤ 0) or a nearly singular input goes to the SVD, which keeps det = +1.
  const double scale = R.norm();
  if (!(scale > 0.0) || !std::isfinite(scale)) return orthonormalizeSvd(R);
  const double det = R.determinant();
  if (!(det > 1e-6 * scale * scale * scale)) return orthonormalizeSvd(R);
  Eigen::Matrix3d X = R;
  for (int it = 0; it < 30; ++it) {
    const Eigen::Matrix3d Xi = X.inverse();
    const double g = std::sqrt(Xi.norm() / X.norm());
    const Eigen::Matrix3d Xn = 0.5 * (g * X + Xi.transpose() / g);
    const double step = (Xn - X).cwiseAbs().maxCoeff();
    X = Xn;
    if (step < 1e-10) {
      // Quadratic convergence: one more step takes the error from ~1e-10 to round-off.
      return 0.5 * (X + X.inverse().transpose());
    }
  }
  return orthonormalizeSvd(R);
}

double rotationAngle(const Eigen::Matrix3d& R) {
  // Near 0 the arccos of the trace loses precision; use atan2(|sin|, cos) from the skew part.
  const double c = std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0);
  const Eigen::Vector3d s(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * s.norm(), c);
}

Eigen::Vector3d eulerZYX(const Eigen::Matrix3d& R) {
  // R = Rz(a)·Ry(b)·Rx(c): R(2,0) = −sin b.
  const double sb = std::clamp(-R(2, 0), -1.0, 1.0);
  const double b = std::asin(sb);
  double a, c;
  if (std::abs(sb) < 1.0 - 1e-12) {
    a = std::atan2(R(1, 0), R(0, 0));
    c = std::atan2(R(2, 1), R(2, 2));
  } else {  // gimbal lock: set x angle to 0 (scipy's convention)
    c = 0.0;
    a = std::atan2(-R(0, 1), R(1, 1));
  }
  return {a, b, c};
}

Eigen::Matrix3d fromEulerZYX(const Eigen::Vector3d& zyx) {
  return (Eigen::AngleAxisd(zyx.x(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(zyx.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(zyx.z(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

namespace {
Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return S;
}
}  // namespace

Eigen::Matrix3d expSO3(const Eigen::Vector3d& w) {
  const double th = w.norm();
  if (th < 1e-12) return Eigen::Matrix3d::Identity() + skew(w);
  return Eigen::AngleAxisd(th, w / th).toRotationMatrix();
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

namespace {
// Left Jacobian of SO(3) and its inverse.
Eigen::Matrix3d leftJacobian(const Eigen::Vector3d& w) {
  const double th = w.norm();
  const Eigen::Matrix3d W = skew(w);
  if (th < 1e-8) return Eigen::Matrix3d::Identity() + 0.5 * W;
  return Eigen::Matrix3d::Identity() + (1 - std::cos(th)) / (th * th) * W +
         (th - std::sin(th)) / (th * th * th) * W * W;
}
}  // namespace

Isometry3d expSE3(const Vector6d& xi) {
  const Eigen::Vector3d v = xi.head<3>();
  const Eigen::Vector3d w = xi.tail<3>();
  return makeIsometry(expSO3(w), leftJacobian(w) * v);
}

Vector6d logSE3(const Isometry3d& T) {
  const Eigen::Vector3d w = logSO3(T.linear());
  Vector6d xi;
  xi.head<3>() = leftJacobian(w).inverse() * T.translation();
  xi.tail<3>() = w;
  return xi;
}

Isometry3d randomRienetTransform(std::mt19937_64& rng, double max_angle_deg,
                                 double max_translation) {
  std::uniform_real_distribution<double> ang(0.0, max_angle_deg * kDegToRad);
  std::uniform_real_distribution<double> tr(-max_translation, max_translation);
  const double ax = ang(rng), ay = ang(rng), az = ang(rng);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  const Eigen::Vector3d t(tr(rng), tr(rng), tr(rng));
  return makeIsometry(R, t);
}

Isometry3d randomAxisAngleTransform(std::mt19937_64& rng, double max_angle_deg,
                                    double max_translation) {
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Eigen::Vector3d axis(n01(rng), n01(rng), n01(rng));
  axis.normalize();
  const double angle = u01(rng) * max_angle_deg * kDegToRad;
  Eigen::Vector3d dir(n01(rng), n01(rng), n01(rng));
  dir.normalize();
  const double tn = u01(rng) * max_translation;
  return makeIsometry(Eigen::AngleAxisd(angle, axis).toRotationMatrix(), tn * dir);
}

// ------------------------------------------------------------------ SE(2)

double wrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

Pose2::Pose2(double x_, double y_, double theta_) : x(x_), y(y_), theta(wrapAngle(theta_)) {}

Pose2 Pose2::operator*(const Pose2& o) const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {x + c * o.x - s * o.y, y + s * o.x + c * o.y, theta + o.theta};
}

Pose2 Pose2::inverse() const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {-(c * x + s * y), -(-s * x + c * y), -theta};
}

Eigen::Vector2d Pose2::operator*(const Eigen::Vector2d& p) const {
  const double c = std::cos(theta), s = std::sin(theta);
  return {x + c * p.x() - s * p.y(), y + s * p.x() + c * p.y()};
}

Eigen::Matrix3d Pose2::matrix() const {
  const double c = std::cos(theta), s = std::sin(theta);
  Eigen::Matrix3d M;
  M << c, -s, x, s, c, y, 0, 0, 1;
  return M;
}

Isometry3d Pose2::toIsometry3d() const {
  return makeIsometry(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                      Eigen::Vector3d(x, y, 0.0));
}

}  // namespace obm
