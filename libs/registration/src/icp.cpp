#include "obm/registration/icp.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/registration/confidence.hpp"
#include "obm/core/parallel.hpp"
#include "unit_free.hpp"

namespace obm::registration {
namespace {

constexpr std::size_t kChunk = 1024;
constexpr std::int32_t kNoMatch = -1;

/// Residual kind of one correspondence, fixed for the iteration's step (and LM retries).
enum Kind : std::uint8_t { kNone = 0, kPlane = 1, kPoint = 2 };

struct Correspondence {
  std::int32_t target = kNoMatch;
  std::uint8_t kind = kNone;
};

struct Normal {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  double cost = 0.0;
  std::size_t count = 0;
};

/// Everything fixed during one ICP iteration.
struct Problem {
  const std::vector<Vector3f>& src;
  const PreparedTarget& target;
  const IcpParams& params;
  const std::vector<double>* weights = nullptr;  ///< per source point prior weights (or all 1)
  /// Per source point colour intensity when the photometric term is on, else null.
  const std::vector<float>* intensity = nullptr;
};

/// Left-perturbed pose update used by the linearisation below: T ← (exp(θ), ρ) ∘ T, i.e.
/// p'' = exp(θ)·p' + ρ ≈ p' + θ × p' + ρ for p' = T·p.
Isometry3d applyStep(const Isometry3d& T, const Vector6d& delta) {
  const Eigen::Vector3d rho = delta.head<3>(), theta = delta.tail<3>();
  const double angle = theta.norm();
  const Eigen::Matrix3d dR = angle > 0.0
                                 ? Eigen::AngleAxisd(angle, theta / angle).toRotationMatrix()
                                 : Eigen::Matrix3d::Identity();
  Isometry3d out = Isometry3d::Identity();
  out.linear() = dR * T.linear();
  out.translation() = dR * T.translation() + rho;
  return out;
}

/// Correspondence of source point i at p' = T·p_i within `gate` (kind kNone when none).
Correspondence findCorrespondence(const Problem& pb, const Eigen::Vector3d& pt, double gate) {
  std::size_t j = 0;
  float d2 = 0.f;
  if (!pb.target.nearest(pt.cast<float>(), gate, j, d2)) return {};
  std::uint8_t kind = kPoint;
  if (pb.params.metric == IcpMetric::PointToPlane)
    kind =
        pb.target.normalValid()[j] ? kPlane : (pb.params.point_to_point_fallback ? kPoint : kNone);
  if (kind == kNone) return {};
  return Correspondence{static_cast<std::int32_t>(j), kind};
}

/// Robust cost (and, when `normal` is set, the IRLS normal equations H δ = −g) of the
/// correspondences at pose T. With `search_gate` > 0 the correspondences are searched first (in
/// the same pass, so one thread barrier per ICP iteration); otherwise `corr` is used as is.
/// Jacobians w.r.t. the left perturbation of p' = T·p:
///   plane: r = nᵀ(p' − q),  J = [nᵀ, (p' × n)ᵀ]
///   point: r = p' − q,      J = [I, −[p']×]
///   colour (with a plane residual, Park et al. 2017 eq. 17–19):
///          r = I(q) + dᵀ(p' − q) − I(p),  J = [dᵀ, (p' × d)ᵀ]
///   (d ⊥ n, so dᵀ(p' − q) equals dᵀ of p' projected on q's tangent plane, minus q).
Normal evaluate(const Problem& pb, std::vector<Correspondence>& corr, const Isometry3d& T,
                bool normal, double search_gate, int threads) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  const auto& tgt = pb.target.cloud().points;
  const auto& nrm = pb.target.normals();
  const auto kernel = pb.params.kernel;
  const double c = pb.params.kernel_scale;
  const bool search = search_gate > 0.0;
  const bool color = pb.intensity != nullptr;
  const double lambda_c = pb.params.color_weight;
  const double c_c = pb.params.color_kernel_scale;
  if (search) corr.assign(pb.src.size(), Correspondence{});
  std::vector<Normal> partials(numChunks(pb.src.size(), kChunk));
  parallelChunks(pb.src.size(), kChunk, threads,
                         [&](std::size_t ci, std::size_t b, std::size_t e) {
                           Normal& P = partials[ci];
                           for (std::size_t i = b; i < e; ++i) {
                             const Eigen::Vector3d pt = R * pb.src[i].cast<double>() + t;
                             if (search) corr[i] = findCorrespondence(pb, pt, search_gate);
                             const Correspondence& k = corr[i];
                             if (k.kind == kNone) continue;
                             const double pw = pb.weights ? (*pb.weights)[i] : 1.0;
                             const Eigen::Vector3d q = tgt[std::size_t(k.target)].cast<double>();
                             ++P.count;
                             if (k.kind == kPlane) {
                               const Eigen::Vector3d n = nrm[std::size_t(k.target)].cast<double>();
                               const double r = n.dot(pt - q);
                               P.cost += pw * robustCost(kernel, r, c);
                               double rc = 0.0;
                               Eigen::Vector3d d = Eigen::Vector3d::Zero();
                               if (color) {
                                 const std::size_t j = std::size_t(k.target);
                                 d = pb.target.colorGradients()[j].cast<double>();
                                 rc = pb.target.colorResidual(j, pt, (*pb.intensity)[i]);
                                 P.cost += lambda_c * pw * robustCost(kernel, rc, c_c);
                               }
                               if (!normal) continue;
                               const double w = pw * robustWeight(kernel, r, c);
                               Vector6d J;
                               J << n, pt.cross(n);
                               P.H.noalias() += w * J * J.transpose();
                               P.g.noalias() += (w * r) * J;
                               if (!color) continue;
                               const double wc = lambda_c * pw * robustWeight(kernel, rc, c_c);
                               J << d, pt.cross(d);
                               P.H.noalias() += wc * J * J.transpose();
                               P.g.noalias() += (wc * rc) * J;
                             } else {
                               const Eigen::Vector3d rv = pt - q;
                               const double rn = rv.norm();
                               P.cost += pw * robustCost(kernel, rn, c);
                               if (!normal) continue;
                               const double w = pw * robustWeight(kernel, rn, c);
                               // JᵀJ = [[I, −S], [S, −S²]] with S = [p']×; Jᵀr = [r; p' × r].
                               Eigen::Matrix3d S;
                               S << 0, -pt.z(), pt.y(), pt.z(), 0, -pt.x(), -pt.y(), pt.x(), 0;
                               P.H.block<3, 3>(0, 0) += w * Eigen::Matrix3d::Identity();
                               P.H.block<3, 3>(0, 3) += -w * S;
                               P.H.block<3, 3>(3, 0) += w * S;
                               P.H.block<3, 3>(3, 3) += -w * S * S;
                               P.g.head<3>() += w * rv;
                               P.g.tail<3>() += w * pt.cross(rv);
                             }
                           }
                         });
  Normal sum;
  for (const auto& P : partials) {
    sum.H += P.H;
    sum.g += P.g;
    sum.cost += P.cost;
    sum.count += P.count;
  }
  return sum;
}

/// Solves (H + damping) δ = −g. Gauss–Newton adds a tiny ridge so that exactly unconstrained
/// directions (a single plane) get a zero step instead of a failed factorisation.
Vector6d solveStep(const Matrix6d& H, const Vector6d& g, double lambda, bool lm) {
  const double max_diag = std::max(H.diagonal().maxCoeff(), 1e-300);
  Matrix6d A = H;
  if (lm) {
    for (int k = 0; k < 6; ++k) A(k, k) += lambda * std::max(H(k, k), 1e-6 * max_diag);
  } else {
    A.diagonal().array() += 1e-9 * max_diag;
  }
  const Vector6d delta = A.ldlt().solve(-g);
  return delta.allFinite() ? delta : Vector6d::Zero();
}

/// Basis (columns, in δ = [ρ; θ] coordinates) of the pose directions the normal equations `H`
/// of `count` correspondences hold (IcpParams::weak_direction_threshold): eigenvectors of the
/// unit-free Hessian (unit_free.hpp, the conditioning score's form) whose eigenvalue is at least
/// `threshold`. Six columns when every direction holds.
Eigen::Matrix<double, 6, Eigen::Dynamic> heldDirections(const Matrix6d& H, std::size_t count,
                                                        double L, double threshold) {
  const Vector6d D = detail::unitFreeScaling(L);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(
      detail::unitFreeHessian(H, D, double(std::max<std::size_t>(1, count))));
  Eigen::Matrix<double, 6, Eigen::Dynamic> basis(6, 0);
  for (int k = 0; k < 6; ++k) {
    if (es.eigenvalues()(k) < threshold) continue;
    basis.conservativeResize(Eigen::NoChange, basis.cols() + 1);
    basis.col(basis.cols() - 1) = D.asDiagonal() * es.eigenvectors().col(k);  // δ = D·u
  }
  return basis;
}

/// The step of solveStep confined to the columns of `B`: δ = B·y with y solving the reduced
/// normal equations, so that no direction outside B moves.
Vector6d solveStepWithin(const Matrix6d& H, const Vector6d& g, double lambda, bool lm,
                         const Eigen::Matrix<double, 6, Eigen::Dynamic>& B) {
  if (B.cols() == 0) return Vector6d::Zero();
  Eigen::MatrixXd A = B.transpose() * H * B;
  const Eigen::VectorXd b = B.transpose() * g;
  const double max_diag = std::max(A.diagonal().maxCoeff(), 1e-300);
  for (Eigen::Index k = 0; k < A.rows(); ++k)
    A(k, k) += lm ? lambda * std::max(A(k, k), 1e-6 * max_diag) : 1e-9 * max_diag;
  const Eigen::VectorXd y = A.ldlt().solve(-b);
  if (!y.allFinite()) return Vector6d::Zero();
  return B * y;
}

}  // namespace

