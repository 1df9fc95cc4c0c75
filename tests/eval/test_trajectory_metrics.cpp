#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eval_test_utils.hpp"
#include "obm/core/errors.hpp"
#include "obm/eval/trajectory_metrics.hpp"

using namespace obm;
using namespace obm::eval;

namespace {

Eigen::Matrix3Xd randomPoints(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

PoseList transformed(const PoseList& poses, const Similarity3& S) {
  PoseList out;
  for (const Isometry3d& T : poses) out.push_back(S * T);
  return out;
}

/// Four poses at the corners (±1, ±1, 0) of a square, identity orientation.
PoseList square(double half_side) {
  PoseList out;
  for (const auto& [x, y] : {std::pair{1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}, {1.0, -1.0}})
    out.push_back(makeIsometry(Eigen::Matrix3d::Identity(),
                               Eigen::Vector3d(half_side * x, half_side * y, 0.0)));
  return out;
}

}  // namespace

TEST(Umeyama, RecoversKnownRigidTransformExactly) {
  std::mt19937_64 rng(5);
  const Eigen::Matrix3Xd src = randomPoints(rng, 20);
  const Isometry3d T = randomRienetTransform(rng, 90.0, 10.0);
  const Eigen::Matrix3Xd dst = (T.linear() * src).colwise() + T.translation();
  const Similarity3 S = umeyamaAlignment(src, dst, false);
  EXPECT_TRUE(S.R.isApprox(T.linear(), 1e-12));
  EXPECT_TRUE(S.t.isApprox(T.translation(), 1e-12));
  EXPECT_DOUBLE_EQ(S.s, 1.0);
}

TEST(Umeyama, RecoversKnownSimilarityExactly) {
  std::mt19937_64 rng(6);
  const Eigen::Matrix3Xd src = randomPoints(rng, 10);
  const Isometry3d T = randomRienetTransform(rng, 90.0, 10.0);
  const double s = 2.5;
  const Eigen::Matrix3Xd dst = (s * T.linear() * src).colwise() + T.translation();
  const Similarity3 S = umeyamaAlignment(src, dst, true);
  EXPECT_NEAR(S.s, s, 1e-12);
  EXPECT_TRUE(S.R.isApprox(T.linear(), 1e-12));
  EXPECT_TRUE(S.t.isApprox(T.translation(), 1e-11));
}

TEST(Umeyama, PlanarAndMirroredInputsGiveProperRotations) {
  // A planar point set (rank-2 covariance) rotated about z is recovered; a mirrored copy cannot be
  // matched by a rotation, and the result must still be one (det = +1, Umeyama's S correction).
  Eigen::Matrix3Xd src(3, 4);
  src << 1, -1, -1, 1, 1, 1, -1, -1, 0, 0, 0, 0;
  src.row(0) *= 2.0;  // a rectangle, so the in-plane rotation is unique
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(umeyamaAlignment(src, Rz * src, false).R.isApprox(Rz, 1e-12));
  std::mt19937_64 rng(8);
  const Eigen::Matrix3Xd src3 = randomPoints(rng, 12);
  Eigen::Matrix3Xd mirrored = src3;
  mirrored.row(0) *= -1.0;
  const Similarity3 S = umeyamaAlignment(src3, mirrored, false);
  EXPECT_NEAR(S.R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((S.R.transpose() * S.R).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
}

TEST(Umeyama, RejectsBadInput) {
  EXPECT_THROW(umeyamaAlignment(Eigen::Matrix3Xd::Zero(3, 4), Eigen::Matrix3Xd::Zero(3, 5), false),
               ContractError);
  EXPECT_THROW(umeyamaAlignment(Eigen::Matrix3Xd::Zero(3, 2), Eigen::Matrix3Xd::Zero(3, 2), false),
               ContractError);
  EXPECT_THROW(umeyamaAlignment(Eigen::Matrix3Xd::Ones(3, 4), Eigen::Matrix3Xd::Ones(3, 4), true),
               ContractError);
}

TEST(Ate, RigidlyTransformedTrajectoryHasZeroErrorAfterAlignment) {
  std::mt19937_64 rng(9);
  const PoseList gt = test::worldYawDrift(test::straightLine(50, 0.5), 0.05,
                                          Eigen::Vector3d(0.2, 1.0, 0.1).normalized());
  Similarity3 G;
  const Isometry3d T = randomRienetTransform(rng, 60.0, 20.0);
  G.R = T.linear();
  G.t = T.translation();
  const PoseList est = transformed(gt, G);
  const AteResult r = absoluteTrajectoryError(gt, est, Alignment::SE3);
  EXPECT_NEAR(r.rmse, 0.0, 1e-10);
  EXPECT_NEAR(r.max, 0.0, 1e-10);
  EXPECT_TRUE(r.alignment.R.isApprox(G.R.transpose(), 1e-10));
  EXPECT_GT(absoluteTrajectoryError(gt, est, Alignment::None).rmse, 1.0);
}

TEST(Ate, ConstantOffsetWithoutAlignmentIsItsNorm) {
  // Every position displaced by d = (3, 4, 12) → each error is ‖d‖ = 13; alignment removes it.
  const PoseList gt = square(1.0);
  Similarity3 shift;
  shift.t = Eigen::Vector3d(3, 4, 12);
  const PoseList est = transformed(gt, shift);
  const AteResult none = absoluteTrajectoryError(gt, est, Alignment::None);
  EXPECT_NEAR(none.rmse, 13.0, 1e-12);
  EXPECT_NEAR(none.mean, 13.0, 1e-12);
  EXPECT_NEAR(none.median, 13.0, 1e-12);
  EXPECT_NEAR(absoluteTrajectoryError(gt, est, Alignment::SE3).rmse, 0.0, 1e-12);
}

TEST(Ate, ScaledSquareKnownErrorRigidZeroWithScale) {
  // Estimate = square of half side 1 + ε around the same centre. By symmetry the rigid
  // alignment is the identity, leaving ε·√2 at every corner; a Sim(3) alignment removes it.
  const double eps = 0.1;
  const PoseList gt = square(1.0), est = square(1.0 + eps);
  const AteResult se3 = absoluteTrajectoryError(gt, est, Alignment::SE3);
  EXPECT_NEAR(se3.rmse, eps * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(se3.max, eps * std::sqrt(2.0), 1e-12);
  EXPECT_TRUE(se3.alignment.R.isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  const AteResult sim3 = absoluteTrajectoryError(gt, est, Alignment::Sim3);
  EXPECT_NEAR(sim3.rmse, 0.0, 1e-12);
  EXPECT_NEAR(sim3.alignment.s, 1.0 / (1.0 + eps), 1e-12);
}

TEST(Ate, RejectsMismatchedOrShortTrajectories) {
  EXPECT_THROW(absoluteTrajectoryError(square(1.0), test::straightLine(5, 1.0)), ContractError);
  EXPECT_THROW(absoluteTrajectoryError(test::straightLine(2, 1.0), test::straightLine(2, 1.0)),
               ContractError);
  EXPECT_THROW(relativePoseError(test::straightLine(4, 1.0), test::straightLine(5, 1.0)),
               ContractError);
  EXPECT_THROW(relativePoseError(test::straightLine(2, 1.0), test::straightLine(2, 1.0)),
               ContractError);
}

TEST(Rpe, ScaleDriftOnStraightLine) {
  // Steps of 1.01 m instead of 1 m: a pair δ frames apart is off by 0.01·δ m, rotation 0.
  const PoseList gt = test::straightLine(200, 1.0), est = test::straightLine(200, 1.01);
  const RpeResult d1 = relativePoseError(gt, est);
  EXPECT_EQ(d1.n_pairs, 199u);
  EXPECT_NEAR(d1.trans_rmse, 0.01, 1e-10);
  EXPECT_NEAR(d1.trans_mean, 0.01, 1e-10);
  EXPECT_NEAR(d1.rot_mean_deg, 0.0, 1e-9);
  const RpeResult d5 = relativePoseError(gt, est, {5.0, DeltaUnit::Frames, 1});
  EXPECT_EQ(d5.n_pairs, 195u);
  EXPECT_NEAR(d5.trans_rmse, 0.05, 1e-10);
  // Distance delta of 10 m: the pair ends at the first frame beyond 10 m, 11 frames later.
  const RpeResult m10 = relativePoseError(gt, est, {10.0, DeltaUnit::Meters, 1});
  EXPECT_EQ(m10.pairs.front(), std::make_pair(std::size_t{0}, std::size_t{11}));
  EXPECT_EQ(m10.n_pairs, 200u - 11u);
  EXPECT_NEAR(m10.trans_rmse, 0.11, 1e-10);
  // A pair every 10 frames: starts 0, 10, …, 190 → 20 pairs.
  EXPECT_EQ(relativePoseError(gt, est, {1.0, DeltaUnit::Frames, 10}).n_pairs, 20u);
  EXPECT_EQ(relativePoseError(gt, est, {500.0, DeltaUnit::Frames, 1}).n_pairs, 0u);
  EXPECT_THROW(relativePoseError(gt, est, {1.5, DeltaUnit::Frames, 1}), ContractError);
  EXPECT_THROW(relativePoseError(gt, est, {0.0, DeltaUnit::Meters, 1}), ContractError);
  EXPECT_THROW(relativePoseError(gt, est, {1.0, DeltaUnit::Frames, 0}), ContractError);
}

TEST(Rpe, RotationErrorOfAConstantRotationRate) {
  // pred_i = Rz(ω·i)·gt_i: the residual of a pair δ frames apart rotates by ω·δ.
  const double omega = 0.2 * kDegToRad;
  const PoseList gt = test::straightLine(100, 0.7);
  const PoseList est = test::worldYawDrift(gt, omega, Eigen::Vector3d::UnitZ());
  const RpeResult r = relativePoseError(gt, est, {3.0, DeltaUnit::Frames, 1});
  EXPECT_NEAR(r.rot_mean_deg, 0.6, 1e-9);
  EXPECT_NEAR(r.rot_rmse_deg, 0.6, 1e-9);
}

class TrajectoryMetricsOnKitti00 : public ::testing::Test {
 protected:
  void SetUp() override {
    OBM_REQUIRE_SHARED_DATA("kitti/poses/00.txt");
    gt_ = test::readKittiPoses(test::kitti00PosesPath());
    ASSERT_EQ(gt_.size(), 4541u);
  }
  PoseList gt_;
};

TEST_F(TrajectoryMetricsOnKitti00, AteZeroForRigidAndSimilarCopies) {
  std::mt19937_64 rng(21);
  const Isometry3d T = randomRienetTransform(rng, 90.0, 100.0);
  Similarity3 G;
  G.R = T.linear();
  G.t = T.translation();
  EXPECT_NEAR(absoluteTrajectoryError(gt_, transformed(gt_, G), Alignment::SE3).rmse, 0.0, 1e-8);
  G.s = 0.8;
  const AteResult sim = absoluteTrajectoryError(gt_, transformed(gt_, G), Alignment::Sim3);
  EXPECT_NEAR(sim.rmse, 0.0, 1e-8);
  EXPECT_NEAR(sim.alignment.s, 1.0 / 0.8, 1e-10);
  EXPECT_GT(absoluteTrajectoryError(gt_, transformed(gt_, G), Alignment::SE3).rmse, 1.0);
}

TEST_F(TrajectoryMetricsOnKitti00, AteOfIsotropicPositionNoise) {
  // Independent N(0, σ²) noise per axis: the aligned error per pose has E‖e‖² ≈ 3σ², so the ATE
  // RMSE is ≈ √3·σ (the 6 alignment parameters absorb a negligible share of 4541 poses).
  std::mt19937_64 rng(4);
  const double sigma = 0.1;
  std::normal_distribution<double> n(0.0, sigma);
  PoseList est = gt_;
  for (Isometry3d& T : est) T.translation() += Eigen::Vector3d(n(rng), n(rng), n(rng));
  const AteResult r = absoluteTrajectoryError(gt_, est, Alignment::SE3);
  EXPECT_NEAR(r.rmse, std::sqrt(3.0) * sigma, 0.05 * std::sqrt(3.0) * sigma);
}

TEST_F(TrajectoryMetricsOnKitti00, RpeInvariantToGlobalTransformAndSeesScaleDrift) {
  const PoseList est = test::scaleDrift(gt_, 1.01);
  const RpeResult a = relativePoseError(gt_, est, {100.0, DeltaUnit::Meters, 10});
  std::mt19937_64 rng(2);
  const Isometry3d T = randomRienetTransform(rng, 90.0, 100.0);
  Similarity3 G;
  G.R = T.linear();
  G.t = T.translation();
  const RpeResult b = relativePoseError(gt_, transformed(est, G), {100.0, DeltaUnit::Meters, 10});
  ASSERT_EQ(a.n_pairs, b.n_pairs);
  EXPECT_NEAR(a.trans_rmse, b.trans_rmse, 1e-8);
  EXPECT_NEAR(a.rot_mean_deg, b.rot_mean_deg, 1e-6);
  // 1 % of the chord of ≈ 100 m segments: just under 1 m.
  EXPECT_NEAR(a.trans_rmse, 1.0, 0.1);
}
