#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eval_test_utils.hpp"
#include "obm/core/errors.hpp"
#include "obm/eval/kitti_odometry.hpp"

using namespace obm;
using namespace obm::eval;

namespace {

// The devkit rounds nothing; all tolerances below are round-off of double arithmetic on
// coordinates up to ~600 m.
constexpr double kTol = 1e-9;

/// Number of segment starts 0, 10, 20, … on a straight line of n frames, 1 m apart, for which the
/// segment of `len` metres ends inside the trajectory: the end is frame first + len + 1 (the first
/// distance strictly greater than len), so first ≤ n − len − 2.
std::size_t straightLineSegments(std::size_t n, std::size_t len) {
  return (n - len - 2) / 10 + 1;
}

}  // namespace

TEST(KittiOdometry, TrajectoryDistancesAndSegmentEnd) {
  const PoseList line = test::straightLine(6, 2.0);
  const std::vector<double> dist = trajectoryDistances(line);
  ASSERT_EQ(dist.size(), 6u);
  for (std::size_t i = 0; i < dist.size(); ++i) EXPECT_DOUBLE_EQ(dist[i], 2.0 * i);
  // Strictly greater than dist[first] + len: from frame 1 (2 m), 4 m more ends at 8 m < 10 m.
  EXPECT_EQ(lastFrameFromSegmentLength(dist, 1, 4.0), std::optional<std::size_t>(4));
  EXPECT_EQ(lastFrameFromSegmentLength(dist, 1, 3.9), std::optional<std::size_t>(3));
  EXPECT_FALSE(lastFrameFromSegmentLength(dist, 1, 8.0).has_value());
  EXPECT_FALSE(lastFrameFromSegmentLength(dist, 9, 1.0).has_value());
  EXPECT_TRUE(trajectoryDistances({}).empty());
}

TEST(KittiOdometry, StraightLineSegmentsAndSpeed) {
  const std::size_t n = 1000;
  const PoseList gt = test::straightLine(n, 1.0);
  const KittiOdometryResult r = evaluateKittiOdometry(gt, gt);
  std::size_t expected = 0;
  for (std::size_t len = 100; len <= 800; len += 100) expected += straightLineSegments(n, len);
  EXPECT_EQ(r.n_segments, expected);
  ASSERT_EQ(r.per_length.size(), 8u);
  EXPECT_EQ(r.per_length[0].n, straightLineSegments(n, 100));  // 90
  EXPECT_EQ(r.per_length[7].n, straightLineSegments(n, 800));  // 20
  const KittiSegmentError& s0 = r.segments.front();
  EXPECT_EQ(s0.first_frame, 0u);
  EXPECT_EQ(s0.last_frame, 101u);
  EXPECT_DOUBLE_EQ(s0.length, 100.0);
  // 100 m over 102 frames at 10 Hz.
  EXPECT_NEAR(s0.speed, 100.0 / (0.1 * 102.0), 1e-12);
  EXPECT_NEAR(r.t_err_percent, 0.0, kTol);
  EXPECT_NEAR(r.r_err_deg_per_100m, 0.0, 1e-5);  // acos near 1 amplifies round-off to ~1e-8 rad
}

TEST(KittiOdometry, StraightLineScaleDriftHandComputed) {
  // Each estimated step is 1.01 m instead of 1 m: a segment of nominal length L spans L + 1 true
  // metres, so its translation error is 0.01 · (L + 1) and t_err = (L + 1) / L percent.
  const PoseList gt = test::straightLine(1000, 1.0);
  const PoseList pred = test::straightLine(1000, 1.01);
  const KittiOdometryResult r = evaluateKittiOdometry(gt, pred);
  double weighted = 0.0;
  std::size_t count = 0;
  for (const KittiLengthStats& l : r.per_length) {
    EXPECT_NEAR(l.t_err_percent, (l.length + 1.0) / l.length, 1e-9) << l.length;
    EXPECT_NEAR(l.r_err_deg_per_100m, 0.0, 1e-5);
    weighted += l.n * (l.length + 1.0) / l.length;
    count += l.n;
  }
  EXPECT_NEAR(r.t_err_percent, weighted / count, 1e-9);
}

