// The front-end's parts behind Frontend (private headers in libs/frontend/src) on tiny synthetic
// input: edge information, the tracker's acceptance tests, the order of the recovery steps, the
// asynchronous local map and the loop closer.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "edge_information.hpp"
#include "local_map.hpp"
#include "loop_closer.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/registration/icp.hpp"
#include "recovery.hpp"
#include "tracker.hpp"

namespace obm::frontend {
namespace {

/// A box seen from inside: the ground and three walls on a 0.5 m grid (constrains every DOF).
PointCloud boxCloud() {
  PointCloud c;
  for (double x = -20.0; x <= 20.0; x += 0.5)
    for (double y = -20.0; y <= 20.0; y += 0.5)
      c.push_back(Vector3f(static_cast<float>(x), static_cast<float>(y), -1.5f));
  for (double s = -20.0; s <= 20.0; s += 0.5)
    for (double z = -1.0; z <= 4.0; z += 0.5) {
      c.push_back(Vector3f(-12.0f, static_cast<float>(s), static_cast<float>(z)));
      c.push_back(Vector3f(14.0f, static_cast<float>(s), static_cast<float>(z)));
      c.push_back(Vector3f(static_cast<float>(s), 17.0f, static_cast<float>(z)));
    }
  return c;
}

/// A keyframe estimated at `T_world_sensor` whose cloud is the box seen from `T_true`.
Keyframe keyframe(std::size_t id, const Isometry3d& T_world_sensor, double travelled,
                  const Isometry3d& T_true) {
  Keyframe kf;
  kf.id = id;
  kf.frame_index = 10 * id;
  kf.T_world_sensor = T_world_sensor;
  kf.travelled = travelled;
  const Eigen::Isometry3f T_sensor_world = T_true.inverse().cast<float>();
  for (const Vector3f& q : boxCloud().points) kf.cloud.push_back(T_sensor_world * q);
  return kf;
}

float minX(const PointCloud& c) {
  float m = std::numeric_limits<float>::infinity();
  for (const Vector3f& q : c.points) m = std::min(m, q.x());
  return m;
}

Isometry3d shifted(double x) {
  Isometry3d T = Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

registration::MatchResult goodMatch() {
  registration::MatchResult r;
  r.status = registration::MatchStatus::Ok;
  r.quality = 0.9;
  r.inlier_ratio = 0.8;
  return r;
}

/// A street corner without the box's near-symmetries (a box turned by 90° fits its ground and
/// half its walls): two facades, a shorter one and pillars at irregular places, a coarse road.
PointCloud cornerCloud() {
  PointCloud corner;
  for (double x = -20.0; x <= 20.0; x += 1.5)
    for (double y = -20.0; y <= 20.0; y += 1.5)
      corner.push_back(Vector3f(static_cast<float>(x), static_cast<float>(y), -1.5f));
  for (double s = -20.0; s <= 20.0; s += 0.6)
    for (double z = -1.0; z <= 6.0; z += 0.6) {
      corner.push_back(Vector3f(-12.0f, static_cast<float>(s), static_cast<float>(z)));
      if (s < 5.0) corner.push_back(Vector3f(14.0f, static_cast<float>(s), static_cast<float>(z)));
      if (s < 0.0) corner.push_back(Vector3f(static_cast<float>(s), 17.0f, static_cast<float>(z)));
    }
  for (const auto& [px, py] :
       std::vector<std::pair<float, float>>{{3, 8}, {-5, -9}, {8, -12}, {-8, 11}, {10, 3}})
    for (double a = 0.0; a < 6.28; a += 0.5)
      for (double z = -1.0; z <= 4.0; z += 0.3)
        corner.push_back(Vector3f(px + 0.3f * static_cast<float>(std::cos(a)),
                                  py + 0.3f * static_cast<float>(std::sin(a)),
                                  static_cast<float>(z)));
  return corner;
}

/// Four seconds of sweeps lost in a turn (the gap-path tests): the last motion is 0.25 m and 3° a
/// frame, the guess drives it 40 times (120° round a 4.8 m circle), but the car left the turn
/// after 15° and drove on straight, a little faster: 7 m from the guess and 105° turned from it.
/// The place is cornerCloud() in the world frame; `sweep` sees it from the true pose.
struct GapInTurn {
  Isometry3d last_motion = Isometry3d::Identity();
  Isometry3d T_last = shifted(-6.0);
  double steps = 40.0;
  Isometry3d T_guess, T_true;
  PointCloud corner = cornerCloud();
  PointCloud sweep;

  GapInTurn() {
    last_motion.rotate(Eigen::AngleAxisd(3.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
    last_motion.translation() = Eigen::Vector3d(0.25, 0.0, 0.0);
    T_guess = T_last * expSE3(steps * logSE3(last_motion));
    T_true = T_last * expSE3(5.0 * logSE3(last_motion));
    T_true.translation() += T_true.linear() * Eigen::Vector3d(0.3 * 35.0, 0.0, 0.0);
    const Eigen::Isometry3f T_sensor_world = T_true.inverse().cast<float>();
    for (const Vector3f& q : corner.points) sweep.push_back(T_sensor_world * q);
  }

  /// The recovery's input for this gap against `local_map` (the frame before: T_last).
  RecoveryInput input(const registration::PreparedTarget& local_map, const Keyframe& last,
                      std::size_t keyframes) const {
    RecoveryInput in{sweep,
                     T_guess,
                     local_map,
                     last,
                     keyframes,
                     last_motion,
                     0.9,
                     std::max(0.0, rotationAngle((T_last.inverse() * T_guess).linear()) -
                                       rotationAngle(last_motion.linear()))};
    in.T_last = T_last;
    in.steps = steps;
    return in;
  }
};

// ---------------------------------------------------------------------------------------------
TEST(FrontendParts, EdgeInformationHasTheFloorAndBridgeEdgesTheirSigmas) {
  // An over-confident match is limited by the floor: Ω → diag(1/σ_t², 1/σ_r²).
  const Matrix6d huge = 1e12 * Matrix6d::Identity();
  const Matrix6d F = registration::informationG2oToTheta(edgeInformation(huge, 1.0, 0.01, 0.001));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(F(i, i), 1e4, 1.0) << i;
  for (int i = 3; i < 6; ++i) EXPECT_NEAR(F(i, i), 1e6, 100.0) << i;
  // No information at all: eigenvalues clamped to 1 (σ <= 1 m / 1 rad).
  EXPECT_TRUE(
      registration::informationG2oToTheta(edgeInformation(Matrix6d::Zero(), 1.0, 0.01, 0.001))
          .isApprox(Matrix6d::Identity(), 1e-12));

  TrackingParams tp;
  const Matrix6d B = registration::informationG2oToTheta(
      bridgeInformation(tp.bridge_sigma_translation, tp.bridge_sigma_rotation));
  EXPECT_NEAR(B(0, 0), 1.0 / (tp.bridge_sigma_translation * tp.bridge_sigma_translation), 1e-9);
  EXPECT_NEAR(B(5, 5), 1.0 / (tp.bridge_sigma_rotation * tp.bridge_sigma_rotation), 1e-6);
  // A restart, or a keyframe without a match, gets the bridge edge; a match its own information.
  registration::MatchResult m = goodMatch();
  m.information = 1e3 * Matrix6d::Identity();
  EXPECT_EQ(odometryEdgeInformation(tp, nullptr, false),
            bridgeInformation(tp.bridge_sigma_translation, tp.bridge_sigma_rotation));
  EXPECT_EQ(odometryEdgeInformation(tp, &m, true), odometryEdgeInformation(tp, nullptr, false));
  EXPECT_EQ(odometryEdgeInformation(tp, &m, false),
            edgeInformation(m.information, tp.information_scale, tp.floor_sigma_translation,
                            tp.floor_sigma_rotation));
  LoopClosureParams lp;
  EXPECT_EQ(loopEdgeInformation(lp, m),
            edgeInformation(m.information, lp.information_scale, lp.floor_sigma_translation,
                            lp.floor_sigma_rotation));
}

TEST(FrontendParts, AcceptanceTestsCheckStatusQualityInliersThenTheCorrection) {
  const AcceptanceBounds b{0.5, 0.6, 1.0, 5.0 * kDegToRad};
  const Isometry3d guess = Isometry3d::Identity();
  using K = RejectionKind;
  registration::MatchResult r = goodMatch();
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::None);
  EXPECT_EQ(checkAcceptance(r, guess, b).detail, "");
  r.status = registration::MatchStatus::NotConverged;
  EXPECT_FALSE(checkAcceptance(r, guess, b).rejected());  // not converged and degenerate are judged
  r.status = registration::MatchStatus::TooFewCorrespondences;
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::MatchStatus);
  EXPECT_EQ(checkAcceptance(r, guess, b).detail.rfind("match status ", 0), 0u);
  r = goodMatch();
  r.quality = 0.4;
  r.inlier_ratio = 0.1;
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::Quality);  // the first failed test
  EXPECT_EQ(checkAcceptance(r, guess, b).detail.rfind("quality ", 0), 0u);
  r = goodMatch();
  r.inlier_ratio = 0.5;
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::InlierRatio);
  EXPECT_NE(checkAcceptance(r, guess, b).detail.find("recent frames fit better"), std::string::npos);
  r = goodMatch();
  r.T_target_source = shifted(1.5);
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::TranslationJump);
  EXPECT_EQ(checkAcceptance(r, guess, b).detail.rfind("jump of 1.5", 0), 0u);
  r.T_target_source = Isometry3d::Identity();
  r.T_target_source.linear() = expSO3(Eigen::Vector3d(0.0, 0.0, 10.0 * kDegToRad));
  EXPECT_EQ(checkAcceptance(r, guess, b).kind, K::RotationJump);
  EXPECT_NE(checkAcceptance(r, guess, b).detail.find(" deg from the constant-velocity guess"),
            std::string::npos);
  EXPECT_STREQ(toString(K::RotationJump), "rotation_jump");
}

