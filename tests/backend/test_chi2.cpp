// g2o χ² by hand on edges with non-diagonal information, the Ceres residuals against it, and the
// analytic Jacobians against automatic / numeric differentiation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cost_functions.hpp"
#include "information.hpp"
#include "obm/backend/metrics.hpp"

using namespace obm;
using namespace obm::backend;

namespace {

Matrix6d nonDiagonalOmega3() {
  Matrix6d O = Matrix6d::Zero();
  O.diagonal() << 4, 3, 2, 5, 5, 6;
  O(0, 1) = O(1, 0) = 1.0;
  O(0, 5) = O(5, 0) = 0.5;
  return O;
}

Matrix6d randomSpd6(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, 1);
  Matrix6d A;
  for (int i = 0; i < 36; ++i) A(i) = n(rng);
  return A * A.transpose() + 0.5 * Matrix6d::Identity();
}

Pose3 randomPose(std::mt19937_64& rng, double t = 3.0) {
  std::normal_distribution<double> n(0, 1);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return Pose3(Eigen::Vector3d(t * n(rng), t * n(rng), t * n(rng)), q.normalized());
}

/// A node's Ceres parameter block: t = x y z, q = x y z w (Eigen order).
std::array<double, 7> poseBlock(const Pose3& p) {
  return {p.t.x(), p.t.y(), p.t.z(), p.q.x(), p.q.y(), p.q.z(), p.q.w()};
}

PoseGraph twoNodeGraph(const Pose3& a, const Pose3& b, const Pose3& z, const Matrix6d& omega) {
  PoseGraph g;
  g.nodes3[0] = Node3{0, a};
  g.nodes3[1] = Node3{1, b};
  Edge3 e;
  e.from = 0;
  e.to = 1;
  e.T_from_to = z;
  e.information = omega;
  g.edges3.push_back(e);
  return g;
}

}  // namespace

TEST(Chi2, Se3HandComputedNonDiagonal) {
  // X_a = I, Z = I, X_b = (t = (1,2,3), rotation 0.4 rad about z) ⇒ Δ = X_b,
  // e = (1, 2, 3, 0, 0, sin 0.2). With Ω above: eᵀΩe = 4·1 + 3·4 + 2·9 + 2·1·(1·2)
  //   + 5·0 + 5·0 + 6·s² + 2·0.5·(1·s) = 38 + 6s² + s, s = sin 0.2.
  const Pose3 b(Eigen::Vector3d(1, 2, 3),
                Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ())));
  const PoseGraph g = twoNodeGraph(Pose3(), b, Pose3(), nonDiagonalOmega3());
  const double s = std::sin(0.2);
  EXPECT_NEAR(chi2(g), 38.0 + 6.0 * s * s + s, 1e-12);
}

TEST(Chi2, Se3HandComputedWithQuaternionSignFlip) {
  // Δ = Z⁻¹·X_a⁻¹·X_b chosen as (t = (0.5, −1, 2), rotation 200° about y): its quaternion has
  // w = cos 100° < 0, so g2o flips it: vec = (0, −sin 100°, 0).
  const Pose3 Xa(Eigen::Vector3d(0, 0, 1),
                 Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())));
  const Pose3 Z(Eigen::Vector3d(1, 0, 0),
                Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())));
  const Isometry3d D = makeIsometry(
      Eigen::AngleAxisd(200.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d(0.5, -1, 2));
  const Pose3 Xb = Pose3::fromIsometry(Xa.isometry() * Z.isometry() * D);
  const Matrix6d O = nonDiagonalOmega3();
  const PoseGraph g = twoNodeGraph(Xa, Xb, Z, O);
  const double s = -std::sin(100.0 * kDegToRad);
  // e = (0.5, −1, 2, 0, s, 0): 4·0.25 + 3·1 + 2·4 + 2·1·(0.5·−1) + 5·s² + 2·0.5·(0.5·0) = 11 + 5s²
  EXPECT_NEAR(chi2(g), 11.0 + 5.0 * s * s, 1e-9);
  const Vector6d e = edgeError(Z, Xa, Xb);
  EXPECT_NEAR(e(4), s, 1e-12);
  EXPECT_NEAR(e(3), 0.0, 1e-12);
  EXPECT_NEAR(e(5), 0.0, 1e-12);
}