TEST(KittiOdometry, PoolsSegmentsOfSeveralSequences) {
  // The devkit averages over all segments of all sequences: a perfect and a 1 %-drifting copy of
  // the same trajectory pool to half the drifting one's error.
  const PoseList gt = test::straightLine(500, 1.0);
  std::vector<KittiSegmentError> all = kittiSegmentErrors(gt, gt);
  const std::vector<KittiSegmentError> drift =
      kittiSegmentErrors(gt, test::straightLine(500, 1.01));
  const double drift_t = summarizeKittiSegments(drift).t_err_percent;
  all.insert(all.end(), drift.begin(), drift.end());
  const KittiOdometryResult pooled = summarizeKittiSegments(all);
  EXPECT_EQ(pooled.n_segments, 2 * drift.size());
  EXPECT_NEAR(pooled.t_err_percent, 0.5 * drift_t, 1e-9);
  EXPECT_GT(drift_t, 1.0);
  // Lengths never reached keep a count of zero and NaN averages.
  EXPECT_EQ(pooled.per_length.back().n, 0u);
  EXPECT_TRUE(std::isnan(pooled.per_length.back().t_err_percent));
}

TEST(KittiOdometry, RejectsMismatchedTrajectories) {
  const PoseList gt = test::straightLine(300, 1.0);
  EXPECT_THROW(evaluateKittiOdometry(gt, test::straightLine(299, 1.0)), ContractError);
  KittiOdometryParams bad;
  bad.step_size = 0;
  EXPECT_THROW(evaluateKittiOdometry(gt, gt, bad), ContractError);
  const KittiOdometryResult empty =
      evaluateKittiOdometry(test::straightLine(50, 1.0), test::straightLine(50, 1.0));
  EXPECT_EQ(empty.n_segments, 0u);
  EXPECT_TRUE(std::isnan(empty.t_err_percent));
}

class KittiOdometryOnSequence00 : public ::testing::Test {
 protected:
  void SetUp() override {
    OBM_REQUIRE_SHARED_DATA("kitti/poses/00.txt");
    gt_ = test::readKittiPoses(test::kitti00PosesPath());
    ASSERT_EQ(gt_.size(), 4541u);
  }
  PoseList gt_;
};

TEST_F(KittiOdometryOnSequence00, IdenticalTrajectoryHasZeroError) {
  const KittiOdometryResult r = evaluateKittiOdometry(gt_, gt_);
  EXPECT_GT(r.n_segments, 2000u);  // 455 starts × 8 lengths, minus those running off the end
  EXPECT_NEAR(r.t_err_percent, 0.0, kTol);
  EXPECT_NEAR(r.r_err_deg_per_100m, 0.0, 1e-5);
}

TEST_F(KittiOdometryOnSequence00, OnePercentScaleDriftGivesOnePercentOfTheChord) {
  // Integrating the true increments with 1.01× translations makes every segment's estimated
  // motion (R_Δgt, 1.01·t_Δgt), so the residual translation is exactly 1 % of the ground-truth
  // chord ‖t_last − t_first‖. The metric divides by the path length, hence t_err = 1 % · chord /
  // len: ≈ 1 % on straight stretches (see StraightLineScaleDriftHandComputed), less where a
  // segment turns a corner — which the long segments of sequence 00's street grid mostly do.
  const PoseList pred = test::scaleDrift(gt_, 1.01);
  const KittiOdometryResult r = evaluateKittiOdometry(gt_, pred);
  const std::vector<double> dist = trajectoryDistances(gt_);
  double expected = 0.0;
  for (const KittiSegmentError& s : r.segments) {
    const double chord =
        (gt_[s.last_frame].translation() - gt_[s.first_frame].translation()).norm();
    ASSERT_NEAR(s.t_err * s.length, 0.01 * chord, 1e-9) << s.first_frame << " " << s.length;
    // A chord never exceeds the travelled distance, which overshoots len by < one frame step.
    ASSERT_LE(chord, dist[s.last_frame] - dist[s.first_frame] + 1e-9);
    expected += chord / s.length;
  }
  // In percent: 100 · mean(0.01 · chord / len) = mean(chord / len).
  const double expected_percent = 100.0 * 0.01 * expected / static_cast<double>(r.n_segments);
  EXPECT_NEAR(r.t_err_percent, expected_percent, 1e-9);
  EXPECT_LE(r.t_err_percent, 1.02);
  EXPECT_GT(r.t_err_percent, 0.0);
  for (const KittiLengthStats& l : r.per_length) EXPECT_LE(l.t_err_percent, 1.02) << l.length;
  EXPECT_NEAR(r.r_err_deg_per_100m, 0.0, 1e-3);
}

