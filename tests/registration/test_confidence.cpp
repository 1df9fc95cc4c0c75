// Confidence: the (t, θ) ↔ g2o (t, vec q) information conversion, the information matrix of
// degenerate and well-conditioned scenes, its σ² scaling, its Jacobian convention (right,
// source-frame perturbation), and the scalar quality.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "obm/registration/confidence.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"

namespace obm {
namespace {

using test::makeSource;
using test::perturbation;
using test::poseError;

const Isometry3d kTruth =
    makeIsometry(Eigen::AngleAxisd(7.0 * kDegToRad, Eigen::Vector3d(-0.3, 0.2, 1.0).normalized())
                     .toRotationMatrix(),
                 Eigen::Vector3d(0.5, 0.3, -0.05));

Matrix6d randomSpd(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i) = N(rng);
  return A * A.transpose() + Matrix6d::Identity();
}

TEST(InformationConversion, ThetaToG2oIsExactJacobianScaling) {
  const Matrix6d omega = randomSpd(1);
  const Matrix6d q = registration::informationThetaToG2o(omega);
  // J = diag(I, 2I): Ω_q = Jᵀ Ω_θ J, computed here independently.
  Vector6d j;
  j << 1, 1, 1, 2, 2, 2;
  const Matrix6d expected = j.asDiagonal() * omega * j.asDiagonal();
  EXPECT_TRUE(q == expected);  // exact: scaling by powers of two
  EXPECT_TRUE(registration::informationG2oToTheta(q) == omega);
  EXPECT_TRUE((q.block<3, 3>(0, 0) == omega.block<3, 3>(0, 0)));
  EXPECT_TRUE((q.block<3, 3>(3, 3) == 4.0 * omega.block<3, 3>(3, 3)));
}

TEST(InformationConversion, MatchesTheQuaternionErrorToFirstOrder) {
  // For a small pose error δ = (ρ, θ), g2o's error is e = (t, vec q) of Exp(δ); the quadratic
  // forms eᵀΩ_q e and δᵀΩ_θ δ must agree to first order.
  const Matrix6d omega = randomSpd(2);
  const Matrix6d omega_q = registration::informationThetaToG2o(omega);
  for (double s : {1e-3, 1e-4}) {
    Vector6d delta;
    delta << 0.3, -0.2, 0.5, 0.4, -0.7, 0.2;
    delta *= s;
    const Eigen::Quaterniond q(
        Eigen::AngleAxisd(delta.tail<3>().norm(), delta.tail<3>().normalized()));
    Vector6d e;
    e << delta.head<3>(), q.vec();
    const double a = delta.dot(omega * delta), b = e.dot(omega_q * e);
    EXPECT_NEAR(b / a, 1.0, 10 * s);
  }
}

// ---------------------------------------------------------------------------------------------
TEST(Information, SinglePlaneIsDegenerateRoomIsNot) {
  registration::IcpParams p;
  p.max_correspondence_distance = 1.0;
  p.kernel = registration::RobustKernel::None;
  // Point-to-point residuals pin the tangential directions to the sampling pattern; on a plane
  // every normal is good, so keep the pure point-to-plane cost (docs/registration.md).
  p.point_to_point_fallback = false;
  registration::ConfidenceParams c;
  // Plane z = -1: only z, roll and pitch are observable. Perturb only those.
  const PointCloud plane = test::planeScene(10.0, 1);
  const PointCloud src = makeSource(plane, Isometry3d::Identity(), 0.5, 0.01, 2);
  Isometry3d guess =
      makeIsometry(Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitX()).toRotationMatrix(),
                   Eigen::Vector3d(0, 0, 0.2));
  const registration::MatchResult r = registration::IcpMatcher(p, c).match(src, plane, guess);
  EXPECT_EQ(r.status, registration::MatchStatus::Degenerate) << r.message;
  EXPECT_LT(r.conditioning, c.degeneracy_threshold);
  const Matrix6d& W = r.information;
  const double scale = W.diagonal().maxCoeff();
  ASSERT_GT(scale, 0.0);
  // Information along a unit direction e is eᵀΩe. Unconstrained: x, y translation and rotation
  // about z (indices 0, 1, 5); three eigenvalues vanish.
  for (int k : {0, 1, 5}) EXPECT_LT(W(k, k), 1e-6 * scale) << "direction " << k << "\n" << W;
  const auto ev = Eigen::SelfAdjointEigenSolver<Matrix6d>(W).eigenvalues();
  EXPECT_LT(ev(2), 1e-6 * ev(5));
  EXPECT_GT(ev(3), 1e-3 * ev(5));
  // Constrained: z, roll, pitch.
  for (int k : {2, 3, 4}) EXPECT_GT(W(k, k), 1e-3 * scale) << "direction " << k;
  EXPECT_NEAR(r.T_target_source.translation().z(), 0.0, 2e-3);