IcpOutcome runIcp(const std::vector<Vector3f>& source_points, const PreparedTarget& target,
                  const Isometry3d& T_target_source_init, const IcpParams& params,
                  const std::vector<double>* point_weights,
                  const std::vector<float>* source_intensity) {
  params.validate();
  if (point_weights && point_weights->size() != source_points.size())
    throw ContractError("runIcp: " + std::to_string(point_weights->size()) + " weights for " +
                        std::to_string(source_points.size()) + " source points");
  if (source_intensity && source_intensity->size() != source_points.size())
    throw ContractError("runIcp: " + std::to_string(source_intensity->size()) +
                        " intensities for " + std::to_string(source_points.size()) +
                        " source points");
  // Depth-noise weights of an RGB-D source, times the caller's prior weights.
  std::vector<double> noise_weights;
  if (params.depth_noise_weights) {
    auto sigma = [&](double z) {
      const double dz = z - params.depth_noise_z0;
      return params.depth_noise_a + params.depth_noise_b * dz * dz;
    };
    const double s1 = sigma(1.0);
    noise_weights.resize(source_points.size());
    for (std::size_t i = 0; i < source_points.size(); ++i) {
      const double r = s1 / sigma(std::max(0.0, double(source_points[i].z())));
      noise_weights[i] = r * r * (point_weights ? (*point_weights)[i] : 1.0);
    }
    point_weights = &noise_weights;
  }
  IcpOutcome out;
  out.T_target_source = T_target_source_init;
  // The photometric term needs intensities on both sides and the plane residual it rides on.
  const bool color = source_intensity && params.color_weight > 0.0 &&
                     target.hasColorGradients() && params.metric == IcpMetric::PointToPlane;
  const Problem pb_wide{source_points, target, params, point_weights,
                        color ? source_intensity : nullptr};
  // The last stage's kernel (IcpParams::final_kernel_scale): the same problem, a narrower c.
  IcpParams tight_params = params;
  tight_params.kernel_scale = params.final_kernel_scale;
  const Problem pb_tight{source_points, target, tight_params, point_weights,
                         color ? source_intensity : nullptr};
  const Problem* stage = &pb_wide;
  bool tight_pending = params.final_kernel_scale > 0.0;
  const double fine = params.max_correspondence_distance;
  double gate = params.initial_max_correspondence_distance > fine
                    ? params.initial_max_correspondence_distance
                    : fine;
  const bool lm = params.solver == IcpSolver::LevenbergMarquardt;
  double lambda = 1e-4;
  Isometry3d T = T_target_source_init;
  std::vector<Correspondence> corr;
  for (int it = 0; it < params.max_iterations; ++it) {
    out.iterations = it + 1;
    // Search + normal equations in one parallel pass.
    const Problem& pb = *stage;
    const Normal ne = evaluate(pb, corr, T, true, gate, params.threads);
    const std::size_t n = ne.count;
    out.num_correspondences = n;
    if (n < static_cast<std::size_t>(params.min_correspondences)) {
      out.T_target_source = T;
      out.status = MatchStatus::TooFewCorrespondences;
      out.message = "ICP: " + std::to_string(n) + " correspondences within " +
                    std::to_string(gate) + " m (need " +
                    std::to_string(params.min_correspondences) + ")";
      return out;
    }
    Vector6d delta = Vector6d::Zero();
    // The directions that move this iteration (IcpParams::weak_direction_threshold).
    Eigen::Matrix<double, 6, Eigen::Dynamic> held(6, 0);
    const bool confine = params.weak_direction_threshold > 0.0;
    if (confine) {
      double p2 = 0.0;
      const Eigen::Matrix3d R = T.linear();
      for (std::size_t i = 0; i < source_points.size(); ++i)
        if (corr[i].kind != kNone)
          p2 += (R * source_points[i].cast<double>() + T.translation()).squaredNorm();
      held = heldDirections(ne.H, n, std::sqrt(p2 / double(n)), params.weak_direction_threshold);
    }
    auto step = [&](double lam, bool use_lm) {
      return confine ? solveStepWithin(ne.H, ne.g, lam, use_lm, held)
                     : solveStep(ne.H, ne.g, lam, use_lm);
    };
    if (!lm) {
      delta = step(0.0, false);
      T = applyStep(T, delta);
    } else {
      // Levenberg–Marquardt on the robust cost of the fixed correspondences: retry with more
      // damping until the cost decreases; no decrease at all means this stage has settled.
      bool accepted = false;
      for (int attempt = 0; attempt < 10 && !accepted; ++attempt) {
        const Vector6d d = step(lambda, true);
        const Isometry3d T_new = applyStep(T, d);
        // Residuals only (no search): cheap enough for one thread, which avoids a barrier.
        const double cost = evaluate(pb, corr, T_new, false, 0.0, 1).cost;
        if (cost <= ne.cost) {
          accepted = true;
          delta = d;
          T = T_new;
          lambda = std::max(lambda * 0.1, 1e-10);
        } else {
          lambda = std::min(lambda * 10.0, 1e10);
        }
      }
    }
    const bool small = delta.head<3>().norm() < params.translation_tolerance &&
                       delta.tail<3>().norm() < params.rotation_tolerance;
    if (small) {
      if (gate > fine) {
        gate = std::max(gate * params.anneal_factor, fine);
        continue;
      }
      if (tight_pending) {
        tight_pending = false;
        stage = &pb_tight;
        lambda = 1e-4;
        continue;
      }
      out.converged = true;
      break;
    }
  }
  // Re-orthonormalise: many small left-multiplications accumulate round-off in R.
  T.linear() = orthonormalize(T.linear());
  out.T_target_source = T;
  if (!out.converged) {
    out.status = MatchStatus::NotConverged;
    out.message = "ICP: no convergence in " + std::to_string(params.max_iterations) + " iterations";
  }
  if (params.polish_max_correspondence_distance > 0.0 &&
      params.metric == IcpMetric::PointToPlane) {
    // Point-to-point polish of the point-to-plane pose (see IcpParams), also when the plane stage
    // ran out of iterations: on noisy clouds it tends to circle its biased minimum. Point-to-point
    // converges linearly, so a polish that uses up its own iterations has still lowered its cost
    // and is kept; the outcome is converged when either stage converged.
    IcpParams polish = params;
    polish.metric = IcpMetric::PointToPoint;
    polish.initial_max_correspondence_distance = fine;
    polish.max_correspondence_distance = std::min(fine, params.polish_max_correspondence_distance);
    polish.polish_max_correspondence_distance = 0.0;
    polish.final_kernel_scale = 0.0;         // the polish is one point-to-point stage, ...
    polish.weak_direction_threshold = 0.0;   // ... whose point pairs hold every direction
    polish.depth_noise_weights = false;  // point_weights already carry them
    const IcpOutcome p = runIcp(source_points, target, T, polish, point_weights);
    if (p.status == MatchStatus::TooFewCorrespondences) return out;  // keep the plane result
    out.T_target_source = p.T_target_source;
    out.iterations += p.iterations;
    out.num_correspondences = p.num_correspondences;
    if (p.converged && !out.converged) {
      out.converged = true;
      out.status = MatchStatus::Ok;
      out.message.clear();
    }
  }
  return out;
}

