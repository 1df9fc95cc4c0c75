#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "obm/core/se3.hpp"
#include "obm/eval/registration_metrics.hpp"
#include "obm/eval/statistics.hpp"

using namespace obm;
using namespace obm::eval;

namespace {

Isometry3d rotationAbout(const Eigen::Vector3d& axis, double angle_rad,
                         const Eigen::Vector3d& t = Eigen::Vector3d::Zero()) {
  return makeIsometry(Eigen::Matrix3d(Eigen::AngleAxisd(angle_rad, axis.normalized())), t);
}

}  // namespace

TEST(RegistrationMetrics, SingleAxisRotationAboutZ) {
  // pred = Rz(θ), gt = I: zyx Euler angles differ by (θ, 0, 0), so MAE(R) = θ/3, RMSE(R) = θ/√3,
  // while the isotropic error is θ itself.
  const double theta_deg = 12.5;
  const PairErrors e = pairErrors(rotationAbout(Eigen::Vector3d::UnitZ(), theta_deg * kDegToRad),
                                  Isometry3d::Identity());
  EXPECT_NEAR(e.euler_abs_deg[0], theta_deg, 1e-10);
  EXPECT_NEAR(e.euler_abs_deg[1], 0.0, 1e-10);
  EXPECT_NEAR(e.euler_abs_deg[2], 0.0, 1e-10);
  EXPECT_NEAR(e.rre_deg, theta_deg, 1e-9);
  EXPECT_DOUBLE_EQ(e.rte, 0.0);

  RegistrationAccumulator acc;
  acc.add(rotationAbout(Eigen::Vector3d::UnitZ(), theta_deg * kDegToRad), Isometry3d::Identity());
  const RegistrationSummary s = acc.summary();
  EXPECT_EQ(s.n, 1u);
  EXPECT_NEAR(s.mae_r, theta_deg / 3.0, 1e-10);
  EXPECT_NEAR(s.rmse_r, theta_deg / std::sqrt(3.0), 1e-10);
  EXPECT_NEAR(s.mie_r, theta_deg, 1e-9);
  EXPECT_DOUBLE_EQ(s.mae_t, 0.0);
  EXPECT_DOUBLE_EQ(s.mie_t, 0.0);
}

TEST(RegistrationMetrics, SingleAxisRotationAboutXOnTopOfGroundTruth) {
  // gt = Rx(a), pred = Rx(a + θ): only the x angle (third of zyx) differs, by θ.
  const double a = 20.0 * kDegToRad, theta = 7.0 * kDegToRad;
  const PairErrors e = pairErrors(rotationAbout(Eigen::Vector3d::UnitX(), a + theta),
                                  rotationAbout(Eigen::Vector3d::UnitX(), a));
  EXPECT_NEAR(e.euler_abs_deg[0], 0.0, 1e-10);
  EXPECT_NEAR(e.euler_abs_deg[1], 0.0, 1e-10);
  EXPECT_NEAR(e.euler_abs_deg[2], 7.0, 1e-10);
  EXPECT_NEAR(e.rre_deg, 7.0, 1e-9);
}

TEST(RegistrationMetrics, IsotropicErrorIsTheResidualAngleAboutAnyAxis) {
  // pred = gt · Rot(axis, α) and pred = Rot(axis, α) · gt both leave a residual rotation of α.
  std::mt19937_64 rng(11);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.8, 0.5).normalized();
  for (double alpha_deg : {0.5, 3.0, 30.0, 120.0, 179.0}) {
    const Isometry3d T_gt = randomRienetTransform(rng);
    const Isometry3d D = rotationAbout(axis, alpha_deg * kDegToRad);
    EXPECT_NEAR(pairErrors(T_gt * D, T_gt).rre_deg, alpha_deg, 1e-6) << alpha_deg;
    EXPECT_NEAR(pairErrors(D * T_gt, T_gt).rre_deg, alpha_deg, 1e-6) << alpha_deg;
  }
}

TEST(RegistrationMetrics, TranslationErrors) {
  const Eigen::Vector3d t_gt(1.0, 2.0, 3.0), d(0.3, -0.4, 1.2);
  RegistrationAccumulator acc;
  acc.add(makeIsometry(Eigen::Matrix3d::Identity(), t_gt + d),
          makeIsometry(Eigen::Matrix3d::Identity(), t_gt));
  const RegistrationSummary s = acc.summary();
  EXPECT_NEAR(s.mae_t, (0.3 + 0.4 + 1.2) / 3.0, 1e-12);
  EXPECT_NEAR(s.rmse_t, std::sqrt((0.09 + 0.16 + 1.44) / 3.0), 1e-12);
  EXPECT_NEAR(s.mie_t, 1.3, 1e-12);  // ‖(0.3, −0.4, 1.2)‖ = 1.3
  EXPECT_NEAR(s.mae_r, 0.0, 1e-12);
  EXPECT_NEAR(s.mie_r, 0.0, 1e-6);
}

