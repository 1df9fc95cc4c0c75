#pragma once
// Ceres residuals of g2o's pose-graph edges (private header; tests include it to check Jacobians).
//
// 3D (g2o EdgeSE3): for node poses X_a = (t_a, q_a), X_b = (t_b, q_b) and measurement Z = (t_z,
// q_z):
//   Δ = Z⁻¹·X_a⁻¹·X_b,  q_Δ = q_z* ⊗ q_a* ⊗ q_b,  t_Δ = R_zᵀ·(R_aᵀ·(t_b − t_a) − t_z),
//   e = [t_Δ; s·vec(q_Δ)] with s = sign(w_Δ) (g2o keeps w ≥ 0),   r = W·e,  WᵀW = Ω  (W = Lᵀ).
// Jacobians are derived in the tangent space of Ceres' EigenQuaternionManifold, whose update is
// q ← [δ; 1]-exponential ⊗ q (a rotation by 2|δ| applied on the left):
//   ∂t_Δ/∂t_a = −R_zᵀR_aᵀ,  ∂t_Δ/∂t_b = R_zᵀR_aᵀ,  ∂t_Δ/∂δ_a = 2·R_zᵀR_aᵀ·[t_b − t_a]×,  ∂t_Δ/∂δ_b
//   = 0, ∂vec(q_Δ)/∂δ_b = G,  ∂vec(q_Δ)/∂δ_a = −G,  G_k = vec(A ⊗ (e_k; 0) ⊗ q_b),  A = q_z* ⊗
//   q_a*,
// and lifted to the 4 ambient quaternion coordinates as J_amb = J_δ·Pᵀ, where P is the manifold's
// PlusJacobian (PᵀP = I at a unit quaternion, so Ceres' product J_amb·P gives back J_δ exactly).
//
// 2D (g2o EdgeSE2): e = [R_zᵀ(R_aᵀ(t_b − t_a) − t_z); wrap(θ_b − θ_a − θ_z)], r = W·e.
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace obm::backend::detail {

using Mat6 = Eigen::Matrix<double, 6, 6>;

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// PlusJacobian of ceres::EigenQuaternionManifold at q (rows x, y, z, w; 3 columns).
inline Eigen::Matrix<double, 4, 3> quaternionPlusJacobian(const Eigen::Quaterniond& q) {
  Eigen::Matrix<double, 4, 3> P;
  P << q.w(), q.z(), -q.y(),  //
      -q.z(), q.w(), q.x(),   //
      q.y(), -q.x(), q.w(),   //
      -q.x(), -q.y(), -q.z();
  return P;
}

/// R³ × unit quaternions, the same manifold as
/// ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold> (block
/// (t, q), t += δ_t, q ← exp(δ_θ) ⊗ q), written out: the product manifold dispatches to its
/// factors through virtual calls and assembles the 7×6 PlusJacobian block by block, a measurable
/// part of a 9-node graph's solve (docs/benchmarks.md, pose graph). Minus is delegated (not used
/// by the trust-region minimiser).
class PoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    x_plus_delta[0] = x[0] + delta[0];
    x_plus_delta[1] = x[1] + delta[1];
    x_plus_delta[2] = x[2] + delta[2];
    return quaternion_.Plus(x + 3, delta + 3, x_plus_delta + 3);
  }

  bool PlusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.topLeftCorner<3, 3>().setIdentity();
    J.bottomRightCorner<4, 3>() =
        quaternionPlusJacobian(Eigen::Map<const Eigen::Quaterniond>(x + 3));
    return true;
  }

  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    y_minus_x[0] = y[0] - x[0];
    y_minus_x[1] = y[1] - x[1];
    y_minus_x[2] = y[2] - x[2];
    return quaternion_.Minus(y + 3, x + 3, y_minus_x + 3);
  }

  bool MinusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
    J.setZero();
    J.topLeftCorner<3, 3>().setIdentity();
    Eigen::Matrix<double, 3, 4, Eigen::RowMajor> Jq;
    if (!quaternion_.MinusJacobian(x + 3, Jq.data())) return false;
    J.bottomRightCorner<3, 4>() = Jq;
    return true;
  }

 private:
  ceres::EigenQuaternionManifold quaternion_;
};