  // The room constrains all six directions.
  const PointCloud room = test::roomScene(20.0, 3);
  const PointCloud rsrc = makeSource(room, kTruth, 0.6, 0.01, 4);
  const registration::MatchResult rr =
      registration::IcpMatcher(p, c).match(rsrc, room, kTruth * perturbation(0.2, 3.0));
  EXPECT_EQ(rr.status, registration::MatchStatus::Ok) << rr.message;
  EXPECT_GT(rr.conditioning, c.conditioning_ref);
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(rr.information);
  EXPECT_GT(es.eigenvalues()(0), 0.0);
  EXPECT_LT(es.eigenvalues()(5) / es.eigenvalues()(0), 1e4);  // well-conditioned
  EXPECT_GT(rr.quality, 0.5);
  EXPECT_GT(rr.quality, r.quality);
}

TEST(Information, ScalesWithInverseNoiseVariance) {
  registration::IcpParams p;
  p.kernel = registration::RobustKernel::None;
  registration::ConfidenceParams c;
  c.min_sigma = 1e-4;
  const PointCloud room = test::roomScene(30.0, 5);
  // Same points, same noise directions, noise doubled.
  const PointCloud s1 = makeSource(room, kTruth, 0.6, 0.01, 6);
  const PointCloud s2 = makeSource(room, kTruth, 0.6, 0.02, 6);
  const Isometry3d guess = kTruth * perturbation(0.1, 2.0);
  const registration::MatchResult r1 = registration::IcpMatcher(p, c).match(s1, room, guess);
  const registration::MatchResult r2 = registration::IcpMatcher(p, c).match(s2, room, guess);
  ASSERT_TRUE(r1.ok() && r2.ok()) << r1.message << r2.message;
  // σ estimates the noise (a point-to-plane residual of isotropic noise has std σ).
  EXPECT_NEAR(r1.sigma, 0.01, 0.002);
  EXPECT_NEAR(r2.sigma, 0.02, 0.004);
  const double ratio = r2.information.trace() / r1.information.trace();
  EXPECT_NEAR(ratio, 0.25, 0.03);
  // And the matrices are symmetric positive definite.
  for (const auto* W : {&r1.information, &r2.information}) {
    EXPECT_TRUE(W->isApprox(W->transpose(), 1e-12));
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(*W).eigenvalues()(0), 0.0);
  }
  // The floor bounds a noise-free match.
  const PointCloud s0 = makeSource(room, kTruth, 0.6, 0.0, 6);
  const registration::MatchResult r0 = registration::IcpMatcher(p, c).match(s0, room, guess);
  EXPECT_DOUBLE_EQ(r0.sigma, c.min_sigma);
  EXPECT_TRUE(r0.information.allFinite());
}

TEST(Information, HessianUsesRightSourceFramePerturbation) {
  // H must be Σ J Jᵀ with J = ∂r/∂δ of r(T·Exp(δ)): check against numerical differentiation of
  // the point-to-plane residuals at a pose that is not the identity.
  registration::IcpParams p;
  p.kernel = registration::RobustKernel::None;
  p.point_to_point_fallback = false;
  registration::ConfidenceParams c;
  c.min_sigma = 1.0;  // Ω = H exactly
  const PointCloud room = test::roomScene(5.0, 7);
  const PointCloud src = makeSource(room, kTruth, 0.5, 0.0, 8);
  const registration::PreparedTarget target(room, p.targetOptions());
  const registration::AlignmentStats s =
      registration::evaluateAlignment(src.points, nullptr, target, kTruth, p, c);
  ASSERT_TRUE(s.valid);
  Matrix6d H = Matrix6d::Zero();
  for (const auto& ps : src.points) {
    std::size_t j;
    float d2;
    if (!target.nearest((kTruth * ps.cast<double>()).cast<float>(), 1.0, j, d2)) continue;
    if (!target.normalValid()[j]) continue;
    const Eigen::Vector3d n = target.normals()[j].cast<double>();
    const Eigen::Vector3d q = target.cloud().points[j].cast<double>();
    Vector6d J;
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d(k) = 1e-6;
      const auto r = [&](const Vector6d& x) {
        return n.dot(kTruth * expSE3(x) * ps.cast<double>() - q);
      };
      J(k) = (r(d) - r(-d)) / 2e-6;
    }
    H += J * J.transpose();
  }
  EXPECT_TRUE(s.hessian.isApprox(H, 1e-5)) << s.hessian << "\n\n" << H;
  EXPECT_TRUE(s.information.isApprox(s.hessian, 1e-12));
}