TEST_F(KittiOdometryOnSequence00, ConstantYawRateGivesPredictableRotationError) {
  // pred_i = Ry(ω·i) · gt_i (y is the vertical axis of KITTI's camera frame): the residual of a
  // segment rotates by exactly ω · (last − first), so r_err = ω · frames / length.
  const double omega_deg = 0.01;  // [deg/frame]
  const PoseList pred = test::worldYawDrift(gt_, omega_deg * kDegToRad, Eigen::Vector3d::UnitY());
  const KittiOdometryResult r = evaluateKittiOdometry(gt_, pred);
  double expected = 0.0;
  for (const KittiSegmentError& s : r.segments) {
    const double frames = static_cast<double>(s.last_frame - s.first_frame);
    ASSERT_NEAR(s.r_err * s.length * kRadToDeg, omega_deg * frames, 1e-6) << s.first_frame;
    expected += omega_deg * frames / s.length * 100.0;
  }
  expected /= static_cast<double>(r.n_segments);
  EXPECT_NEAR(r.r_err_deg_per_100m, expected, 1e-6);
  // Coarse cross-check from the sequence's mean frame spacing: 4540 frames over its length.
  const double metres_per_frame = trajectoryDistances(gt_).back() / 4540.0;
  EXPECT_NEAR(r.r_err_deg_per_100m, omega_deg * 100.0 / metres_per_frame,
              0.15 * omega_deg * 100.0 / metres_per_frame);
}

TEST_F(KittiOdometryOnSequence00, InvariantToGlobalTransformOfTheEstimate) {
  // A noisy estimate (random-walk odometry noise) and the same estimate moved by a global rigid
  // transform G: every segment compares P_first⁻¹·P_last, from which G cancels.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n_t(0.0, 0.02), n_r(0.0, 0.05 * kDegToRad);
  PoseList pred{gt_.front()};
  for (std::size_t i = 1; i < gt_.size(); ++i) {
    Vector6d xi;
    xi << n_t(rng), n_t(rng), n_t(rng), n_r(rng), n_r(rng), n_r(rng);
    pred.push_back(pred.back() * relative(gt_[i - 1], gt_[i]) * expSE3(xi));
  }
  const Isometry3d G = randomRienetTransform(rng, 90.0, 500.0);
  PoseList moved;
  for (const Isometry3d& P : pred) moved.push_back(G * P);

  const KittiOdometryResult a = evaluateKittiOdometry(gt_, pred);
  const KittiOdometryResult b = evaluateKittiOdometry(gt_, moved);
  ASSERT_EQ(a.n_segments, b.n_segments);
  EXPECT_GT(a.t_err_percent, 0.1);                      // the noise is visible …
  EXPECT_NEAR(a.t_err_percent, b.t_err_percent, 1e-7);  // … and G is not
  EXPECT_NEAR(a.r_err_deg_per_100m, b.r_err_deg_per_100m, 1e-6);
  for (std::size_t k = 0; k < a.per_length.size(); ++k)
    EXPECT_NEAR(a.per_length[k].t_err_percent, b.per_length[k].t_err_percent, 1e-7);
}