/// g2o EdgeSE3 residual with analytic Jacobians. Parameter blocks: one per node, (t, q) with
/// t = x y z and q in Eigen order x y z w, on the manifold R³ × EigenQuaternionManifold (one 6-dof
/// block per node keeps the block-sparse normal equations as small as the graph).
class EdgeSe3Cost final : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  EdgeSe3Cost(const Eigen::Vector3d& t_z, const Eigen::Quaterniond& q_z,
              const Mat6& sqrt_information)
      : t_z_(t_z), q_z_inv_(q_z.normalized().conjugate()), W_(sqrt_information) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> t_a(p[0]), t_b(p[1]);
    const Eigen::Map<const Eigen::Quaterniond> q_a(p[0] + 3), q_b(p[1] + 3);
    const Eigen::Quaterniond q_a_inv = q_a.conjugate();
    const Eigen::Quaterniond A = q_z_inv_ * q_a_inv;
    const Eigen::Quaterniond q_d = A * q_b;
    const Eigen::Vector3d d = t_b - t_a;
    const Eigen::Matrix3d M = A.toRotationMatrix();  // R_zᵀ·R_aᵀ
    const Eigen::Vector3d t_d = M * d - q_z_inv_ * t_z_;
    const double s = q_d.w() < 0.0 ? -1.0 : 1.0;
    Eigen::Matrix<double, 6, 1> e;
    e << t_d, s * q_d.vec();
    Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
    r.noalias() = W_ * e;
    if (!jacobians) return true;

    using J6x3 = Eigen::Matrix<double, 6, 3>;
    using J6x7 = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;
    Eigen::Matrix3d G;  // ∂vec(q_Δ)/∂δ_b, columns vec(A ⊗ (e_k, 0) ⊗ q_b)
    for (int k = 0; k < 3; ++k) {
      Eigen::Quaterniond u(0.0, 0.0, 0.0, 0.0);
      u.vec()[k] = 1.0;
      G.col(k) = s * (A * u * q_b).vec();
    }
    const Eigen::Matrix<double, 6, 3> WtM = W_.leftCols<3>() * M;  // W·[M; 0]
    if (jacobians[0]) {
      Eigen::Map<J6x7> J(jacobians[0]);
      J.leftCols<3>() = -WtM;
      J6x3 Jd;
      Jd.topRows<3>() = 2.0 * M * skew(d);
      Jd.bottomRows<3>() = -G;
      J.rightCols<4>().noalias() = (W_ * Jd) * quaternionPlusJacobian(q_a).transpose();
    }
    if (jacobians[1]) {
      Eigen::Map<J6x7> J(jacobians[1]);
      J.leftCols<3>() = WtM;
      J.rightCols<4>().noalias() =
          (W_.rightCols<3>() * G) * quaternionPlusJacobian(q_b).transpose();
    }
    return true;
  }

 private:
  Eigen::Vector3d t_z_;
  Eigen::Quaterniond q_z_inv_;
  Mat6 W_;
};

/// The same residual for automatic differentiation (reference for the analytic Jacobians).
struct EdgeSe3AutoDiff {
  EdgeSe3AutoDiff(const Eigen::Vector3d& t_z, const Eigen::Quaterniond& q_z, const Mat6& W)
      : t_z(t_z), q_z(q_z.normalized()), W(W) {}
  template <typename T>
  bool operator()(const T* a, const T* b, T* res) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    using Q = Eigen::Quaternion<T>;
    const Eigen::Map<const V3> t_a(a), t_b(b);
    const Eigen::Map<const Q> q_a(a + 3), q_b(b + 3);
    const Q qz_inv = q_z.conjugate().template cast<T>();
    const Q q_d = qz_inv * q_a.conjugate() * q_b;
    const V3 t_d = qz_inv * (q_a.conjugate() * (t_b - t_a) - t_z.template cast<T>());
    const T s = q_d.w() < T(0) ? T(-1) : T(1);
    Eigen::Matrix<T, 6, 1> e;
    e << t_d, s * q_d.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> out(res);
    out = W.template cast<T>() * e;
    return true;
  }
  Eigen::Vector3d t_z;
  Eigen::Quaterniond q_z;
  Mat6 W;
};