TEST(Chi2, Se2HandComputedNonDiagonal) {
  // X_a = (1, 2, π/2), X_b = (1, 4, π/2 + 0.3) ⇒ t_ab = R_aᵀ(0, 2) = (2, 0), θ_ab = 0.3.
  // Z = (1.5, 0.1, 0.2) ⇒ e = (R(0.2)ᵀ(0.5, −0.1), 0.1).
  PoseGraph g;
  g.dimension = 2;
  g.nodes2[0] = Node2{0, Pose2(1, 2, M_PI / 2)};
  g.nodes2[1] = Node2{1, Pose2(1, 4, M_PI / 2 + 0.3)};
  Edge2 e;
  e.from = 0;
  e.to = 1;
  e.T_from_to = Pose2(1.5, 0.1, 0.2);
  e.information << 10, 2, 1, 2, 8, 0.5, 1, 0.5, 20;
  g.edges2.push_back(e);
  const double c = std::cos(0.2), s = std::sin(0.2);
  const double ex = c * 0.5 + s * -0.1, ey = -s * 0.5 + c * -0.1, et = 0.1;
  const double expected =
      10 * ex * ex + 8 * ey * ey + 20 * et * et + 2 * (2 * ex * ey + 1 * ex * et + 0.5 * ey * et);
  EXPECT_NEAR(chi2(g), expected, 1e-12);
  // Angle wrapping: θ_b − θ_a − θ_z = 3.5 rad is an error of 3.5 − 2π.
  g.nodes2[1].T_world_node.theta = M_PI / 2 + 3.7;
  const Eigen::Vector3d err =
      edgeError(e.T_from_to, g.nodes2[0].T_world_node, g.nodes2[1].T_world_node);
  EXPECT_NEAR(err(2), 3.5 - 2 * M_PI, 1e-12);
}

TEST(Chi2, CeresResidualIsExactlyG2oChi2) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose3 a = randomPose(rng), b = randomPose(rng), z = randomPose(rng);
    const Matrix6d O = randomSpd6(rng);
    detail::EdgeSe3Cost cost(z.t, z.q, detail::sqrtInformation<6>(O));
    std::array<double, 7> pa = poseBlock(a), pb = poseBlock(b);
    const double* params[2] = {pa.data(), pb.data()};
    Eigen::Matrix<double, 6, 1> r;
    ASSERT_TRUE(cost.Evaluate(params, r.data(), nullptr));
    const Vector6d e = edgeError(z, a, b);
    const double chi = e.dot(O * e);
    EXPECT_NEAR(r.squaredNorm(), chi, 1e-9 * std::max(1.0, chi));
    // Weighting by L instead of Lᵀ (the Ceres example) gives a different cost when Ω is not
    // diagonal.
    const Eigen::Matrix<double, 6, 6> L = O.llt().matrixL();
    EXPECT_GT(std::abs((L * e).squaredNorm() - chi), 1e-6 * chi);
  }
}

TEST(Chi2, SingularInformationStillExact) {
  // A PSD Ω with a zero eigenvalue (no information along one direction): W = √Λ·Vᵀ.
  std::mt19937_64 rng(3);
  Eigen::Matrix<double, 6, 5> B;
  std::normal_distribution<double> n(0, 1);
  for (int i = 0; i < 30; ++i) B(i) = n(rng);
  const Matrix6d O = B * B.transpose();
  const Pose3 a = randomPose(rng), b = randomPose(rng), z = randomPose(rng);
  const Matrix6d W = detail::sqrtInformation<6>(O);
  const Vector6d e = edgeError(z, a, b);
  EXPECT_NEAR((W * e).squaredNorm(), e.dot(O * e), 1e-9 * e.dot(O * e));
}

TEST(Chi2, Se3AnalyticJacobiansMatchAutoDiff) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose3 a = randomPose(rng), b = randomPose(rng), z = randomPose(rng);
    const Matrix6d W = detail::sqrtInformation<6>(randomSpd6(rng));
    detail::EdgeSe3Cost analytic(z.t, z.q, W);
    ceres::AutoDiffCostFunction<detail::EdgeSe3AutoDiff, 6, 7, 7> autodiff(
        new detail::EdgeSe3AutoDiff(z.t, z.q, W));
    std::array<double, 7> pa = poseBlock(a), pb = poseBlock(b);
    const double* params[2] = {pa.data(), pb.data()};
    Eigen::Matrix<double, 6, 1> r1, r2;
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> J1[2], J2[2];
    double* j1[2] = {J1[0].data(), J1[1].data()};
    double* j2[2] = {J2[0].data(), J2[1].data()};
    ASSERT_TRUE(analytic.Evaluate(params, r1.data(), j1));
    ASSERT_TRUE(autodiff.Evaluate(params, r2.data(), j2));
    EXPECT_LT((r1 - r2).norm(), 1e-10 * std::max(1.0, r1.norm()));
    // Compare in the manifold's tangent space (what the solver uses): J·blockdiag(I₃, P).
    const ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold>
        manifold;
    for (int k = 0; k < 2; ++k) {
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus;
      ASSERT_TRUE(manifold.PlusJacobian(k == 0 ? pa.data() : pb.data(), plus.data()));
      const Eigen::Matrix<double, 6, 6> t1 = J1[k] * plus, t2 = J2[k] * plus;
      EXPECT_LT((t1 - t2).norm(), 1e-9 * std::max(1.0, t2.norm()))
          << "trial " << trial << " block " << k;
      // The plus-Jacobian used for the lift is Ceres' own.
      EXPECT_LT(
          (plus.bottomRightCorner<4, 3>() - detail::quaternionPlusJacobian(k == 0 ? a.q : b.q))
              .norm(),
          1e-15);
    }
  }
}