TEST(FrontendParts, RecoveryStepsRunInTheDocumentedOrder) {
  EXPECT_EQ(Recovery::stepNames(),
            (std::vector<std::string>{"wide_gate", "gap_paths", "last_keyframe", "second_opinion",
                                      "confirmed_jump"}));
}

TEST(FrontendParts, TheLastKeyframeStepTakesTheMatchersRegistrationAndTimesItByMatcher) {
  // No wide gate: the first step that runs registers against the last keyframe with ICP.
  TrackingParams tp;
  const registration::IcpMatcher icp;
  Recovery recovery(tp, nullptr, icp);
  const Isometry3d I = Isometry3d::Identity();
  const Keyframe kf = keyframe(3, shifted(2.0), 8.0, shifted(2.0));
  const Keyframe now = keyframe(4, I, 8.5, shifted(2.4));  // the sweep, 0.4 m further
  const registration::PreparedTarget local_map(kf.cloud);
  const Isometry3d guess = shifted(2.2);
  const RecoveryInput in{now.cloud, guess, local_map, kf, 4, I, 0.8};
  FrameResult fr;
  fr.index = 40;
  StageTimes times;
  recovery.startSweep();
  recovery.recover(in, {RejectionKind::InlierRatio, "tracking said no"}, fr, times);
  EXPECT_EQ(fr.status, TrackingStatus::Recovered);
  EXPECT_EQ(fr.rejection, RejectionKind::InlierRatio);  // why tracking did not take it
  EXPECT_EQ(fr.reason, "tracking said no; taken: icp against the last keyframe");
  EXPECT_LT((fr.match.T_target_source.translation() - Eigen::Vector3d(2.4, 0, 0)).norm(), 0.05);
  EXPECT_FALSE(recovery.takeConfirmedJump());
  // ICP's time is "loop_icp" (as in loop verification), not the OBMNet stage.
  EXPECT_EQ(times.entries().count("loop_icp"), 1u);
  EXPECT_EQ(times.entries().count("obmnet"), 0u);
}