inline double wrapPi(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

/// g2o EdgeSE2 residual with analytic Jacobians. Parameter blocks: (x, y, θ)_a, (x, y, θ)_b.
class EdgeSe2Cost final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  EdgeSe2Cost(double x, double y, double theta, const Eigen::Matrix3d& sqrt_information)
      : tz_(x, y), th_z_(theta), cz_(std::cos(theta)), sz_(std::sin(theta)), W_(sqrt_information) {}

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const double* a = p[0];
    const double* b = p[1];
    const double ca = std::cos(a[2]), sa = std::sin(a[2]);
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double tx = ca * dx + sa * dy, ty = -sa * dx + ca * dy;  // R_aᵀ(t_b − t_a)
    const double ex = tx - tz_.x(), ey = ty - tz_.y();
    const Eigen::Vector3d e(cz_ * ex + sz_ * ey, -sz_ * ex + cz_ * ey, wrapPi(b[2] - a[2] - th_z_));
    Eigen::Map<Eigen::Vector3d> r(residuals);
    r.noalias() = W_ * e;
    if (!jacobians) return true;
    // M = R_zᵀ·R_aᵀ (rotation by −(θ_a + θ_z))
    const double cm = cz_ * ca - sz_ * sa, sm = sz_ * ca + cz_ * sa;  // cos, sin of θ_a + θ_z
    Eigen::Matrix3d Jb;
    Jb << cm, sm, 0, -sm, cm, 0, 0, 0, 1;
    if (jacobians[0]) {
      Eigen::Matrix3d Ja;
      Ja << -cm, -sm, cz_ * ty - sz_ * tx,  //
          sm, -cm, -sz_ * ty - cz_ * tx,    //
          0, 0, -1;
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(jacobians[0]).noalias() = W_ * Ja;
    }
    if (jacobians[1])
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(jacobians[1]).noalias() = W_ * Jb;
    return true;
  }

 private:
  Eigen::Vector2d tz_;
  double th_z_, cz_, sz_;
  Eigen::Matrix3d W_;
};

/// Dynamic covariance scaling (Agarwal et al., ICRA 2013) as a Ceres loss on s = χ² of an edge.
/// DCS scales the residual by k = min(1, 2Φ/(Φ + s)), i.e. weights the edge's normal equations by
/// k². This is the M-estimator whose IRLS weight ρ'(s) is exactly that k²:
///   ρ(s) = s (s ≤ Φ),   ρ(s) = 3Φ − 4Φ²/(Φ + s) (s > Φ),   continuous with ρ' at s = Φ,
/// so Ceres' trust-region step acceptance sees a cost consistent with its gradient.
class DcsLoss final : public ceres::LossFunction {
 public:
  explicit DcsLoss(double phi) : phi_(phi) {}
  /// Φ of the self-calibrating mode (`dcs:auto`), changed between solves, never during one.
  void setPhi(double phi) { phi_ = phi; }
  void Evaluate(double s, double rho[3]) const override {
    if (s <= phi_) {
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    }
    const double d = phi_ + s, p2 = phi_ * phi_;
    rho[0] = 3.0 * phi_ - 4.0 * p2 / d;
    rho[1] = 4.0 * p2 / (d * d);
    rho[2] = -8.0 * p2 / (d * d * d);
  }

 private:
  double phi_;
};

}  // namespace obm::backend::detail