TEST(Information, ObmNetStylePriorWeightsScaleTheInformation) {
  // ω_i = prior_i · robust weight: a uniform prior c multiplies H and leaves σ² (almost) alone.
  registration::IcpParams p;
  registration::ConfidenceParams c;
  c.min_sigma = 1e-6;
  const PointCloud room = test::roomScene(10.0, 9);
  const PointCloud src = makeSource(room, kTruth, 0.5, 0.01, 10);
  const registration::PreparedTarget target(room, p.targetOptions());
  const std::vector<double> ones(src.size(), 1.0), threes(src.size(), 3.0);
  const auto a = registration::evaluateAlignment(src.points, &ones, target, kTruth, p, c);
  const auto b = registration::evaluateAlignment(src.points, &threes, target, kTruth, p, c);
  const auto none = registration::evaluateAlignment(src.points, nullptr, target, kTruth, p, c);
  EXPECT_TRUE(a.information == none.information);
  EXPECT_TRUE(b.hessian.isApprox(3.0 * a.hessian, 1e-12));
  EXPECT_NEAR(b.information.trace() / a.information.trace(), 3.0, 0.01);
  // Zero prior on half the points: they drop out of H.
  std::vector<double> half(src.size(), 1.0);
  for (std::size_t i = 0; i < half.size(); i += 2) half[i] = 0.0;
  const auto h = registration::evaluateAlignment(src.points, &half, target, kTruth, p, c);
  EXPECT_NEAR(h.hessian.trace() / a.hessian.trace(), 0.5, 0.05);
  EXPECT_EQ(h.num_correspondences, a.num_correspondences);  // geometry counts are unweighted
}

TEST(Quality, CombinesTheFourTerms) {
  registration::ConfidenceParams c;
  // Full credit everywhere.
  EXPECT_DOUBLE_EQ(registration::matchQuality(0.9, 0.0, 0.9, 0.5, 1.0, c), 1.0);
  // Each term alone.
  EXPECT_DOUBLE_EQ(registration::matchQuality(0.5 * c.inlier_ratio_ref, 0.0, 1.0, 1.0, 1.0, c),
                   0.5);
  EXPECT_DOUBLE_EQ(registration::matchQuality(1.0, 0.25, 1.0, 1.0, 1.0, c), 0.75);
  EXPECT_DOUBLE_EQ(registration::matchQuality(1.0, 0.0, 0.25 * c.overlap_ref, 1.0, 1.0, c), 0.25);
  EXPECT_DOUBLE_EQ(registration::matchQuality(1.0, 0.0, 1.0, 0.0, 1.0, c), 0.0);
  EXPECT_DOUBLE_EQ(registration::matchQuality(1.0, 2.0, 1.0, 1.0, 1.0, c), 0.0);  // clamped
  // A misaligned pose scores lower than the aligned one.
  registration::IcpParams p;
  const PointCloud room = test::roomScene(10.0, 11);
  const PointCloud src = makeSource(room, kTruth, 0.5, 0.01, 12);
  const registration::PreparedTarget target(room, p.targetOptions());
  auto quality = [&](const Isometry3d& T) {
    const auto s = registration::evaluateAlignment(src.points, nullptr, target, T, p, c);
    return registration::matchQuality(s.inlier_ratio, s.rmse, s.overlap, s.conditioning,
                                      p.max_correspondence_distance, c);
  };
  const double good = quality(kTruth), bad = quality(kTruth * perturbation(0.8, 15.0));
  EXPECT_GT(good, 0.8);
  EXPECT_LT(bad, 0.5 * good);
}

}  // namespace
TEST(WeakestTranslationSigma, IsTheLargestMarginalTranslationDeviation) {
  // Diagonal information: σ along y is 1/√4 = 0.5 m, the others smaller.
  Matrix6d omega = Matrix6d::Zero();
  omega.diagonal() << 100.0, 4.0, 25.0, 1e4, 1e4, 1e4;
  Eigen::Vector3d dir;
  EXPECT_NEAR(registration::weakestTranslationSigma(omega, &dir), 0.5, 1e-12);
  EXPECT_NEAR(std::abs(dir.y()), 1.0, 1e-12);
  // A translation that a rotation can explain is marginalised: coupling t_x with θ_z raises σ_x
  // above 1/√Ω_xx even though Ω_xx alone is large.
  Matrix6d coupled = Matrix6d::Identity() * 100.0;
  coupled(0, 5) = coupled(5, 0) = 99.0;
  const double sigma = registration::weakestTranslationSigma(coupled, &dir);
  EXPECT_GT(sigma, 0.5);
  EXPECT_NEAR(std::abs(dir.x()), 1.0, 1e-9);
  // No information along z at all: unconstrained.
  Matrix6d singular = Matrix6d::Identity();
  singular(2, 2) = 0.0;
  EXPECT_TRUE(std::isinf(registration::weakestTranslationSigma(singular)));
  EXPECT_TRUE(std::isinf(registration::weakestTranslationSigma(Matrix6d::Constant(NAN))));
}

}  // namespace obm
