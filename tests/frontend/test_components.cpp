// The front-end's parts on tiny synthetic input: preprocessing, keyframe decision,
// constant-velocity model, place descriptor, parameter loading and the matcher fallback.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "obm/backend/optimizer.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/frontend/descriptor.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/frontend/keyframe_selector.hpp"
#include "obm/frontend/motion_model.hpp"
#include "obm/frontend/preprocess.hpp"
#include "obm/registration/obmnet_matcher.hpp"
#include "test_data.hpp"

namespace obm::frontend {
namespace {

Isometry3d pose(double x, double y, double z, double yaw_deg, double pitch_deg = 0.0) {
  return makeIsometry(fromEulerZYX(Eigen::Vector3d(yaw_deg, pitch_deg, 0.0) * kDegToRad),
                      Eigen::Vector3d(x, y, z));
}

double transDiff(const Isometry3d& a, const Isometry3d& b) {
  return (a.inverse() * b).translation().norm();
}
double rotDiff(const Isometry3d& a, const Isometry3d& b) {
  return rotationAngle((a.inverse() * b).linear());
}

// ---------------------------------------------------------------------------------------------
TEST(Preprocess, DropsNonFiniteAndOutOfRangePointsAndCountsThem) {
  PointCloud c;
  c.intensity = {};
  c.push_back({1.0f, 0.0f, 0.0f});      // 1 m: too near
  c.push_back({3.0f, 0.0f, 0.0f});      // kept
  c.push_back({0.0f, 4.0f, 0.0f});      // kept
  c.push_back({NAN, 1.0f, 1.0f});       // non-finite
  c.push_back({0.0f, 0.0f, INFINITY});  // non-finite
  c.push_back({200.0f, 0.0f, 0.0f});    // too far
  c.timestamp = 12.5;
  PreprocessStats s;
  const PointCloud out = cleanAndCrop(c, 2.0, 100.0, &s);
  EXPECT_EQ(s.points_in, 6u);
  EXPECT_EQ(s.non_finite, 2u);
  EXPECT_EQ(s.cropped, 2u);
  EXPECT_EQ(s.points_out, 2u);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out.points[0], Vector3f(3.0f, 0.0f, 0.0f));
  EXPECT_EQ(out.points[1], Vector3f(0.0f, 4.0f, 0.0f));
  EXPECT_DOUBLE_EQ(out.timestamp, 12.5);
  // max_range <= 0: no upper bound.
  EXPECT_EQ(cleanAndCrop(c, 2.0, 0.0).size(), 3u);
}

TEST(Preprocess, VoxelGridThenSamplesExactlyNPointsReproducibly) {
  PointCloud c;
  std::mt19937_64 gen(3);
  std::uniform_real_distribution<float> U(-20.f, 20.f);
  for (int i = 0; i < 20000; ++i) c.push_back({U(gen), U(gen), U(gen)});
  PreprocessParams p;
  p.min_range = 0.0;
  p.max_range = 0.0;
  p.voxel = 2.0;
  p.max_points = 0;
  std::mt19937_64 rng1(5), rng2(5);
  const PointCloud voxelised = preprocess(c, p, rng1);
  EXPECT_LT(voxelised.size(), c.size());
  EXPECT_LE(voxelised.size(), 20u * 20u * 20u);  // at most one point per 2 m voxel of the cube
  p.max_points = 500;
  std::mt19937_64 a(5), b(5);
  PreprocessStats s;
  const PointCloud s1 = preprocess(c, p, a, &s), s2 = preprocess(c, p, b);
  ASSERT_EQ(s1.size(), 500u);
  EXPECT_EQ(s.points_out, 500u);
  for (std::size_t i = 0; i < s1.size(); ++i) EXPECT_EQ(s1.points[i], s2.points[i]);
}

TEST(Preprocess, EmptyAndAllNanSweepsGiveEmptyClouds) {
  PointCloud empty;
  std::mt19937_64 rng(1);
  EXPECT_TRUE(preprocess(empty, PreprocessParams(), rng).empty());
  PointCloud nan;
  for (int i = 0; i < 100; ++i) nan.push_back({NAN, NAN, NAN});
  PreprocessStats s;
  EXPECT_TRUE(preprocess(nan, PreprocessParams(), rng, &s).empty());
  EXPECT_EQ(s.non_finite, 100u);
}

// ---------------------------------------------------------------------------------------------
TEST(KeyframeSelector, DistanceRotationAndFrameCountEachTrigger) {
  KeyframeParams p;
  p.distance = 2.0;
  p.rotation = 10.0 * kDegToRad;
  p.max_frames = 0;
  const KeyframeSelector sel(p);
  const Isometry3d kf = pose(5, -3, 1, 30);
  EXPECT_FALSE(sel.isKeyframe(kf, kf * pose(1.9, 0, 0, 0), 100));
  EXPECT_TRUE(sel.isKeyframe(kf, kf * pose(2.0, 0, 0, 0), 1));
  EXPECT_TRUE(sel.isKeyframe(kf, kf * pose(0, 1.5, 1.5, 0), 1));  // 2.12 m in any direction
  EXPECT_FALSE(sel.isKeyframe(kf, kf * pose(0, 0, 0, 9.9), 1));
  EXPECT_TRUE(sel.isKeyframe(kf, kf * pose(0, 0, 0, 10.1), 1));
  EXPECT_TRUE(sel.isKeyframe(kf, kf * pose(0, 0, 0, 0, -10.1), 1));  // pitch counts too
  p.max_frames = 5;
  const KeyframeSelector by_count(p);
  EXPECT_FALSE(by_count.isKeyframe(kf, kf, 4));
  EXPECT_TRUE(by_count.isKeyframe(kf, kf, 5));
  p.distance = 0.0;
  EXPECT_THROW(KeyframeSelector{p}, ConfigError);
}

TEST(KeyframeSelector, OverlapDropTriggersAfterTheMinimumGap) {
  KeyframeParams p;
  p.distance = 2.0;
  const Isometry3d kf = pose(1, 2, 0, 30);
  const Isometry3d near = kf * pose(0.1, 0, 0, 1);
  // Off by default: only distance, rotation and the frame count decide.
  EXPECT_FALSE(KeyframeSelector(p).isKeyframe(kf, near, 5, 0.3, 0.95));
  p.overlap_drop = 0.9;
  p.overlap_min_frames = 3;
  const KeyframeSelector sel(p);
  EXPECT_TRUE(sel.isKeyframe(kf, near, 3, 0.85, 0.95));   // 0.85 < 0.9 x 0.95
  EXPECT_FALSE(sel.isKeyframe(kf, near, 3, 0.86, 0.95));  // 0.86 > 0.855
  EXPECT_FALSE(sel.isKeyframe(kf, near, 2, 0.5, 0.95));   // the map has not taken the last one yet
  EXPECT_FALSE(sel.isKeyframe(kf, near, 10, 0.5, 0.0));   // no recent frames to compare with
  EXPECT_TRUE(sel.isKeyframe(kf, kf * pose(2.0, 0, 0, 0), 1, 0.95, 0.95));  // distance still counts
  p.overlap_drop = 1.0;
  EXPECT_THROW(p.validate(), std::exception);
}

// ---------------------------------------------------------------------------------------------
TEST(ConstantVelocityModel, PredictsAConstantScrewMotionExactly) {
  const Isometry3d step = pose(1.2, 0.1, 0.02, 3.0, 0.5);
  ConstantVelocityModel m;
  EXPECT_TRUE(m.predict(0.0).isApprox(Isometry3d::Identity()));
  Isometry3d T = pose(10, 20, 1, 45);
  m.update(T, 0.0);
  EXPECT_TRUE(m.predict(0.1).isApprox(T));  // one pose: no velocity yet
  for (int i = 1; i <= 5; ++i) {
    T = T * step;
    m.update(T, 0.1 * i);
    const Isometry3d predicted = m.predict(0.1 * (i + 1));
    EXPECT_LT(transDiff(predicted, T * step), 1e-9);
    EXPECT_LT(rotDiff(predicted, T * step), 1e-9);
  }
  EXPECT_TRUE(m.lastMotion().isApprox(step, 1e-12));
}

TEST(ConstantVelocityModel, ScalesTheMotionByTheTimeBetweenFrames) {
  const Isometry3d step = pose(1.0, 0.0, 0.0, 4.0);
  ConstantVelocityModel m;
  m.update(Isometry3d::Identity(), 1.0);
  m.update(step, 1.1);
  // Two frame periods after the last pose (a dropped frame): the same twist for twice the time.
  const Isometry3d two = m.predict(1.3, true);
  EXPECT_LT(transDiff(two, step * step * step), 1e-9);
  EXPECT_LT(rotDiff(two, step * step * step), 1e-9);
  // Without time stamps: one step.
  EXPECT_LT(transDiff(m.predict(1.3, false), step * step), 1e-9);
  EXPECT_GT(transDiff(m.predict(1.3, false), step * step * step), 0.5);
  // A non-increasing time stamp falls back to one step.
  EXPECT_LT(transDiff(m.predict(1.1, true), step * step), 1e-9);
  // The steps it extrapolated (what the recovery's gap paths start from).
  EXPECT_NEAR(m.steps(1.3, true), 2.0, 1e-9);
  EXPECT_NEAR(m.steps(1.3, false), 1.0, 1e-12);
  EXPECT_NEAR(m.steps(1.1, true), 1.0, 1e-12);
  EXPECT_LT(transDiff(m.lastPose(), step), 1e-12);
}

TEST(ConstantVelocityModel, CorrectionMovesTheHistoryRigidly) {
  const Isometry3d step = pose(1.0, 0.2, 0.0, 2.0);
  ConstantVelocityModel m;
  m.update(Isometry3d::Identity(), 0.0);
  m.update(step, 0.1);
  const Isometry3d C = pose(0.5, -2.0, 0.1, 7.0);
  m.applyCorrection(C);
  EXPECT_LT(transDiff(m.predict(0.2), C * step * step), 1e-9);
  EXPECT_TRUE(m.lastMotion().isApprox(step, 1e-12));
  m.reset();
  EXPECT_EQ(m.count(), 0);
}

// ---------------------------------------------------------------------------------------------
PointCloud randomPlace(std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<float> U(-60.f, 60.f), H(0.f, 12.f);
  PointCloud c;
  for (int b = 0; b < 40; ++b) {  // 40 random "buildings" of random height
    const float x = U(gen), y = U(gen), h = H(gen);
    for (int k = 0; k < 50; ++k)
      c.push_back({x + 0.05f * k, y, -1.7f + h * static_cast<float>(k) / 49.f});
  }
  return c;
}

TEST(PlaceDescriptor, IsHeadingInvariantAndRecoversTheYaw) {
  DescriptorParams p;
  const PointCloud a = randomPlace(1);
  const double yaw = 48.0 * kDegToRad;  // 8 sectors of 6°
  const PointCloud b = a.transformed(
      makeIsometry(expSO3(Eigen::Vector3d(0, 0, yaw)), Eigen::Vector3d::Zero()).inverse(), "b");
  const PlaceDescriptor da = computeDescriptor(a, p), db = computeDescriptor(b, p);
  ASSERT_EQ(da.bins.rows(), p.rings);
  ASSERT_EQ(da.bins.cols(), p.sectors);
  const DescriptorMatch same = compareDescriptors(da, db);
  EXPECT_LT(same.distance, 0.05);
  // p_b = R(yaw)⁻¹·p_a: T_b_a is a rotation by −48° about z.
  EXPECT_NEAR(same.yaw, -yaw, 7.0 * kDegToRad);
  const DescriptorMatch other = compareDescriptors(da, computeDescriptor(randomPlace(2), p));
  EXPECT_GT(other.distance, same.distance + 0.1);
  EXPECT_DOUBLE_EQ(compareDescriptors(da, PlaceDescriptor()).distance, 1.0);
}

// ---------------------------------------------------------------------------------------------
TEST(FrontendParams, LoadsEverySectionAndNamesBadKeys) {
  const ConfigNode root = ConfigNode::fromString(R"(
preprocess: {min_range: 1.5, max_range: 80, voxel: 0.4, max_points: 5000}
keyframes: {distance: 3.0, rotation_deg: 15, revisit_radius: 5}
local_map: {keyframes: 8, voxel: 0.25, radius: 70}
tracking: {icp: {max_correspondence_distance: 0.8}, min_quality: 0.2,
           max_correction_rotation_deg: 6, floor_sigma_rotation_deg: 0.1}
loop_closure: {min_travel: 40, loss: "cauchy:2", descriptor: {rings: 10, sectors: 30},
               relocalisation: {confirmations: 3, agreement_rotation_deg: 4}}
matcher: {type: icp, fallback: icp, icp: {initial_max_correspondence_distance: 3.0}}
optimizer: {init: file, max_iterations: 20}
)",
                                                 "test.yaml");
  const FrontendParams p = FrontendParams::load(root);
  EXPECT_DOUBLE_EQ(p.preprocess.min_range, 1.5);
  EXPECT_EQ(p.preprocess.max_points, 5000u);
  EXPECT_DOUBLE_EQ(p.keyframes.rotation, 15.0 * kDegToRad);
  EXPECT_DOUBLE_EQ(p.keyframes.revisit_radius, 5.0);
  EXPECT_EQ(p.local_map.keyframes, 8u);
  EXPECT_DOUBLE_EQ(p.tracking.icp.max_correspondence_distance, 0.8);
  EXPECT_DOUBLE_EQ(p.tracking.max_correction_rotation, 6.0 * kDegToRad);
  EXPECT_DOUBLE_EQ(p.tracking.floor_sigma_rotation, 0.1 * kDegToRad);
  EXPECT_DOUBLE_EQ(p.loop_closure.min_travel, 40.0);
  EXPECT_EQ(p.loop_closure.loss.kind, backend::LossKind::Cauchy);
  EXPECT_DOUBLE_EQ(p.loop_closure.loss.scale, 2.0);
  EXPECT_EQ(p.loop_closure.descriptor.sectors, 30);
  EXPECT_EQ(p.loop_closure.relocalisation.confirmations, 3u);
  EXPECT_DOUBLE_EQ(p.loop_closure.relocalisation.agreement_rotation, 4.0 * kDegToRad);
  EXPECT_EQ(p.matcher.type, registration::MatcherKind::Icp);
  EXPECT_EQ(p.matcher_fallback, registration::MatcherKind::Icp);
  EXPECT_DOUBLE_EQ(p.matcher.icp.initial_max_correspondence_distance, 3.0);
  EXPECT_EQ(p.optimizer.max_iterations, 20);

