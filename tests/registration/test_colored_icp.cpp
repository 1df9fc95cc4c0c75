// Coloured ICP (IcpParams::color_weight): the tangent-plane colour gradients of a prepared target
// and the photometric term that pins a pose the geometry leaves free (a textured wall).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "obm/core/errors.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"

namespace obm {
namespace {

using test::poseError;
using test::texturedWall;
using test::wallParams;
using test::wallPose;

TEST(ColoredIcp, GradientsOfALinearRampAreItsSlopeInThePlane) {
  // I = 0.1 + 2·(x + 0.2) on the plane z = 1: d = (2, 0, 0) per metre, d ⟂ n.
  PointCloud cloud;
  for (double x = -0.2; x <= 0.2; x += 0.01)
    for (double y = -0.2; y <= 0.2; y += 0.01) {
      const double g = 0.1 + 2.0 * (x + 0.2);
      const auto c = static_cast<std::uint8_t>(std::lround(255.0 * g));
      cloud.points.push_back(Vector3f(float(x), float(y), 1.f));
      cloud.colors.push_back(Color3u8(c, c, c));
    }
  registration::PreparedTarget::Options o;
  o.color_gradients = true;
  o.min_planarity = 0.0;
  const registration::PreparedTarget t(cloud, o);
  ASSERT_TRUE(t.hasColorGradients());
  std::size_t checked = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < t.size(); ++i) {
    const Vector3f& p = t.cloud().points[i];
    if (std::abs(p.x()) > 0.15 || std::abs(p.y()) > 0.15) continue;  // away from the border
    const Vector3f& d = t.colorGradients()[i];
    // Each point: within the 8-bit quantisation of the ramp over its neighbourhood.
    EXPECT_NEAR(d.x(), 2.0, 0.15) << i;
    EXPECT_NEAR(d.y(), 0.0, 0.15) << i;
    EXPECT_NEAR(d.dot(t.normals()[i]), 0.0, 1e-3) << i;
    mean += d.cast<double>();
    ++checked;
  }
  ASSERT_GT(checked, 500u);
  mean /= double(checked);
  EXPECT_NEAR(mean.x(), 2.0, 0.02);  // the quantisation averages out
  EXPECT_NEAR(mean.y(), 0.0, 0.02);