void applyConfidence(MatchResult& result, const AlignmentStats& all_stats,
                     const AlignmentStats& info_stats, bool set_overlap, const IcpParams& icp,
                     const ConfidenceParams& confidence) {
  result.num_correspondences = all_stats.num_correspondences;
  result.inlier_ratio = all_stats.inlier_ratio;
  result.rmse = all_stats.rmse;
  result.fitness = all_stats.overlap;
  if (set_overlap) result.overlap = all_stats.overlap;
  result.information = info_stats.information;
  result.sigma = std::sqrt(info_stats.sigma2_used);
  // Conditioning and quality are properties of the pose and the geometry, taken on every source
  // point whichever matcher produced the pose, so that one threshold means the same for all of
  // them; only the information carries the matcher's own weights (the network's ω).
  result.conditioning = all_stats.conditioning;
  const bool too_few = !info_stats.valid || all_stats.num_correspondences <
                                                static_cast<std::size_t>(icp.min_correspondences);
  if (too_few) {
    if (result.status == MatchStatus::Ok || result.status == MatchStatus::NotConverged) {
      result.status = MatchStatus::TooFewCorrespondences;
      result.message = "confidence: " + std::to_string(all_stats.num_correspondences) +
                       " correspondences at the solution within " +
                       std::to_string(icp.max_correspondence_distance) + " m (need " +
                       std::to_string(icp.min_correspondences) + ")";
    }
    result.information.setZero();
    result.quality = 0.0;
    return;
  }
  if (result.status == MatchStatus::Ok &&
      info_stats.conditioning < confidence.degeneracy_threshold) {
    result.status = MatchStatus::Degenerate;
    result.message = "confidence: normalised smallest Hessian eigenvalue " +
                     std::to_string(info_stats.conditioning) + " < " +
                     std::to_string(confidence.degeneracy_threshold) +
                     " (a direction is unconstrained by the geometry)";
  }
  result.quality = matchQuality(all_stats.inlier_ratio, all_stats.rmse, all_stats.overlap,
                                all_stats.conditioning, icp.max_correspondence_distance, confidence);
}

