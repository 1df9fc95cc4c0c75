// The correlative search over heading and translation (registration::correlativeSearch): a start
// for pairs turned about a known axis by more than ICP's basin, from two independent samplings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"

namespace obm {
namespace {

/// The room of scenes.hpp (z up) seen from a sensor turned by 55° about z and moved 0.7 m: the
/// target and the source are two independent samplings (no shared point), the source keeps only
/// what lies in front of its sensor (x > 0 in its own frame) and carries 5 mm noise.
/// With `pitch_deg`, both sensors look down by that much (turned about their own x), so the
/// turn about the room's vertical is not a turn about their z.
struct TurnedRoomPair {
  Isometry3d T_target_source;
  PointCloud target, source;
  explicit TurnedRoomPair(double pitch_deg = 0.0) {
    const Isometry3d G_world_target = makeIsometry(
        Eigen::AngleAxisd(pitch_deg * kDegToRad, Eigen::Vector3d::UnitX()).toRotationMatrix(),
        Eigen::Vector3d::Zero());
    const Isometry3d G_world_source =
        makeIsometry(
            Eigen::AngleAxisd(55.0 * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
            Eigen::Vector3d(0.6, -0.4, 0.1)) *
        G_world_target;
    T_target_source = G_world_target.inverse() * G_world_source;
    target = test::roomScene(60.0, 1).transformed(G_world_target.inverse(), "target");
    const PointCloud other =
        test::roomScene(60.0, 2).transformed(G_world_target.inverse(), "target");
    PointCloud whole = test::makeSource(other, T_target_source, 1.0, 0.005, 3);
    for (const auto& p : whole.points)
      if (p.x() > 0.f) source.push_back(p);
    source.frame_id = "source";
  }
};

registration::CorrelativeSearchParams roomSearch() {
  registration::CorrelativeSearchParams p;
  p.axis = "z";
  p.heading_range_deg = 60.0;
  p.heading_step_deg = 2.0;
  p.translation_range = 1.0;
  p.cell = 0.1;
  p.candidates = 3;
  return p;
}

TEST(CorrelativeSearch, FindsATurnBeyondIcpsBasinFromIndependentSamplings) {
  const TurnedRoomPair pair;
  const auto hits = registration::correlativeSearch(pair.source, pair.target, roomSearch());
  ASSERT_FALSE(hits.empty());
  const auto [dt, dr] = test::poseError(hits.front().T_target_source, pair.T_target_source);
  // The heading grid steps by 2°, the translation by 10 cm (5 cm at the end): the best pose is
  // within a step of the heading and a coarse cell and a half of the translation; ICP does the
  // rest (below).
  EXPECT_LT(dr, 2.0) << "heading " << hits.front().heading_deg << ", axis "
                     << hits.front().axis.transpose();
  EXPECT_LT(dt, 0.15);
  // The same with the vertical shifts cut to ±0.2 m (the pair moved 0.1 m along z).
  auto level = roomSearch();
  level.axial_range = 0.2;
  const auto level_hits = registration::correlativeSearch(pair.source, pair.target, level);
  ASSERT_FALSE(level_hits.empty());
  const auto [lt, lr] = test::poseError(level_hits.front().T_target_source, pair.T_target_source);
  EXPECT_LT(lr, 2.0);
  EXPECT_LT(lt, 0.15);

  // Refined by ICP from the search's pose the pair is registered; from the identity the same ICP
  // stops in a wrong pose (the search is what makes the start).
  registration::IcpParams icp;
  icp.normal_neighbors = 10;
  const registration::IcpMatcher matcher(icp);
  const auto from_search = matcher.match(pair.source, pair.target, hits.front().T_target_source);
  const auto [st, sr] = test::poseError(from_search.T_target_source, pair.T_target_source);
  EXPECT_LT(sr, 0.5);
  EXPECT_LT(st, 0.02);
  const auto from_identity = matcher.match(pair.source, pair.target, Isometry3d::Identity());
  const auto [it, ir] = test::poseError(from_identity.T_target_source, pair.T_target_source);
  EXPECT_GT(ir + 10.0 * it, 5.0) << "ICP alone registered the pair: the test shows nothing";
}

TEST(CorrelativeSearch, TurnsAboutTheFloorsNormalWhenTheSensorLooksDown) {
  // Both sensors pitched by 15°: the room's vertical is 15° off their z axis.
  const TurnedRoomPair pair(15.0);
  const Eigen::Vector3d up = Eigen::AngleAxisd(-15.0 * kDegToRad, Eigen::Vector3d::UnitX()) *
                             Eigen::Vector3d::UnitZ();
  const auto floor = registration::floorNormal(pair.target.points, 0.1, Eigen::Vector3d::UnitZ(),
                                               30.0);
  ASSERT_TRUE(floor.has_value());
  EXPECT_LT(std::acos(std::min(1.0, std::abs(floor->dot(up)))) * kRadToDeg, 1.0)
      << floor->transpose();
  // No floor within the allowed tilt: nothing, rather than a wall's normal.
  EXPECT_FALSE(registration::floorNormal(pair.target.points, 0.1, Eigen::Vector3d::UnitZ(), 5.0)
                   .has_value());

  auto p = roomSearch();
  const auto hits = registration::correlativeSearch(pair.source, pair.target, p);
  ASSERT_FALSE(hits.empty());
  const auto [dt, dr] = test::poseError(hits.front().T_target_source, pair.T_target_source);
  EXPECT_LT(dr, 2.0);
  EXPECT_LT(dt, 0.15);
  EXPECT_LT(std::acos(std::min(1.0, std::abs(hits.front().axis.dot(up)))) * kRadToDeg, 1.0);
  // Turned about the sensor's own z instead, the best pose keeps the tilt's error.
  p.axis_from_floor = false;
  const auto level = registration::correlativeSearch(pair.source, pair.target, p);
  ASSERT_FALSE(level.empty());
  EXPECT_GT(test::poseError(level.front().T_target_source, pair.T_target_source).second, 5.0);
}

TEST(CorrelativeSearch, CandidatesAreRankedAndApartAndDeterministic) {
  const TurnedRoomPair pair;
  auto p = roomSearch();
  p.candidates = 4;
  const auto hits = registration::correlativeSearch(pair.source, pair.target, p);
  ASSERT_EQ(hits.size(), 4u);
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (i > 0) {
      EXPECT_GE(hits[i - 1].score, hits[i].score);
    }
    for (std::size_t j = 0; j < i; ++j) {
      const double dh = std::abs(hits[i].heading_deg - hits[j].heading_deg);
      const double dm =
          (hits[i].T_target_source.translation() - hits[j].T_target_source.translation()).norm();
      EXPECT_TRUE(dh >= p.min_separation_deg || dm >= p.min_separation_m) << i << " vs " << j;
    }
  }
  const auto again = registration::correlativeSearch(pair.source, pair.target, p);
  ASSERT_EQ(again.size(), hits.size());
  for (std::size_t i = 0; i < hits.size(); ++i) {
    EXPECT_EQ(again[i].score, hits[i].score);
    EXPECT_TRUE(again[i].T_target_source.isApprox(hits[i].T_target_source));
  }
  // The initial guess composes: starting from the truth's heading the best turn is near 0°.
  Isometry3d init = Isometry3d::Identity();
  init.linear() = pair.T_target_source.linear();
  const auto from_guess = registration::correlativeSearch(pair.source, pair.target, p, init);
  ASSERT_FALSE(from_guess.empty());
  EXPECT_LE(std::abs(from_guess.front().heading_deg), 2.0);
  EXPECT_TRUE(registration::correlativeSearch(PointCloud(), pair.target, p).empty());
}

/// An object of about a unit's size, three boxes in an L with a post (no symmetry), sampled twice
/// on its own (no shared point); the source is the second sampling turned by 60° about an oblique
/// axis, moved 1.1 units, cut to the part with x > −0.2 in the object's frame and jittered.
struct TurnedObjectPair {
  Isometry3d T_target_source;
  PointCloud target, source;
  static PointCloud object(std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    PointCloud c;
    test::sampleBox(c, {-0.6f, -0.3f, -0.2f}, {0.6f, 0.0f, 0.1f}, 1200.0, rng);
    test::sampleBox(c, {0.3f, 0.0f, -0.2f}, {0.6f, 0.5f, 0.1f}, 1200.0, rng);
    test::sampleBox(c, {-0.5f, -0.25f, 0.1f}, {-0.35f, -0.1f, 0.6f}, 1200.0, rng);
    c.frame_id = "target";
    return c;
  }
  TurnedObjectPair() {
    T_target_source = makeIsometry(
        Eigen::AngleAxisd(60.0 * kDegToRad, Eigen::Vector3d(1.0, 2.0, -1.0).normalized())
            .toRotationMatrix(),
        Eigen::Vector3d(0.8, -0.6, 0.45));
    target = object(1);
    PointCloud cut;
    for (const auto& p : object(2).points)
      if (p.x() > -0.2f) cut.push_back(p);
    source = test::makeSource(cut, T_target_source, 1.0, 0.005, 3);
  }
};

TEST(CorrelativeSearch, EveryRotationAboutTheCentroidsFindsAnObjectTurnedObliquely) {
  const TurnedObjectPair pair;
  const auto p = test::unitObjectSearch(10.0, 8);
  const auto hits = registration::correlativeSearch(pair.source, pair.target, p);
  ASSERT_EQ(hits.size(), 8u);
  // ICP from each of the search's poses; the one with the most points on the target's surface
  // (within 1 cm of its tangent planes) is the pair's pose. From the identity ICP fails.
  registration::ConfidenceParams tight;
  tight.inlier_threshold = 0.01;
  const registration::IcpMatcher matcher(test::unitObjectIcp(), tight);
  registration::MatchResult best;
  double nearest_start = 180.0;
  for (const auto& h : hits) {
    // Every pose turns about one axis by up to the range, on the grid's steps.
    EXPECT_LE(h.heading_deg, p.heading_range_deg + 1e-9);
    nearest_start =
        std::min(nearest_start, test::poseError(h.T_target_source, pair.T_target_source).second);
    auto r = matcher.match(pair.source, pair.target, h.T_target_source);
    if (r.inlier_ratio > best.inlier_ratio) best = r;
  }
  // The grid's steps of 10° leave at most 8.7° (half a cube's diagonal) to the nearest turn.
  EXPECT_LT(nearest_start, 9.0);
  const auto [bt, br] = test::poseError(best.T_target_source, pair.T_target_source);
  EXPECT_LT(br, 1.0);
  EXPECT_LT(bt, 0.01);
  const auto from_identity = matcher.match(pair.source, pair.target, Isometry3d::Identity());
  const auto [it, ir] = test::poseError(from_identity.T_target_source, pair.T_target_source);
  EXPECT_GT(ir + 10.0 * it, 5.0) << "ICP alone registered the pair: the test shows nothing";
  // About the source's origin with translations around the identity, the 1.1-unit move is out
  // of the 0.3 range: no pose is near.
  auto origin = p;
  origin.align_centroids = false;
  for (const auto& h : registration::correlativeSearch(pair.source, pair.target, origin))
    EXPECT_GT(test::poseError(h.T_target_source, pair.T_target_source).first, 0.3);
  // A grid of every rotation refuses a runaway count.
  auto fine = p;
  fine.heading_step_deg = 5.0;
  EXPECT_THROW(fine.validate(), ConfigError);
}

TEST(CorrelativeSearch, RejectsBadSettingsByName) {
  registration::CorrelativeSearchParams p;
  p.axis = "w";
  EXPECT_THROW(p.validate(), ConfigError);
  p = registration::CorrelativeSearchParams();
  p.max_tilt_deg = 90.0;
  EXPECT_THROW(p.validate(), ConfigError);
  p = registration::CorrelativeSearchParams();
  p.axial_range = -2.0;
  EXPECT_THROW(p.validate(), ConfigError);
  p = registration::CorrelativeSearchParams();
  p.translation_range = 10.0;
  p.cell = 0.1;  // 201³ shifts per heading
  try {
    p.validate();
    FAIL() << "a runaway grid was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("translation_range / cell"), std::string::npos);
  }
  try {
    registration::CorrelativeSearchParams::load(
        ConfigNode::fromString("axis: z\ncel: 0.2\n", "search.yaml"));
    FAIL() << "an unknown key was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cel"), std::string::npos) << e.what();
  }
  const auto q = registration::CorrelativeSearchParams::load(
      ConfigNode::fromString("axis: z\nheading_range_deg: 180\ncell: 0.5\ntranslation_range: 5\n",
                             "search.yaml"));
  EXPECT_EQ(q.axis, "z");
  EXPECT_EQ(q.heading_range_deg, 180.0);
  EXPECT_EQ(q.cell, 0.5);
  EXPECT_EQ(q.translation_range, 5.0);
}

}  // namespace
}  // namespace obm