  registration::PreparedTarget::Options off = o;
  off.color_gradients = false;
  EXPECT_FALSE(registration::PreparedTarget(cloud, off).hasColorGradients());
  PointCloud grey = cloud;
  grey.colors.clear();
  EXPECT_FALSE(registration::PreparedTarget(grey, o).hasColorGradients());
}

TEST(ColoredIcp, TheTexturePinsTheInPlaneShiftThatGeometryLeavesFree) {
  // Two independent samplings of the same textured wall; the source is seen from a camera moved
  // 4 cm / 3 cm along the wall and rotated 2° about the wall normal. Point-to-plane ICP has no
  // constraint in the wall's plane and stays where it started; the photometric term recovers it.
  const Isometry3d T_target_source_true =
      makeIsometry(Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                   Eigen::Vector3d(0.04, -0.03, 0.0));
  const PointCloud target = texturedWall(0.008, 1, wallPose());
  const PointCloud source =
      texturedWall(0.012, 2, T_target_source_true.inverse() * wallPose());

  registration::IcpParams geometric = wallParams();
  registration::IcpParams colored = geometric;
  colored.color_weight = 0.033;  // Park et al.'s σ = 0.968
  colored.color_kernel_scale = 0.2;

  const registration::PreparedTarget target_geo(target, geometric.targetOptions());
  const registration::PreparedTarget target_col(target, colored.targetOptions());
  ASSERT_FALSE(target_geo.hasColorGradients());
  ASSERT_TRUE(target_col.hasColorGradients());

  const registration::MatchResult geo =
      registration::IcpMatcher(geometric).match(source, target_geo, Isometry3d::Identity());
  const registration::MatchResult col =
      registration::IcpMatcher(colored).match(source, target_col, Isometry3d::Identity());
  const auto [geo_t, geo_r] = poseError(geo.T_target_source, T_target_source_true);
  const auto [col_t, col_r] = poseError(col.T_target_source, T_target_source_true);
  EXPECT_GT(geo_t, 0.03) << "geometric ICP should not see the in-plane shift";
  EXPECT_LT(col_t, 0.004) << "coloured ICP: " << col_t << " m, " << col_r << " deg";
  EXPECT_LT(col_r, 0.3);
  // The quality sees what pinned the pose: a plane is degenerate for the geometric cost, not for
  // the coloured one.
  std::printf("conditioning: geometric %.2e (%s), coloured %.2e (%s)\n", geo.conditioning,
              toString(geo.status), col.conditioning, toString(col.status));
  EXPECT_EQ(geo.status, registration::MatchStatus::Degenerate);
  EXPECT_EQ(col.status, registration::MatchStatus::Ok);
  EXPECT_GT(col.conditioning, 100.0 * geo.conditioning);
  EXPECT_GT(col.quality, geo.quality);

  // Colourless source: the photometric term is off and the result is the geometric one.
  PointCloud grey = source;
  grey.colors.clear();
  const registration::MatchResult off =
      registration::IcpMatcher(colored).match(grey, target_col, Isometry3d::Identity());
  EXPECT_TRUE(off.T_target_source.isApprox(geo.T_target_source, 1e-9));
}

TEST(ColoredIcp, ColouredInliersTellASlideAlongTheWallFromTheRightPose) {
  // A pose slid 6 cm along a textured wall pairs nearly every point within the inlier threshold,
  // as the right pose does; the grey residuals tell them apart (ConfidenceParams::
  // color_inlier_threshold), which the inlier counts that choose between ICP starts rely on.
  const PointCloud target = texturedWall(0.008, 1, wallPose());
  const PointCloud source = texturedWall(0.012, 2, wallPose());  // T_target_source = identity
  registration::IcpParams icp = wallParams();
  icp.color_weight = 0.033;
  const registration::PreparedTarget prepared(target, icp.targetOptions());
  ASSERT_TRUE(prepared.hasColorGradients());
  const std::vector<float> grey = registration::colorIntensities(source, prepared, icp);
  ASSERT_EQ(grey.size(), source.size());
  const Isometry3d right = Isometry3d::Identity();
  const Isometry3d slid = makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.06, 0, 0));
  registration::ConfidenceParams geometric;
  geometric.inlier_threshold = 0.01;
  registration::ConfidenceParams coloured = geometric;
  coloured.color_inlier_threshold = 0.05;
  auto inliers = [&](const Isometry3d& T, const registration::ConfidenceParams& c,
                     const std::vector<float>* intensity) {
    return double(
        registration::evaluateAlignment(source.points, nullptr, prepared, T, icp, c, intensity)
            .num_inliers);
  };
  const double geo_right = inliers(right, geometric, &grey);
  const double geo_slid = inliers(slid, geometric, &grey);
  const double col_right = inliers(right, coloured, &grey);
  const double col_slid = inliers(slid, coloured, &grey);
  std::printf("inliers: geometric %.0f right / %.0f slid, coloured %.0f right / %.0f slid\n",
              geo_right, geo_slid, col_right, col_slid);
  EXPECT_GT(geo_slid, 0.9 * geo_right) << "the geometry alone barely sees the slide";
  EXPECT_GT(col_right, 0.9 * geo_right) << "the right pose's grey residuals are within 0.05";
  EXPECT_LT(col_slid, 0.5 * col_right) << "the slide lays the wrong texture on the target";
  // Off (threshold 0), without intensities, or without the photometric term: geometric counts.
  EXPECT_EQ(inliers(slid, geometric, &grey), geo_slid);
  EXPECT_EQ(inliers(slid, coloured, nullptr), geo_slid);
  registration::IcpParams no_colour = icp;
  no_colour.color_weight = 0.0;
  EXPECT_EQ(double(registration::evaluateAlignment(source.points, nullptr, prepared, slid,
                                                   no_colour, coloured, &grey)
                       .num_inliers),
            geo_slid);
  registration::ConfidenceParams bad;
  bad.color_inlier_threshold = -0.01;
  EXPECT_THROW(bad.validate(), ContractError);
}

