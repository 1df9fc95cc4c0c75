#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/core/ransac_pose.hpp"

using namespace obm;

namespace {

constexpr double kPi = 3.14159265358979323846;

Isometry3d yawPose(double yaw, const Eigen::Vector3d& t) {
  return makeIsometry(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(), t);
}

/// `n` source points in a 40 m box; the first `n_true` pairs are T·s exactly, the rest random
/// targets (wrong matches).
void makePairs(const Isometry3d& T, std::size_t n, std::size_t n_true, std::uint64_t seed,
               std::vector<Eigen::Vector3d>& src, std::vector<Eigen::Vector3d>& tgt) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  src.clear();
  tgt.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d s(u(rng), u(rng), 0.1 * u(rng));
    src.push_back(s);
    tgt.push_back(i < n_true ? Eigen::Vector3d(T * s)
                             : Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng)));
  }
}

double angleBetween(const Isometry3d& a, const Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

}  // namespace

TEST(RansacPose, PlanarPoseFromSeventyPercentWrongPairs) {
  const Isometry3d T = yawPose(0.6, {3.0, -2.0, 0.5});
  std::vector<Eigen::Vector3d> s, t;
  makePairs(T, 300, 90, 1, s, t);
  RansacPoseParams p;
  p.inlier_threshold = 0.2;
  p.iterations = 2000;
  const auto r = ransacPose(s, t, p);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.inliers, 90u);  // every true pair, none of the random ones (40 m box, 0.2 m gate)
  EXPECT_LT(angleBetween(r.T_target_source, T), 1e-9);
  EXPECT_LT((r.T_target_source.translation() - T.translation()).norm(), 1e-9);
  // The weighted SVD's counterpart, least squares over every pair, is far off on the same pairs.
  std::vector<std::size_t> all(s.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  EXPECT_GT((fitRigidPose(s, t, all, true).translation() - T.translation()).norm(), 0.5);
}

TEST(RansacPose, FullRotationFromHalfWrongPairs) {
  const Isometry3d T = makeIsometry(
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, -1.0).normalized()).toRotationMatrix(),
      Eigen::Vector3d(-1.0, 0.5, 2.0));
  std::vector<Eigen::Vector3d> s, t;
  makePairs(T, 200, 100, 2, s, t);
  RansacPoseParams p;
  p.planar = false;
  p.inlier_threshold = 0.2;
  const auto r = ransacPose(s, t, p);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.inliers, 100u);
  EXPECT_LT(angleBetween(r.T_target_source, T), 1e-9);
  // A planar search cannot express the tilt: it finds no pose with the true pairs' consensus.
  p.planar = true;
  EXPECT_LT(ransacPose(s, t, p).inliers, 50u);
}

TEST(RansacPose, GroupsCountEachSourcePointOnce) {
  // Each source point brings three candidate targets; the true one is among them for 60 of the
  // 200 points. Without groups a wrong pose that many candidates of one point agree with could
  // win; with them the consensus is a count of source points.
  const Isometry3d T = yawPose(-0.3, {1.0, 4.0, 0.0});
  std::vector<Eigen::Vector3d> s0, t0;
  makePairs(T, 200, 60, 3, s0, t0);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  RansacPoseParams p;
  p.inlier_threshold = 0.2;
  p.iterations = 20000;
  std::vector<Eigen::Vector3d> s, t;
  for (std::size_t i = 0; i < s0.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      s.push_back(s0[i]);
      // The true (or first random) target first, then two more random ones.
      t.push_back(c == 0 ? t0[i] : Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng)));
      p.group.push_back(i);
    }
  const auto r = ransacPose(s, t, p);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.inliers, 60u);
  EXPECT_LT(angleBetween(r.T_target_source, T), 1e-9);
  p.group.pop_back();
  EXPECT_THROW(ransacPose(s, t, p), ContractError);
}

TEST(RansacPose, HeadingSectorExcludesPosesTurnedFurther) {
  const Isometry3d T = yawPose(2.0, {0.0, 0.0, 0.0});  // 115°
  std::vector<Eigen::Vector3d> s, t;
  makePairs(T, 100, 80, 5, s, t);
  RansacPoseParams p;
  p.inlier_threshold = 0.2;
  EXPECT_EQ(ransacPose(s, t, p).inliers, 80u);
  p.max_yaw = kPi / 4.0;
  const auto r = ransacPose(s, t, p);
  EXPECT_LT(r.inliers, 10u);
  if (r.ok)
    EXPECT_LE(std::abs(std::atan2(r.T_target_source.linear()(1, 0), r.T_target_source.linear()(0, 0))),
              kPi / 4.0 + 1e-9);
}

TEST(RansacPose, BadInput) {
  std::vector<Eigen::Vector3d> s(5, Eigen::Vector3d::Zero()), t(4, Eigen::Vector3d::Zero());
  RansacPoseParams p;
  EXPECT_THROW(ransacPose(s, t, p), ContractError);
  t.resize(5);
  EXPECT_THROW(ransacPose(s, t, p, std::vector<double>(3, 1.0)), ContractError);
  p.inlier_threshold = 0.0;
  EXPECT_THROW(ransacPose(s, t, p), ContractError);
  p.inlier_threshold = 0.1;
  // Coincident points fix no pose: no sample is scored.
  EXPECT_FALSE(ransacPose(s, t, p).ok);
  s.resize(1);
  t.resize(1);
  EXPECT_FALSE(ransacPose(s, t, p).ok);
}