std::vector<float> colorIntensities(const PointCloud& source, const PreparedTarget& target,
                                    const IcpParams& params) {
  std::vector<float> intensity;
  if (params.color_weight > 0.0 && source.hasColors() && target.hasColorGradients()) {
    intensity.reserve(source.size());
    for (const auto& c : source.colors) intensity.push_back(colorIntensity(c));
  }
  return intensity;
}

IcpMatcher::IcpMatcher(const IcpParams& icp, const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence) {}

MatchResult IcpMatcher::impl_match(const PointCloud& source, const PreparedTarget& target,
                                   const Isometry3d& T_target_source_init) const {
  const std::vector<float> intensity = colorIntensities(source, target, icp_);
  const IcpOutcome icp = runIcp(source.points, target, T_target_source_init, icp_, nullptr,
                                intensity.empty() ? nullptr : &intensity);
  MatchResult result = icp.toMatchResult();
  if (icp.status == MatchStatus::TooFewCorrespondences) return result;
  const AlignmentStats stats =
      evaluateAlignment(source.points, nullptr, target, result.T_target_source, icp_, confidence_,
                        intensity.empty() ? nullptr : &intensity);
  applyConfidence(result, stats, stats, true, icp_, confidence_);
  return result;
}

}  // namespace obm::registration