TEST(ColoredIcp, ParametersAreValidated) {
  registration::IcpParams p;
  p.color_weight = -0.1;
  EXPECT_THROW(p.validate(), ContractError);
  p.color_weight = 0.1;
  p.color_kernel_scale = 0.0;
  EXPECT_THROW(p.validate(), ContractError);
  const std::vector<Vector3f> pts(40, Vector3f(0.f, 0.f, 1.f));
  const std::vector<float> intensity(3, 0.5f);
  PointCloud t;
  t.points = pts;
  EXPECT_THROW(registration::runIcp(pts, registration::PreparedTarget(t), Isometry3d::Identity(),
                                    registration::IcpParams(), nullptr, &intensity),
               ContractError);
}

/// A room seen by a depth camera (optical frame: x right, y down, z forward): back wall at 4.5 m,
/// floor, left wall, and a box 1 m in front of the camera.
PointCloud cameraRoom(std::uint64_t seed) {
  PointCloud c;
  std::mt19937_64 rng(seed);
  using test::sampleRect;
  sampleRect(c, {-2.f, -1.5f, 4.5f}, {4.f, 0.f, 0.f}, {0.f, 3.f, 0.f}, 6000, rng);    // back wall
  sampleRect(c, {-2.f, 1.2f, 0.5f}, {4.f, 0.f, 0.f}, {0.f, 0.f, 4.f}, 6000, rng);     // floor
  sampleRect(c, {-2.f, -1.5f, 0.5f}, {0.f, 2.7f, 0.f}, {0.f, 0.f, 4.f}, 4000, rng);   // left wall
  sampleRect(c, {-0.2f, 0.5f, 1.0f}, {0.5f, 0.f, 0.f}, {0.f, 0.7f, 0.f}, 1500, rng);  // box front
  sampleRect(c, {0.3f, 0.5f, 1.0f}, {0.f, 0.f, 0.4f}, {0.f, 0.7f, 0.f}, 1500, rng);   // box side
  sampleRect(c, {-0.2f, 0.5f, 1.0f}, {0.5f, 0.f, 0.f}, {0.f, 0.f, 0.4f}, 1500, rng);  // box top
  return c;
}

TEST(DepthNoiseWeights, FarNoisyDepthPullsLess) {
  // The source's depth carries the structured-light noise σ(z) = a + b·(z − z₀)² along each ray
  // (2 mm at 1 m, 3 cm at 4.5 m); the target (a local map) is clean. Weighting by 1/σ² lets the
  // near, precise points decide: over several noise draws the pose error shrinks.
  registration::IcpParams plain;
  plain.max_correspondence_distance = 0.15;
  plain.kernel = registration::RobustKernel::Huber;
  plain.kernel_scale = 0.02;
  plain.max_iterations = 60;
  registration::IcpParams weighted = plain;
  weighted.depth_noise_weights = true;
  const Isometry3d T_true =
      makeIsometry(Eigen::AngleAxisd(1.5 * kDegToRad, Eigen::Vector3d(0.3, 1.0, 0.2).normalized())
                       .toRotationMatrix(),
                   Eigen::Vector3d(0.03, -0.02, 0.04));
  const registration::PreparedTarget target(cameraRoom(1), plain.targetOptions());
  double err_plain = 0.0, err_weighted = 0.0;
  const int draws = 6;
  for (int k = 0; k < draws; ++k) {
    PointCloud src = cameraRoom(100 + k).transformed(T_true.inverse(), "camera");
    std::mt19937_64 rng(200 + k);
    std::normal_distribution<float> N(0.f, 1.f);
    for (auto& p : src.points) {
      const float dz = p.z() - 0.4f;
      const float sigma = 0.0012f + 0.0019f * dz * dz;
      p *= 1.f + sigma * N(rng) / p.z();  // along the ray: the depth z moves by sigma·N
    }
    err_plain += poseError(registration::IcpMatcher(plain)
                               .match(src, target, Isometry3d::Identity())
                               .T_target_source,
                           T_true)
                     .first;
    err_weighted += poseError(registration::IcpMatcher(weighted)
                                  .match(src, target, Isometry3d::Identity())
                                  .T_target_source,
                              T_true)
                        .first;
  }
  err_plain /= draws;
  err_weighted /= draws;
  std::printf("mean translation error: unweighted %.5f m, depth-noise weighted %.5f m\n", err_plain,
              err_weighted);
  EXPECT_LT(err_weighted, 0.8 * err_plain);  // measured 0.36 mm against 0.53 mm
}

}  // namespace
}  // namespace obm