TEST(FrontendParts, AMatchOnTheGuessIntoUnmappedSpaceIsTrackedWithGuessAgreement) {
  // The local map is the box; the sweep sees the box and, as much again, a room beyond it that
  // the map has not seen (a doorway, a fast turn): its right match pairs ~60 % of the points,
  // below 0.7 of the recent frames' ratio.
  const PointCloud box = boxCloud();
  PointCloud wider = box;
  for (double y = -20.0; y <= 20.0; y += 0.5)
    for (double z = -1.0; z <= 9.0; z += 0.5) wider.push_back(Vector3f(40.0f, static_cast<float>(y), static_cast<float>(z)));
  for (double x = 41.0; x <= 60.0; x += 0.5)
    for (double y = -20.0; y <= 20.0; y += 0.5) wider.push_back(Vector3f(static_cast<float>(x), static_cast<float>(y), 6.0f));
  const auto run = [&](double agreement, const Isometry3d& T_true) {
    TrackingParams tp;
    tp.guess_agreement_translation = agreement;
    Tracker tracker(tp);
    const registration::PreparedTarget map(box, tracker.icp().icpParams().targetOptions());
    registration::MatchResult m;
    StageTimes times;
    for (int k = 0; k < 3; ++k)  // the recent frames: the box alone, fully paired
      EXPECT_FALSE(tracker.track(box, map, Isometry3d::Identity(), true, m, times).rejected());
    PointCloud sweep;
    const Eigen::Isometry3f T_sensor_world = T_true.inverse().cast<float>();
    for (const Vector3f& q : wider.points) sweep.push_back(T_sensor_world * q);
    const Rejection r = tracker.track(sweep, map, Isometry3d::Identity(), true, m, times);
    return std::make_pair(r, m);
  };
  const auto [off, m_off] = run(0.0, Isometry3d::Identity());
  EXPECT_EQ(off.kind, RejectionKind::InlierRatio) << off.detail << " (inlier ratio " << m_off.inlier_ratio << ")";
  const auto [on, m_on] = run(0.02, Isometry3d::Identity());
  EXPECT_FALSE(on.rejected()) << on.detail;
  EXPECT_LT(m_on.T_target_source.translation().norm(), 0.02);
  // A sweep 0.3 m from the guess: the match may be right, but prediction and registration
  // disagree, so the relative inlier test stands.
  const auto [far, m_far] = run(0.02, shifted(0.3));
  EXPECT_EQ(far.kind, RejectionKind::InlierRatio) << far.detail;
}