TEST(Chi2, Se2AnalyticJacobiansMatchNumeric) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix3d A;
    for (int i = 0; i < 9; ++i) A(i) = n(rng);
    const Eigen::Matrix3d O = A * A.transpose() + Eigen::Matrix3d::Identity();
    detail::EdgeSe2Cost cost(n(rng), n(rng), 0.5 * n(rng), detail::sqrtInformation<3>(O));
    double a[3] = {2 * n(rng), 2 * n(rng), 0.5 * n(rng)},
           b[3] = {2 * n(rng), 2 * n(rng), 0.5 * n(rng)};
    const double* params[2] = {a, b};
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> Ja, Jb;
    double* J[2] = {Ja.data(), Jb.data()};
    ASSERT_TRUE(cost.Evaluate(params, r.data(), J));
    for (int blk = 0; blk < 2; ++blk)
      for (int c = 0; c < 3; ++c) {
        double* x = blk == 0 ? a : b;
        const double h = 1e-6, x0 = x[c];
        Eigen::Vector3d rp, rm;
        x[c] = x0 + h;
        cost.Evaluate(params, rp.data(), nullptr);
        x[c] = x0 - h;
        cost.Evaluate(params, rm.data(), nullptr);
        x[c] = x0;
        const Eigen::Vector3d num = (rp - rm) / (2 * h);
        const Eigen::Vector3d ana =
            blk == 0 ? Eigen::Vector3d(Ja.col(c)) : Eigen::Vector3d(Jb.col(c));
        EXPECT_LT((num - ana).norm(), 1e-5 * std::max(1.0, ana.norm()));
      }
  }
}

TEST(Chi2, DcsLossIsConsistentAndWeightsLikeDcs) {
  const double phi = 2.0;
  detail::DcsLoss loss(phi);
  double rho[3];
  loss.Evaluate(phi, rho);
  EXPECT_NEAR(rho[0], phi, 1e-12);
  for (double s : {0.5, 1.9, 2.5, 10.0, 1000.0}) {
    loss.Evaluate(s, rho);
    const double k = std::min(1.0, 2 * phi / (phi + s));
    EXPECT_NEAR(rho[1], k * k, 1e-12) << s;  // IRLS weight = DCS scaling²
    double lo[3], hi[3];
    const double h = 1e-6 * std::max(1.0, s);
    loss.Evaluate(s - h, lo);
    loss.Evaluate(s + h, hi);
    EXPECT_NEAR((hi[0] - lo[0]) / (2 * h), rho[1], 1e-6) << s;  // ρ' is the derivative of ρ
    if (s > phi) {
      EXPECT_NEAR((hi[1] - lo[1]) / (2 * h), rho[2], 1e-6) << s;
    }
  }
  loss.Evaluate(1e12, rho);
  EXPECT_LT(rho[0], 3 * phi);  // bounded: an outlier's cost saturates
}

TEST(Chi2, PoseManifoldEqualsCeresProductManifold) {
  // The optimizer's written-out (t, q) manifold must be the product manifold the Jacobians above
  // are derived for: same Plus, PlusJacobian, Minus and MinusJacobian.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0, 1);
  const detail::PoseManifold ours;
  const ceres::ProductManifold<ceres::EuclideanManifold<3>, ceres::EigenQuaternionManifold> ref;
  ASSERT_EQ(ours.AmbientSize(), ref.AmbientSize());
  ASSERT_EQ(ours.TangentSize(), ref.TangentSize());
  for (int trial = 0; trial < 50; ++trial) {
    const Pose3 a = randomPose(rng), b = randomPose(rng);
    const std::array<double, 7> x = poseBlock(a), y = poseBlock(b);
    std::array<double, 6> delta{};
    // Also the zero step (Ceres's quaternion Plus has a separate branch for it).
    if (trial > 0)
      for (double& d : delta) d = 0.5 * n(rng);
    std::array<double, 7> p1{}, p2{};
    ASSERT_TRUE(ours.Plus(x.data(), delta.data(), p1.data()));
    ASSERT_TRUE(ref.Plus(x.data(), delta.data(), p2.data()));
    for (int i = 0; i < 7; ++i) EXPECT_DOUBLE_EQ(p1[i], p2[i]) << "trial " << trial;

    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P1, P2;
    ASSERT_TRUE(ours.PlusJacobian(x.data(), P1.data()));
    ASSERT_TRUE(ref.PlusJacobian(x.data(), P2.data()));
    EXPECT_LT((P1 - P2).norm(), 1e-15) << "trial " << trial;

    std::array<double, 6> m1{}, m2{};
    ASSERT_TRUE(ours.Minus(y.data(), x.data(), m1.data()));
    ASSERT_TRUE(ref.Minus(y.data(), x.data(), m2.data()));
    for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(m1[i], m2[i]) << "trial " << trial;

    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> M1, M2;
    ASSERT_TRUE(ours.MinusJacobian(x.data(), M1.data()));
    ASSERT_TRUE(ref.MinusJacobian(x.data(), M2.data()));
    EXPECT_LT((M1 - M2).norm(), 1e-15) << "trial " << trial;
  }
}
