#include "obm/registration/confidence.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "obm/core/errors.hpp"
#include "obm/registration/match_result.hpp"
#include "obm/core/parallel.hpp"
#include "unit_free.hpp"

namespace obm::registration {
namespace {

constexpr std::size_t kChunk = 1024;

/// Per-chunk partial sums (summed in chunk order: bit-identical for any thread count).
struct Partial {
  Matrix6d H = Matrix6d::Zero();
  Matrix6d Hc = Matrix6d::Zero();  // the photometric term's (coloured ICP)
  double weight_sum = 0.0;   // Σ ω m
  double omega_sum = 0.0;    // Σ ω
  double weighted_r2 = 0.0;  // Σ ω ‖r‖²
  double weighted_p2 = 0.0;  // Σ ω ‖p‖²
  double r2 = 0.0;           // Σ ‖r‖²
  std::size_t correspondences = 0;
  std::size_t inliers = 0;
};

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

}  // namespace

const char* toString(MatchStart start) {
  switch (start) {
    case MatchStart::Guess:
      return "guess";
    case MatchStart::Network:
      return "network";
    case MatchStart::Hypothesis:
      return "hypothesis";
    case MatchStart::Heading:
      return "heading";
    case MatchStart::Turn:
      return "turn";
    case MatchStart::Search:
      return "search";
  }
  return "?";
}

const char* toString(MatchStatus status) {
  switch (status) {
    case MatchStatus::Ok:
      return "ok";
    case MatchStatus::EmptyInput:
      return "empty_input";
    case MatchStatus::TooFewPoints:
      return "too_few_points";
    case MatchStatus::TooFewCorrespondences:
      return "too_few_correspondences";
    case MatchStatus::NotConverged:
      return "not_converged";
    case MatchStatus::Degenerate:
      return "degenerate";
  }
  return "unknown";
}

Matrix6d informationThetaToG2o(const Matrix6d& omega_theta) {
  // Ω_q = Jᵀ Ω_θ J with J = diag(I, 2I): scale rows and columns 3..5 by 2.
  Matrix6d out = omega_theta;
  out.block<3, 6>(3, 0) *= 2.0;
  out.block<6, 3>(0, 3) *= 2.0;
  return out;
}

Matrix6d informationG2oToTheta(const Matrix6d& omega_q) {
  Matrix6d out = omega_q;
  out.block<3, 6>(3, 0) *= 0.5;
  out.block<6, 3>(0, 3) *= 0.5;
  return out;
}

AlignmentStats evaluateAlignment(const std::vector<Vector3f>& source_points,
                                 const std::vector<double>* point_weights,
                                 const PreparedTarget& target, const Isometry3d& T_target_source,
                                 const IcpParams& icp, const ConfidenceParams& confidence,
                                 const std::vector<float>* source_intensity) {
  OBM_ASSERT(!point_weights || point_weights->size() == source_points.size(),
             "evaluateAlignment: one prior weight per source point");
  OBM_ASSERT(!source_intensity || source_intensity->size() == source_points.size(),
             "evaluateAlignment: one intensity per source point");
  const bool color = source_intensity && icp.color_weight > 0.0 && target.hasColorGradients();
  AlignmentStats s;
  s.num_points = source_points.size();
  if (source_points.empty() || target.empty()) return s;

  const Eigen::Matrix3d R = T_target_source.linear();
  const Eigen::Vector3d t = T_target_source.translation();
  const auto& tgt = target.cloud().points;
  const auto& normals = target.normals();
  const auto& valid = target.normalValid();
  const bool plane_metric = icp.metric == IcpMetric::PointToPlane;
  const double gate = icp.max_correspondence_distance;
  const double inlier2 = confidence.inlier_threshold * confidence.inlier_threshold;
  // Coloured inliers: the grey residual must agree too (ConfidenceParams::color_inlier_threshold).
  const bool color_inliers =
      colorInliersApply(icp, confidence, target, source_intensity != nullptr);

  std::vector<Partial> partials(numChunks(source_points.size(), kChunk));
  parallelChunks(
      source_points.size(), kChunk, icp.threads, [&](std::size_t c, std::size_t b, std::size_t e) {
        Partial& P = partials[c];
        for (std::size_t i = b; i < e; ++i) {
          const Eigen::Vector3d p = source_points[i].cast<double>();
          const Eigen::Vector3d pt = R * p + t;
          std::size_t j = 0;
          float d2 = 0.f;
          if (!target.nearest(pt.cast<float>(), gate, j, d2)) continue;
          const Eigen::Vector3d q = tgt[j].cast<double>();
          const double prior = point_weights ? (*point_weights)[i] : 1.0;
          double r2 = 0.0;
          double rc = 0.0;  // grey residual (coloured pairs)
          if (color) rc = target.colorResidual(j, pt, (*source_intensity)[i]);
          if (plane_metric && valid[j]) {
            const Eigen::Vector3d n = normals[j].cast<double>();
            const double r = n.dot(pt - q);
            r2 = r * r;
            const double w = prior * robustWeight(icp.kernel, r, icp.kernel_scale);
            // Right perturbation T·Exp(δ): ∂r/∂ρ = (Rᵀn)ᵀ, ∂r/∂θ = (p × Rᵀn)ᵀ.
            const Eigen::Vector3d ns = R.transpose() * n;
            Vector6d J;
            J << ns, p.cross(ns);
            P.H.noalias() += w * J * J.transpose();
            if (color) {
              // Coloured ICP's photometric term constrains what the geometry may leave free.
              const Eigen::Vector3d d = target.colorGradients()[j].cast<double>();
              const double wc = icp.color_weight * prior *
                                robustWeight(icp.kernel, rc, icp.color_kernel_scale);
              const Eigen::Vector3d ds = R.transpose() * d;
              J << ds, p.cross(ds);
              P.Hc.noalias() += wc * J * J.transpose();
            }
            P.weight_sum += w;
            P.omega_sum += w;
            P.weighted_r2 += w * r2;
            P.weighted_p2 += w * p.squaredNorm();
          } else if (!plane_metric || icp.point_to_point_fallback) {
            const Eigen::Vector3d rv = pt - q;
            r2 = rv.squaredNorm();
            const double w = prior * robustWeight(icp.kernel, std::sqrt(r2), icp.kernel_scale);
            // ∂r/∂δ = R·[I, −[p]×]; JᵀJ = [I, −[p]×]ᵀ[I, −[p]×].
            const Eigen::Matrix3d S = skew(p);
            P.H.block<3, 3>(0, 0) += w * Eigen::Matrix3d::Identity();
            P.H.block<3, 3>(0, 3) += -w * S;
            P.H.block<3, 3>(3, 0) += w * S;
            P.H.block<3, 3>(3, 3) += -w * S * S;
            P.weight_sum += 3.0 * w;
            P.omega_sum += w;
            P.weighted_r2 += w * r2;
            P.weighted_p2 += w * p.squaredNorm();
          } else {
            continue;  // plane metric without a trusted normal and no fallback: not used
          }
          P.r2 += r2;
          ++P.correspondences;
          if (r2 <= inlier2 &&
              (!color_inliers || std::abs(rc) <= confidence.color_inlier_threshold))
            ++P.inliers;
        }
      });
  Partial T;
  for (const auto& P : partials) {
    T.H += P.H;
    T.Hc += P.Hc;
    T.weight_sum += P.weight_sum;
    T.omega_sum += P.omega_sum;
    T.weighted_r2 += P.weighted_r2;
    T.weighted_p2 += P.weighted_p2;
    T.r2 += P.r2;
    T.correspondences += P.correspondences;
    T.inliers += P.inliers;
  }
  s.num_correspondences = T.correspondences;
  s.num_inliers = T.inliers;
  s.overlap = double(T.correspondences) / double(s.num_points);
  s.inlier_ratio = double(T.inliers) / double(s.num_points);
  s.rmse = T.correspondences ? std::sqrt(T.r2 / double(T.correspondences)) : 0.0;
  s.weight_sum = T.weight_sum;
  s.hessian = 0.5 * (T.H + T.H.transpose());
  s.valid = T.weight_sum > 6.0 && T.omega_sum > 0.0;
  if (!s.valid) return s;
  s.sigma2 = T.weighted_r2 / (T.weight_sum - 6.0);
  s.sigma2_used = std::max(s.sigma2, confidence.min_sigma * confidence.min_sigma);
  s.information = (confidence.information_scale / s.sigma2_used) * s.hessian;
  // Unit-free conditioning: rotation columns scaled by the RMS lever arm L, per unit weight.
  const Vector6d D = detail::unitFreeScaling(std::sqrt(T.weighted_p2 / T.omega_sum));
  // With coloured ICP, the conditioning is that of the whole cost the pose minimised (geometric +
  // photometric): a wall with a texture is not degenerate for it. The information stays geometric.
  const Matrix6d H_cost = color ? Matrix6d(s.hessian + 0.5 * (T.Hc + T.Hc.transpose())) : s.hessian;
  const Matrix6d Hn = detail::unitFreeHessian(H_cost, D, T.weight_sum);
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(Hn, Eigen::EigenvaluesOnly);
  s.conditioning = std::max(0.0, es.eigenvalues()(0));
  return s;
}

bool colorInliersApply(const IcpParams& icp, const ConfidenceParams& confidence,
                       const PreparedTarget& target, bool source_has_intensity) {
  return confidence.color_inlier_threshold > 0.0 && icp.color_weight > 0.0 &&
         target.hasColorGradients() && source_has_intensity;
}

double matchQuality(double inlier_ratio, double rmse, double overlap, double conditioning,
                    double max_correspondence_distance, const ConfidenceParams& c) {
  auto credit = [](double x, double ref) { return std::clamp(x / ref, 0.0, 1.0); };
  const double q_inliers = credit(inlier_ratio, c.inlier_ratio_ref);
  const double q_rmse = std::clamp(1.0 - rmse / max_correspondence_distance, 0.0, 1.0);
  const double q_overlap = credit(overlap, c.overlap_ref);
  const double q_cond = credit(conditioning, c.conditioning_ref);
  const double q = q_inliers * q_rmse * q_overlap * q_cond;
  return std::isfinite(q) ? q : 0.0;
}

double weakestTranslationSigma(const Matrix6d& information, Eigen::Vector3d* direction) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (direction) *direction = Eigen::Vector3d::UnitX();
  if (!information.allFinite()) return kInf;
  // Ω is symmetric positive semi-definite; an LDLT that is not positive definite means a
  // direction with no information at all.
  const Matrix6d omega = 0.5 * (information + information.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix6d> full(omega);
  if (full.info() != Eigen::Success) return kInf;
  const double top = full.eigenvalues().maxCoeff();
  if (!(top > 0.0) || full.eigenvalues().minCoeff() <= top * 1e-14) return kInf;
  const Matrix6d cov = full.eigenvectors() * full.eigenvalues().cwiseInverse().asDiagonal() *
                       full.eigenvectors().transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> tt(0.5 * (cov.topLeftCorner<3, 3>() +
                                                           cov.topLeftCorner<3, 3>().transpose()));
  if (tt.info() != Eigen::Success) return kInf;
  if (direction) *direction = tt.eigenvectors().col(2);
  return std::sqrt(std::max(0.0, tt.eigenvalues()(2)));
}

}  // namespace obm::registration