TEST(FrontendParts, AfterAGapOrWithAFitLikeTrackingTheRecoveryMayCorrectALargeTurn) {
  // The guess extrapolated a turn over a gap in the time stamps, 30° more than the car turned:
  // beyond the 4 × 5° a recovery may correct, unless the bound grows by the extrapolated turn.
  TrackingParams tp;  // max_correction_rotation 5°, recovery_gate 4 m, ±10°, ±20° hypotheses
  const Tracker tracker(tp);  // its wide gate does not depend on the keys changed below
  const registration::IcpMatcher icp;
  const Isometry3d T_true = shifted(2.4);
  const Keyframe kf = keyframe(3, Isometry3d::Identity(), 8.0, Isometry3d::Identity());
  const Keyframe now = keyframe(4, Isometry3d::Identity(), 8.5, T_true);  // the sweep
  const registration::PreparedTarget local_map(kf.cloud,
                                               tracker.icp().icpParams().targetOptions());  // world
  Isometry3d guess = T_true;
  guess.rotate(Eigen::AngleAxisd(30.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
  Isometry3d last_motion = Isometry3d::Identity();
  last_motion.rotate(Eigen::AngleAxisd(3.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
  const auto recover = [&](double extrapolated_deg, double large_turn_ratio = 0.0) {
    tp.recovery_large_turn_relative_inlier_ratio = large_turn_ratio;
    Recovery recovery(tp, tracker.wideGate(), icp);
    const RecoveryInput in{now.cloud, guess,          local_map, kf, 4, last_motion,
                           0.8,       extrapolated_deg * kDegToRad};
    FrameResult fr;
    StageTimes times;
    recovery.startSweep();
    recovery.recover(in, {RejectionKind::TranslationJump, "tracking said no"}, fr, times);
    return fr;
  };
  const FrameResult without = recover(0.0);
  EXPECT_NE(without.status, TrackingStatus::Recovered) << without.reason;
  const FrameResult with = recover(35.0);
  ASSERT_EQ(with.status, TrackingStatus::Recovered) << with.reason;
  EXPECT_LT((with.match.T_target_source.translation() - T_true.translation()).norm(), 0.05);
  EXPECT_LT(rotationAngle(with.match.T_target_source.linear()) * kRadToDeg, 0.2);
  // Without a gap (sweeps lost, the stamps regular) nothing was extrapolated, but a registration
  // 30° from the guess that fits as well as the tracked frames is taken too.
  const FrameResult large_turn = recover(0.0, 0.95);
  ASSERT_EQ(large_turn.status, TrackingStatus::Recovered) << large_turn.reason;
  EXPECT_LT((large_turn.match.T_target_source.translation() - T_true.translation()).norm(), 0.05);
}

TEST(FrontendParts, AfterAGapTheGapPathsFindTheCarWhereTheTurningGuessLostIt) {
  // GapInTurn, the place in the local map.
  TrackingParams tp;
  const Tracker tracker(tp);
  const registration::IcpMatcher icp;
  const GapInTurn g;
  const Isometry3d& T_true = g.T_true;
  Keyframe kf;
  kf.id = 3;
  kf.cloud = g.corner;  // the local map, in the world frame
  const registration::PreparedTarget local_map(kf.cloud, tracker.icp().icpParams().targetOptions());
  ASSERT_GT((g.T_guess.inverse() * T_true).translation().norm(), 6.0);
  const auto recover = [&](double min_steps) {
    tp.recovery_gap_speed_min = 1.0;  // 1.0, 1.2, 1.4 (10 m of path, 2 m apart): faster
    tp.recovery_gap_speed_max = 1.4;
    tp.recovery_gap_min_steps = min_steps;
    Recovery recovery(tp, tracker.wideGate(), icp);
    const RecoveryInput in = g.input(local_map, kf, 4);
    FrameResult fr;
    StageTimes times;
    recovery.startSweep();
    recovery.recover(in, {RejectionKind::InlierRatio, "tracking said no"}, fr, times);
    return std::make_pair(fr, recovery.takenBy());
  };
  const auto [off, off_step] = recover(0.0);
  EXPECT_NE(off.status, TrackingStatus::Recovered) << off.reason;
  const auto [on, on_step] = recover(5.0);
  ASSERT_EQ(on.status, TrackingStatus::Recovered) << on.reason;
  EXPECT_EQ(on_step, "gap_paths") << on.reason;
  const Isometry3d err = T_true.inverse() * on.match.T_target_source;
  EXPECT_LT(err.translation().norm(), 0.05) << on.reason;
  EXPECT_LT(rotationAngle(err.linear()) * kRadToDeg, 0.2) << on.reason;
  // A gap shorter than min_steps leaves the step out.
  const auto [short_gap, short_step] = recover(41.0);
  EXPECT_NE(short_step, "gap_paths");
}

TEST(FrontendParts, AfterAGapTheGapPathsFindTheCarOnTheMapOfAnEarlierPass) {
  // GapInTurn, but the local map (the keyframes before the gap) does not reach where the car is
  // now: it holds another place 500 m away. An earlier pass mapped the place, in a keyframe older
  // than the local map (its cloud in its own sensor frame, 3 m and 40° from the true pose). The
  // paths find the car against that keyframe only when recovery_gap_map_radius lets them look
  // there, and the recovery hands that map on for the frames after.
  TrackingParams tp;
  const Tracker tracker(tp);
  const registration::IcpMatcher icp;
  const GapInTurn g;
  const Isometry3d& T_true = g.T_true;
  Keyframe earlier;  // the earlier pass
  earlier.id = 0;
  earlier.T_world_sensor = T_true;
  earlier.T_world_sensor.rotate(Eigen::AngleAxisd(40.0 * kDegToRad, Eigen::Vector3d::UnitZ()));
  earlier.T_world_sensor.translation() += Eigen::Vector3d(2.0, -2.2, 0.0);
  const Eigen::Isometry3f T_earlier_world = earlier.T_world_sensor.inverse().cast<float>();
  for (const Vector3f& q : g.corner.points) earlier.cloud.push_back(T_earlier_world * q);
  Keyframe before_gap;  // the last keyframe before the gap, elsewhere
  before_gap.id = 7;
  for (const Vector3f& q : g.corner.points)
    before_gap.cloud.push_back(q + Vector3f(500.0f, 0.0f, 0.0f));
  const std::vector<Keyframe> keyframes{earlier, before_gap};
  const registration::PreparedTarget local_map(before_gap.cloud,
                                               tracker.icp().icpParams().targetOptions());
  const auto recover = [&](double radius) {
    tp.recovery_gap_speed_min = 1.0;
    tp.recovery_gap_speed_max = 1.4;
    tp.recovery_gap_min_steps = 5.0;
    tp.recovery_gap_map_radius = radius;
    Recovery recovery(tp, tracker.wideGate(), icp);
    RecoveryInput in = g.input(local_map, before_gap, 2);
    in.all_keyframes = &keyframes;
    in.old_keyframes_end = 1;  // the earlier pass only: the other one is the local map's
    FrameResult fr;
    StageTimes times;
    recovery.startSweep();
    recovery.recover(in, {RejectionKind::InlierRatio, "tracking said no"}, fr, times);
    const bool handed_on = recovery.takeRecoveryMap() != nullptr;
    return std::make_tuple(fr, recovery.takenBy(), handed_on);
  };
  const auto [off, off_step, off_map] = recover(0.0);
  EXPECT_NE(off.status, TrackingStatus::Recovered) << off.reason;
  EXPECT_FALSE(off_map);
  const auto [on, on_step, on_map] = recover(20.0);
  ASSERT_EQ(on.status, TrackingStatus::Recovered) << on.reason;
  EXPECT_EQ(on_step, "gap_paths") << on.reason;
  EXPECT_TRUE(on_map);
  EXPECT_NE(on.reason.find("earlier submaps"), std::string::npos) << on.reason;
  const Isometry3d err = T_true.inverse() * on.match.T_target_source;
  EXPECT_LT(err.translation().norm(), 0.05) << on.reason;
  EXPECT_LT(rotationAngle(err.linear()) * kRadToDeg, 0.2) << on.reason;
}

TEST(FrontendParts, AJumpTheStampsHideIsFoundAmongThePathsOfLostSweeps) {
  // Twelve sweeps lost on a straight drive at 0.6 m a frame, the time stamps regular: the guess
  // is one step on, the car 7.2 m further, beyond what the wide gate corrects.
  TrackingParams tp;
  tp.recovery_gap_min_steps = 5.0;
  const Tracker tracker(tp);
  const registration::IcpMatcher icp;
  Isometry3d last_motion = Isometry3d::Identity();
  last_motion.translation() = Eigen::Vector3d(0.6, 0.0, 0.0);
  const Isometry3d T_last = shifted(-6.0);
  const Isometry3d T_guess = T_last * last_motion;
  const Isometry3d T_true = shifted(-6.0 + 13 * 0.6);
  Keyframe kf;
  kf.id = 3;
  kf.cloud = cornerCloud();
  PointCloud sweep;
  const Eigen::Isometry3f T_sensor_world = T_true.inverse().cast<float>();
  for (const Vector3f& q : kf.cloud.points) sweep.push_back(T_sensor_world * q);
  const registration::PreparedTarget local_map(kf.cloud, tracker.icp().icpParams().targetOptions());
  const auto recover = [&](int max_steps) {
    tp.recovery_jump_max_steps = max_steps;
    tp.recovery_gap_corner_turns.clear();  // (a straight drive: the corners only cost time)
    Recovery recovery(tp, tracker.wideGate(), icp);
    RecoveryInput in{sweep, T_guess, local_map, kf, 4, last_motion, 0.9, 0.0};
    in.T_last = T_last;
    in.steps = 1.0;
    FrameResult fr;
    StageTimes times;
    recovery.startSweep();
    recovery.recover(in, {RejectionKind::TranslationJump, "tracking said no"}, fr, times);
    return std::make_pair(fr, recovery.takenBy());
  };
  const auto [off, off_step] = recover(0);
  EXPECT_NE(off_step, "gap_paths") << off.reason;
  EXPECT_NE(off.status, TrackingStatus::Recovered) << off.reason;
  const auto [on, on_step] = recover(16);
  ASSERT_EQ(on.status, TrackingStatus::Recovered) << on.reason;
  EXPECT_EQ(on_step, "gap_paths") << on.reason;
  EXPECT_NE(on.reason.find("jump paths"), std::string::npos) << on.reason;
  const Isometry3d err = T_true.inverse() * on.match.T_target_source;
  EXPECT_LT(err.translation().norm(), 0.05) << on.reason;
  EXPECT_LT(rotationAngle(err.linear()) * kRadToDeg, 0.2) << on.reason;
}

// keyframe_normals: each keyframe's normals and colour gradients are estimated once, in its own
// sensor frame, and turned into the world frame when the map is merged. Two keyframes see the box
// from sensors turned by 30° and 120° about z (and tilted), so a normal or gradient left in the
// sensor frame would point the wrong way; the map must match the one whose normals are estimated
// on the merged cloud.
TEST(FrontendParts, KeyframeNormalsAreEstimatedOnceAndTurnedIntoTheWorldFrame) {
  const auto turned = [](double x, double yaw_deg, double tilt_deg) {
    Isometry3d T = shifted(x);
    T.linear() = (Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(tilt_deg * kDegToRad, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    return T;
  };
  // Grey level rising along world x (one grey step per 2 m): the floor's gradient is along +x.
  const auto coloured = [](Keyframe kf) {
    const Eigen::Isometry3f T = kf.T_world_sensor.cast<float>();
    for (const Vector3f& q : kf.cloud.points) {
      const float x = (T * q).x();
      const auto g = static_cast<std::uint8_t>(std::clamp(128.f + 6.f * x, 0.f, 255.f));
      kf.cloud.colors.push_back(Color3u8(g, g, g));
    }
    return kf;
  };
  std::vector<Keyframe> kfs;
  for (const auto& [id, T] : {std::pair<std::size_t, Isometry3d>{0, turned(0.0, 30.0, 5.0)},
                              {1, turned(2.0, 120.0, -4.0)},
                              {2, turned(4.0, -60.0, 2.0)}})
    kfs.push_back(coloured(keyframe(id, T, 2.0 * double(id), T)));

  registration::PreparedTarget::Options opt;
  opt.color_gradients = true;
  opt.threads = 1;
  LocalMapParams lp;
  lp.async = false;
  lp.radius = 1000.0;
  lp.voxel = 0.5;
  lp.keyframe_normals = true;
  LocalMap per_keyframe(lp, opt);
  lp.keyframe_normals = false;
  LocalMap merged(lp, opt);
  StageTimes times;
  std::vector<Keyframe> so_far;
  for (const Keyframe& kf : kfs) {
    so_far.push_back(kf);
    per_keyframe.afterKeyframe(so_far, 10 * kf.id, false, times);
    merged.afterKeyframe(so_far, 10 * kf.id, false, times);
  }
  // Three maps built, each keyframe's surface estimated once (not 1 + 2 + 3 times).
  EXPECT_EQ(per_keyframe.surfacesEstimated(), 3u);
  EXPECT_EQ(merged.surfacesEstimated(), 0u);

  const registration::PreparedTarget& a = per_keyframe.target();
  const registration::PreparedTarget& b = merged.target();
  ASSERT_EQ(a.size(), b.size());  // the same voxel grid over the same points
  ASSERT_TRUE(a.hasColorGradients());
  std::size_t floor_points = 0, agree = 0, both_valid = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Vector3f& p = a.cloud().points[i];
    EXPECT_NEAR((p - b.cloud().points[i]).norm(), 0.0, 1e-4) << i;
    if (!a.normalValid()[i] || !b.normalValid()[i]) continue;
    // Away from the box's edges (where one view's neighbourhood and the merged views' straddle
    // different faces) the two maps' normals agree.
    int planes_near = 0;  // the floor z = -1.5 and the walls x = -12, x = 14, y = 17
    for (const float d : {p.z() + 1.5f, p.x() + 12.f, p.x() - 14.f, p.y() - 17.f})
      planes_near += std::abs(d) < 1.1f ? 1 : 0;
    const bool edge = planes_near > 1 || std::abs(p.x()) > 19.5f || std::abs(p.y()) > 19.5f ||
                      p.z() > 3.9f;
    if (edge) continue;
    ++both_valid;
    if (std::abs(a.normals()[i].dot(b.normals()[i])) > std::cos(5.0 * kDegToRad)) ++agree;
    if (std::abs(p.z() + 1.5f) < 0.01f && std::abs(p.x()) < 8.f && std::abs(p.y()) < 8.f) {
      ++floor_points;
      EXPECT_GT(std::abs(a.normals()[i].z()), 0.99f) << "floor normal at " << p.transpose();
      // 6 grey levels per metre along x: 6/255 per metre.
      const Vector3f g = a.colorGradients()[i];
      EXPECT_NEAR(g.x(), 6.f / 255.f, 0.005f) << "floor gradient at " << p.transpose();
      EXPECT_NEAR(g.y(), 0.f, 0.005f) << "floor gradient at " << p.transpose();
    }
  }
  EXPECT_GT(floor_points, 100u);
  EXPECT_GT(both_valid, a.size() / 3);
  EXPECT_GE(double(agree), 0.99 * double(both_valid));
}

TEST(FrontendParts, AnAsynchronousLocalMapIsInstalledAFixedNumberOfFramesLater) {
  LocalMapParams lp;
  lp.async = true;
  lp.radius = 1000.0;
  LocalMap map(lp, registration::PreparedTarget::Options());
  StageTimes times;
  const Isometry3d I = Isometry3d::Identity();
  std::vector<Keyframe> kfs{keyframe(0, I, 0.0, I)};
  map.afterKeyframe(kfs, 0, false, times);  // no map yet: built at once
  ASSERT_TRUE(map.exists());
  const std::size_t first_size = map.target().size();
  EXPECT_EQ(first_size, kfs[0].cloud.size());  // one keyframe: no voxel grid

  kfs.push_back(keyframe(1, shifted(10.0), 10.0, I));  // the box again, 10 m further
  map.afterKeyframe(kfs, 7, false, times);  // a worker builds the next map
  for (std::size_t frame = 7; frame < 7 + LocalMap::kDelayFrames; ++frame) {
    map.installPending(frame, times);
    EXPECT_EQ(map.target().size(), first_size) << "frame " << frame;
  }
  map.installPending(7 + LocalMap::kDelayFrames, times);
  EXPECT_GT(map.target().size(), first_size);  // both boxes, on the voxel grid
  EXPECT_NEAR(minX(map.target().cloud()), minX(kfs[0].cloud), 1e-3);
  EXPECT_EQ(times.entries().count("local_map_build"), 1u);

  // A restart keeps only the keyframes from the restart on, built at once.
  map.restartAt(2);
  kfs.push_back(keyframe(2, shifted(50.0), 50.0, I));
  map.afterKeyframe(kfs, 12, true, times);
  EXPECT_EQ(map.target().size(), kfs[2].cloud.size());
  EXPECT_NEAR(minX(map.target().cloud()), minX(kfs[2].cloud) + 50.0f, 1e-3);
}

/// Loop closure on every keyframe, candidates 50 m back along the path, no descriptor check.
LoopClosureParams everyKeyframeLoops() {
  LoopClosureParams lp;
  lp.enabled = true;
  lp.use_descriptor = false;
  lp.check_every = 1;
  lp.min_travel = 50.0;
  return lp;
}

TEST(FrontendParts, TheLoopCloserVerifiesACandidateFarEnoughAlongThePath) {
  const LoopClosureParams lp = everyKeyframeLoops();
  const registration::IcpMatcher icp;
  LoopCloser closer(lp, 0.3, icp);
  backend::Optimizer optimizer;
  FrontendStats stats;
  StageTimes times;
  std::vector<LoopClosure> loops;
  // Two keyframes 5 m apart in space and 20 m along the path: no candidate.
  const Isometry3d I = Isometry3d::Identity();
  std::vector<Keyframe> kfs{keyframe(0, I, 0.0, I), keyframe(1, shifted(5.0), 20.0, shifted(5.0))};
  optimizer.addNode(0, kfs[0].T_world_sensor);
  optimizer.addNode(1, kfs[1].T_world_sensor);
  EXPECT_EQ(closer.search(kfs, loops, optimizer, stats, times), 0u);
  EXPECT_TRUE(loops.empty());
  EXPECT_EQ(stats.loop_searches, 1u);
  // A third one 100 m along the path, back at the start (truly 0.3 m from keyframe 0, estimated
  // 0.1 m: 0.2 m of drift): verified, accepted, a loop edge from keyframe 0 (the nearest).
  kfs.push_back(keyframe(2, shifted(0.1), 100.0, shifted(0.3)));
  optimizer.addNode(2, kfs[2].T_world_sensor);
  ASSERT_EQ(closer.search(kfs, loops, optimizer, stats, times), 1u);
  ASSERT_EQ(loops.size(), 1u);
  EXPECT_TRUE(loops[0].accepted) << loops[0].reason;
  EXPECT_EQ(loops[0].from, 0u);
  EXPECT_EQ(loops[0].to, 2u);
  EXPECT_LT((loops[0].T_from_to.translation() - Eigen::Vector3d(0.3, 0.0, 0.0)).norm(), 0.05);
  EXPECT_NEAR(loops[0].correction, 0.2, 0.05);
  EXPECT_EQ(stats.loop_candidates, 1u);
  EXPECT_EQ(stats.loops_accepted, 1u);
  ASSERT_EQ(optimizer.graph().edges3.size(), 1u);
  EXPECT_TRUE(optimizer.graph().edges3[0].is_loop);
  EXPECT_EQ(times.entries().count(toString(closer.verifyStage())), 1u);
  EXPECT_EQ(closer.verifyStage(), Stage::LoopIcp);
  EXPECT_STREQ(toString(Stage::LoopIcp), "loop_icp");
}

/// One loop search of the newest of `kfs` with `matcher`; the loops it recorded and the counters.
struct OneSearch {
  std::vector<LoopClosure> loops;
  FrontendStats stats;
};
OneSearch searchOnce(const LoopClosureParams& lp, const registration::ScanMatcher& matcher,
                     const std::vector<Keyframe>& kfs) {
  LoopCloser closer(lp, 0.3, matcher);
  backend::Optimizer optimizer;
  StageTimes times;
  for (const Keyframe& kf : kfs) optimizer.addNode(static_cast<backend::NodeId>(kf.id), kf.T_world_sensor);
  OneSearch out;
  closer.search(kfs, out.loops, optimizer, out.stats, times);
  return out;
}

TEST(FrontendParts, TheLoopCloserSkipsCandidatesLookingTheOtherWay) {
  // Keyframe 1 is back at keyframe 0's place, 100 m along the path, but its optical axis (z) is
  // turned by 150° about the vertical (y down in the optical frame): a revisit walked back.
  auto run = [](double max_view_angle_deg) {
    LoopClosureParams lp = everyKeyframeLoops();
    lp.max_view_angle = max_view_angle_deg * kDegToRad;
    Isometry3d turned = Isometry3d::Identity();
    turned.linear() = Eigen::AngleAxisd(150.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const Isometry3d I = Isometry3d::Identity();
    return searchOnce(lp, registration::IcpMatcher(),
                      {keyframe(0, I, 0.0, I), keyframe(1, turned, 100.0, turned)})
        .stats.loop_candidates;
  };
  EXPECT_EQ(run(0.0), 1u);    // no bound: verified
  EXPECT_EQ(run(160.0), 1u);  // within the bound
  EXPECT_EQ(run(45.0), 0u);   // looking 150° apart: not a candidate
}

/// Stands in for a matcher that registers without the guess and picks the wrong one of two
/// symmetric poses: it returns the estimate turned by 180° about z, with the scores of a perfect
/// registration (as a street of identical facades gives one).
class FlippedPoseMatcher : public registration::ScanMatcher {
 public:
  FlippedPoseMatcher()
      : registration::ScanMatcher(registration::IcpParams(), registration::ConfidenceParams()) {}
  std::string name() const override { return "flipped"; }
  bool global() const override { return true; }

 protected:
  registration::MatchResult impl_match(const PointCloud& /*source*/,
                                       const registration::PreparedTarget& /*target*/,
                                       const Isometry3d& T_target_source_init) const override {
    registration::MatchResult r;
    Isometry3d turn = Isometry3d::Identity();
    turn.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    r.T_target_source = T_target_source_init * turn;
    r.status = registration::MatchStatus::Ok;
    r.converged = true;
    r.quality = 0.9;
    r.inlier_ratio = 0.96;
    r.information = Matrix6d::Identity() * 100.0;
    return r;
  }
};

TEST(FrontendParts, TheLoopCloserRejectsAPoseTurnedBeyondTheHeadingDrift) {
  auto run = [](double max_rotation_deg) {
    LoopClosureParams lp = everyKeyframeLoops();
    lp.max_correction_rotation = max_rotation_deg * kDegToRad;
    lp.correction_rotation_per_m = 0.01 * kDegToRad;
    const Isometry3d I = Isometry3d::Identity();
    return searchOnce(lp, FlippedPoseMatcher(),
                      {keyframe(0, I, 0.0, I), keyframe(1, shifted(0.1), 100.0, I)})
        .loops;
  };
  const std::vector<LoopClosure> bounded = run(15.0);
  ASSERT_EQ(bounded.size(), 1u);
  EXPECT_FALSE(bounded[0].accepted);
  EXPECT_NEAR(bounded[0].correction_rotation * kRadToDeg, 180.0, 1e-6);
  // 15° + 0.01°/m × 100 m = 16°.
  EXPECT_EQ(bounded[0].rejection, RejectionKind::LoopRotationCorrection);
  EXPECT_NE(bounded[0].reason.find("rotation correction 180"), std::string::npos)
      << bounded[0].reason;
  EXPECT_NE(bounded[0].reason.find("at most 16"), std::string::npos) << bounded[0].reason;
  // Without the bound the flipped pose passes every other check: the bound is what stops it.
  const std::vector<LoopClosure> unbounded = run(0.0);
  ASSERT_EQ(unbounded.size(), 1u);
  EXPECT_TRUE(unbounded[0].accepted) << unbounded[0].reason;
}

}  // namespace
}  // namespace obm::frontend
