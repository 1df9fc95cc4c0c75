#pragma once
// Checks (and optionally repairs) information matrices, and the square-root weight W with
// WᵀW = Ω used by the residuals: W = Lᵀ from Ω = L·Lᵀ when Ω is positive definite, W = √Λ·Vᵀ from
// the eigen-decomposition Ω = V·Λ·Vᵀ when it is only semi-definite. Either way ‖W·e‖² = eᵀΩe.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

namespace obm::backend::detail {

enum class InfoStatus { Ok, Repaired, NonFinite, Asymmetric, NotPsd };

inline const char* describe(InfoStatus s) {
  switch (s) {
    case InfoStatus::NonFinite:
      return "information matrix has a non-finite entry";
    case InfoStatus::Asymmetric:
      return "information matrix is not symmetric";
    case InfoStatus::NotPsd:
      return "information matrix is not positive semi-definite";
    default:
      return "information matrix is fine";
  }
}

/// Validates Ω; with `repair`, a symmetric Ω with negative eigenvalues gets them clamped to zero
/// (returns Repaired). Negative eigenvalues down to −1e-12·λ_max are round-off and accepted.
template <int N>
InfoStatus checkInformation(Eigen::Matrix<double, N, N>& omega, bool repair) {
  if (!omega.allFinite()) return InfoStatus::NonFinite;
  const double scale = std::max(omega.cwiseAbs().maxCoeff(), 1e-300);
  if ((omega - omega.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return InfoStatus::Asymmetric;
  Eigen::LLT<Eigen::Matrix<double, N, N>> llt(omega);
  if (llt.info() == Eigen::Success) return InfoStatus::Ok;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> es(omega);
  const auto& ev = es.eigenvalues();
  const double tol = 1e-12 * std::max(ev.cwiseAbs().maxCoeff(), 1e-300);
  if (ev.minCoeff() >= -tol) return InfoStatus::Ok;
  if (!repair) return InfoStatus::NotPsd;
  omega = es.eigenvectors() * ev.cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
  omega = 0.5 * (omega + omega.transpose()).eval();
  return InfoStatus::Repaired;
}

/// W with WᵀW = Ω (Ω symmetric PSD): Lᵀ of the Cholesky factor, or √Λ·Vᵀ if Ω is singular.
template <int N>
Eigen::Matrix<double, N, N> sqrtInformation(const Eigen::Matrix<double, N, N>& omega) {
  Eigen::LLT<Eigen::Matrix<double, N, N>> llt(omega);
  if (llt.info() == Eigen::Success) return llt.matrixL().transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> es(omega);
  return es.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace obm::backend::detail