TEST(RegistrationMetrics, EulerDifferenceIsNotWrappedAsInTheReference) {
  // Rz(179°) vs Rz(−179°): RIENet subtracts the scipy angles directly → 358° on z, whereas the
  // isotropic error is the true 2°.
  const PairErrors e = pairErrors(rotationAbout(Eigen::Vector3d::UnitZ(), -179.0 * kDegToRad),
                                  rotationAbout(Eigen::Vector3d::UnitZ(), 179.0 * kDegToRad));
  EXPECT_NEAR(e.euler_abs_deg[0], 358.0, 1e-9);
  EXPECT_NEAR(e.rre_deg, 2.0, 1e-6);
}

TEST(RegistrationMetrics, AggregatesAreMeansOverPairsAndAngles) {
  // Pair 1: z error 6°; pair 2: y error 3° and translation error (0, 0, 2).
  RegistrationAccumulator acc;
  acc.add(rotationAbout(Eigen::Vector3d::UnitZ(), 6.0 * kDegToRad), Isometry3d::Identity(), 4.0);
  acc.add(rotationAbout(Eigen::Vector3d::UnitY(), 3.0 * kDegToRad, Eigen::Vector3d(0, 0, 2)),
          Isometry3d::Identity(), 2.0);
  const RegistrationSummary s = acc.summary();
  EXPECT_EQ(s.n, 2u);
  EXPECT_NEAR(s.mae_r, (6.0 + 3.0) / 6.0, 1e-10);
  EXPECT_NEAR(s.rmse_r, std::sqrt((36.0 + 9.0) / 6.0), 1e-10);
  EXPECT_NEAR(s.mie_r, 4.5, 1e-9);
  EXPECT_NEAR(s.mae_t, 2.0 / 6.0, 1e-12);
  EXPECT_NEAR(s.mie_t, 1.0, 1e-12);
  EXPECT_NEAR(s.rmse_rre_deg, std::sqrt((36.0 + 9.0) / 2.0), 1e-9);
  EXPECT_NEAR(s.rmse_rte, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s.median_rre_deg, 4.5, 1e-9);
  EXPECT_NEAR(s.median_rte, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.mean_ms, 3.0);
  EXPECT_DOUBLE_EQ(s.median_ms, 3.0);
  ASSERT_EQ(acc.pairs().size(), 2u);
  EXPECT_NEAR(acc.pairs()[1].euler_abs_deg[1], 3.0, 1e-10);
}

TEST(RegistrationMetrics, RecallUsesBothStrictThresholds) {
  RegistrationAccumulator acc(RecallThresholds::kitti());
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  acc.add(rotationAbout(z, 4.0 * kDegToRad, Eigen::Vector3d(1.9, 0, 0)), Isometry3d::Identity());
  acc.add(rotationAbout(z, 1.0 * kDegToRad, Eigen::Vector3d(0.5, 0, 0)), Isometry3d::Identity());
  acc.add(rotationAbout(z, 6.0 * kDegToRad, Eigen::Vector3d(0.1, 0, 0)), Isometry3d::Identity());
  acc.add(rotationAbout(z, 1.0 * kDegToRad, Eigen::Vector3d(0, 2.5, 0)), Isometry3d::Identity());
  const RegistrationSummary s = acc.summary();
  EXPECT_DOUBLE_EQ(s.recall, 0.5);
  EXPECT_NEAR(s.rre_success_deg, 2.5, 1e-9);
  EXPECT_NEAR(s.rte_success, 1.2, 1e-12);

  RegistrationAccumulator loose(RecallThresholds{10.0, 3.0});
  loose.add(rotationAbout(z, 6.0 * kDegToRad, Eigen::Vector3d(0.1, 0, 0)), Isometry3d::Identity());
  EXPECT_DOUBLE_EQ(loose.summary().recall, 1.0);
}

TEST(RegistrationMetrics, MedianRuntimeAndEmptySummary) {
  RegistrationAccumulator acc;
  EXPECT_TRUE(std::isnan(acc.summary().mae_r));
  EXPECT_TRUE(std::isnan(acc.summary().recall));
  EXPECT_EQ(acc.summary().n, 0u);
  for (double ms : {1.0, 5.0, 3.0}) acc.add(Isometry3d::Identity(), Isometry3d::Identity(), ms);
  EXPECT_DOUBLE_EQ(acc.summary().median_ms, 3.0);
  acc.add(Isometry3d::Identity(), Isometry3d::Identity(), 10.0);
  EXPECT_DOUBLE_EQ(acc.summary().median_ms, 4.0);  // numpy: mean of the two middle values
  EXPECT_DOUBLE_EQ(acc.summary().mean_ms, 19.0 / 4.0);
  EXPECT_DOUBLE_EQ(acc.summary().recall, 1.0);
  acc.clear();
  EXPECT_EQ(acc.size(), 0u);
}

TEST(Statistics, NumpySemantics) {
  EXPECT_DOUBLE_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);
  EXPECT_DOUBLE_EQ(median({7.0}), 7.0);
  EXPECT_DOUBLE_EQ(mean({1.0, 2.0, 6.0}), 3.0);
  EXPECT_DOUBLE_EQ(rootMeanSquare({3.0, 4.0}), std::sqrt(12.5));
  EXPECT_TRUE(std::isnan(median({})));
}
