#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "obm/core/se3.hpp"

using namespace obm;

TEST(SE3, RowMajorRoundTrip) {
  std::mt19937_64 rng(3);
  const Isometry3d T = randomRienetTransform(rng);
  const Isometry3d T2 = fromRowMajor3x4(toRowMajor3x4(T));
  EXPECT_TRUE(T.matrix().isApprox(T2.matrix(), 1e-15));
  const auto v = toRowMajor3x4(T);
  EXPECT_DOUBLE_EQ(v[3], T.translation().x());
  EXPECT_DOUBLE_EQ(v[1], T.linear()(0, 1));
}

TEST(SE3, FrameConventionComposition) {
  // T_a_b maps b-points into a; T_a_c = T_a_b · T_b_c.
  const Isometry3d T_a_b = makeIsometry(Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())),
                                        Eigen::Vector3d(1, 2, 3));
  const Isometry3d T_b_c = makeIsometry(Eigen::Matrix3d(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX())),
                                        Eigen::Vector3d(0, -1, 0.5));
  const Eigen::Vector3d p_c(0.1, 0.2, 0.3);
  EXPECT_TRUE(((T_a_b * T_b_c) * p_c).isApprox(T_a_b * (T_b_c * p_c), 1e-12));
  EXPECT_TRUE(relative(T_a_b, T_a_b * T_b_c).matrix().isApprox(T_b_c.matrix(), 1e-12));
}

TEST(SE3, EulerZYXMatchesScipyConvention) {
  // Hand-computed: R = Rz(30°)·Ry(20°)·Rx(10°) must decompose back to (30, 20, 10).
  const Eigen::Vector3d zyx(30 * kDegToRad, 20 * kDegToRad, 10 * kDegToRad);
  const Eigen::Matrix3d R = fromEulerZYX(zyx);
  const Eigen::Matrix3d R_manual =
      (Eigen::AngleAxisd(zyx[0], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(zyx[1], Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(zyx[2], Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  EXPECT_TRUE(R.isApprox(R_manual, 1e-14));
  EXPECT_TRUE(eulerZYX(R).isApprox(zyx, 1e-12));
  // R(2,0) = -sin(y)
  EXPECT_NEAR(R(2, 0), -std::sin(20 * kDegToRad), 1e-14);
}

TEST(SE3, RotationAngleSmallAndLarge) {
  for (double a : {1e-9, 1e-4, 0.5, 3.0}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(a, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    EXPECT_NEAR(rotationAngle(R), a, 1e-12) << a;
  }
}

TEST(SE3, ExpLogRoundTrip) {
  Vector6d xi;
  xi << 0.3, -0.2, 1.0, 0.1, -0.4, 0.25;
  const Isometry3d T = expSE3(xi);
  EXPECT_TRUE(logSE3(T).isApprox(xi, 1e-10));
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
}

TEST(SE3, RienetTransformWithinBounds) {
  std::mt19937_64 rng(42);
  for (int i = 0; i < 200; ++i) {
    const Isometry3d T = randomRienetTransform(rng, 45.0, 0.5);
    EXPECT_LE(T.translation().cwiseAbs().maxCoeff(), 0.5);
    // Composition of three rotations of ≤45° each is ≤135°.
    EXPECT_LE(rotationAngle(T.linear()), 135.0 * kDegToRad + 1e-9);
    EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  }
  std::mt19937_64 a(7), b(7);
  EXPECT_TRUE(randomRienetTransform(a).isApprox(randomRienetTransform(b)));
}

TEST(SE3, AxisAngleTransformBounds) {
  std::mt19937_64 rng(1);
  for (int i = 0; i < 200; ++i) {
    const Isometry3d T = randomAxisAngleTransform(rng, 45.0, 0.5);
    EXPECT_LE(rotationAngle(T.linear()), 45.0 * kDegToRad + 1e-12);
    EXPECT_LE(T.translation().norm(), 0.5 + 1e-12);
  }
}

TEST(SE3, OrthonormalizeProjects) {
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Matrix3d Rn = R;
  Rn(0, 1) += 1e-3;
  const Eigen::Matrix3d P = orthonormalize(Rn);
  EXPECT_NEAR(P.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((P.transpose() * P).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_LT((P - R).norm(), 2e-3);
}

TEST(SE3, OrthonormalizeIsTheNearestRotation) {
  // The result must be the SVD projection U·Vᵀ (the nearest rotation in the Frobenius norm) for
  // near-rotations, strongly scaled or skewed matrices, and reflections (det < 0 → det = +1).
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  auto svdProjection = [](const Eigen::Matrix3d& M) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d U = svd.matrixU();
    if ((U * svd.matrixV().transpose()).determinant() < 0) U.col(2) *= -1.0;
    return Eigen::Matrix3d(U * svd.matrixV().transpose());
  };
  for (int k = 0; k < 300; ++k) {
    const Isometry3d T = randomAxisAngleTransform(rng, 180.0, 0.0);
    Eigen::Matrix3d E;
    for (int i = 0; i < 9; ++i) E(i / 3, i % 3) = n(rng);
    const double noise = k < 100 ? 1e-3 : (k < 200 ? 0.3 : 3.0);
    Eigen::Matrix3d M = (k % 7 == 0 ? 0.2 : 1.0) * T.linear() + noise * E;
    if (k % 11 == 0) M.col(0) *= -1.0;  // a reflection
    const Eigen::Matrix3d P = orthonormalize(M);
    EXPECT_NEAR(P.determinant(), 1.0, 1e-12) << k;
    EXPECT_TRUE((P.transpose() * P).isApprox(Eigen::Matrix3d::Identity(), 1e-12)) << k;
    // The nearest rotation is unique unless two singular values (with the sign) coincide.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(M);
    const auto sv = svd.singularValues();
    if (sv(1) - sv(2) > 1e-3 && sv(0) - sv(1) > 1e-3) {
      EXPECT_LT((P - svdProjection(M)).cwiseAbs().maxCoeff(), 1e-10) << k;
    }
  }
  EXPECT_TRUE(orthonormalize(Eigen::Matrix3d::Zero()).isUnitary(1e-12));
}

TEST(SE2, ComposeInverseWrap) {
  const Pose2 a(1.0, 2.0, 3.0), b(-0.5, 0.3, 0.5);
  const Pose2 c = a * b;
  EXPECT_NEAR(c.theta, wrapAngle(3.5), 1e-15);
  EXPECT_GT(c.theta, -M_PI);
  EXPECT_LE(c.theta, M_PI);
  const Pose2 id = a * a.inverse();
  EXPECT_NEAR(id.x, 0, 1e-12);
  EXPECT_NEAR(id.y, 0, 1e-12);
  EXPECT_NEAR(id.theta, 0, 1e-12);
  EXPECT_TRUE((a.matrix() * b.matrix()).isApprox(c.matrix(), 1e-12));
  EXPECT_NEAR(wrapAngle(M_PI), M_PI, 1e-15);
  EXPECT_NEAR(wrapAngle(-M_PI), M_PI, 1e-15);
  EXPECT_NEAR(wrapAngle(7.0), 7.0 - 2 * M_PI, 1e-15);
}