  auto expectError = [](const std::string& yaml, const std::string& key) {
    try {
      FrontendParams::load(ConfigNode::fromString(yaml, "bad.yaml"));
      ADD_FAILURE() << "no error for: " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  };
  expectError("keyframes: {distanse: 3}", "keyframes.distanse");
  expectError("keyframes: {distance: -1}", "distance");
  expectError("keyframes: {revisit_radius: -2}", "revisit_radius");
  expectError("tracking: {min_quality: 2}", "min_quality");
  expectError("tracking: {icp: {kernel: blah}}", "tracking.icp.kernel");
  expectError("loop_closure: {loss: \"square:1\"}", "loop_closure.loss");
  expectError("loop_closure: {descriptor: {sectors: 2}}", "sectors");
  expectError("matcher: {type: sift}", "matcher.type");
  expectError("loop_closure: {relocalisation: {confirmation: 2}}",
              "loop_closure.relocalisation.confirmation");
  expectError("loop_closure: {relocalisation: {confirmations: 0}}", "confirmations");
  expectError("matcher: {type: icp, fallback: sift}", "matcher.fallback");
  expectError("loop_closure: {max_correction_rotation_deg: -1}", "max_correction_rotation_deg");
  expectError("local_map: {keyframes: 0}", "keyframes");
  expectError("tracking: {recovery_confirm_jumps: true}", "recovery_confirm_jumps");
  expectError("tracking: {recovery_confirmed_relative_inlier_ratio: 1.5}",
              "recovery_confirmed_relative_inlier_ratio");
  const FrontendParams jumps = FrontendParams::load(ConfigNode::fromString(
      "tracking: {recovery_agreement_translation: 0.3, recovery_confirm_jumps: true,\n"
      "           recovery_confirmed_relative_inlier_ratio: 0.5}",
      "jumps.yaml"));
  EXPECT_TRUE(jumps.tracking.recovery_confirm_jumps);
  EXPECT_DOUBLE_EQ(jumps.tracking.recovery_confirmed_relative_inlier_ratio, 0.5);
  // Loop edges may take the DCS loss with Φ calibrated by the optimiser; a zero Φ is an error.
  const FrontendParams dcs_auto =
      FrontendParams::load(ConfigNode::fromString("loop_closure: {loss: \"dcs:auto\"}", "auto.yaml"));
  EXPECT_EQ(backend::toString(dcs_auto.loop_closure.loss), "dcs:auto");
  expectError("loop_closure: {loss: \"dcs:0\"}", "loss");
}

TEST(FrontendParams, MissingModelFallsBackOnlyWhenConfigured) {
  const std::string dir = test::scratchDir("frontend_fallback");
  const std::string yaml = dir + "/map.yaml";
  std::ofstream(yaml) << "matcher:\n  type: obmnet+icp\n  fallback: icp\n  obmnet:\n"
                         "    model_path: models/none.pt\n";
  const FrontendParams p = FrontendParams::load(ConfigNode::loadFile(yaml));
  // The model path is resolved against the YAML file's folder.
  EXPECT_EQ(std::filesystem::path(p.matcher.obmnet.network.model_path),
            std::filesystem::path(dir) / "models/none.pt");
  const MatcherChoice c = chooseMatcher(p);
  EXPECT_TRUE(c.fell_back);
  EXPECT_EQ(c.config.type, registration::MatcherKind::Icp);
  EXPECT_NE(c.message.find("none.pt"), std::string::npos) << c.message;
  EXPECT_NE(c.message.find("fallback"), std::string::npos) << c.message;

  FrontendParams strict = p;
  strict.matcher_fallback.reset();
  try {
    chooseMatcher(strict);
    ADD_FAILURE() << "a missing model without fallback must be an error";
  } catch (const Error& e) {
    // IoError when the model file is missing; ConfigError when the build has no OBMNet at all.
    if (registration::obmNetAvailable())
      EXPECT_NE(dynamic_cast<const IoError*>(&e), nullptr) << e.what();
    else
      EXPECT_NE(dynamic_cast<const ConfigError*>(&e), nullptr) << e.what();
    EXPECT_NE(std::string(e.what()).find("none.pt"), std::string::npos) << e.what();
  }
  // ICP needs no model.
  FrontendParams icp = strict;
  icp.matcher.type = registration::MatcherKind::Icp;
  const MatcherChoice ci = chooseMatcher(icp);
  EXPECT_FALSE(ci.fell_back);
  EXPECT_EQ(ci.config.type, registration::MatcherKind::Icp);
}

}  // namespace
}  // namespace obm::frontend
