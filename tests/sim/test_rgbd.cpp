// RGB-D camera model: exact depth without noise, Kinect-like axial noise statistics, disparity
// quantisation, depth limits and projector shadows, looking at a wall at a known distance.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/sim/geometry.hpp"
#include "obm/sim/rgbd_camera.hpp"

using namespace obm;
using namespace obm::sim;

namespace {
// A wall facing the camera at depth z (camera at the origin looking along +z).
RaycastScene wallAt(double z) {
  SceneMesh s;
  MeshBuilder(s).aabb({-50, -50, z}, {50, 50, z + 1}, Material::Wall);
  return RaycastScene(s);
}

RgbdParams ideal() {
  RgbdParams p;
  p.width = 160;
  p.height = 120;
  p.fx = p.fy = 131.25;
  p.cx = 79.5;
  p.cy = 59.5;
  p.noise = false;
  p.disparity_step_px = 0.0;
  p.projector_shadow = false;
  p.threads = 2;
  return p;
}

void stats(const DepthFrame& f, double& mean, double& sd) {
  double s = 0, s2 = 0, n = 0;
  for (float d : f.depth)
    if (d > 0) s += d, s2 += static_cast<double>(d) * d, n += 1;
  mean = s / n;
  sd = std::sqrt(std::max(0.0, s2 / n - mean * mean));
}
}  // namespace

TEST(Rgbd, DefaultsAreTheTumKinectIntrinsics) {
  const RgbdParams p;
  EXPECT_EQ(p.width, 640);
  EXPECT_EQ(p.height, 480);
  EXPECT_DOUBLE_EQ(p.fx, 525.0);
  EXPECT_DOUBLE_EQ(p.fy, 525.0);
  EXPECT_DOUBLE_EQ(p.cx, 319.5);
  EXPECT_DOUBLE_EQ(p.cy, 239.5);
  EXPECT_DOUBLE_EQ(p.min_depth, 0.4);
  EXPECT_DOUBLE_EQ(p.max_depth, 8.0);
  EXPECT_THROW(RgbdParams::load(ConfigNode::fromString("width: 0\n", "cam.yaml")), ConfigError);
}

TEST(Rgbd, NoiseFreeDepthIsExactAndBackProjectsOntoThePlane) {
  const RaycastScene wall = wallAt(2.0);
  const RgbdSimulator cam(ideal());
  const DepthFrame f = cam.render(wall, Eigen::Isometry3d::Identity(), 0.0, 1);
  ASSERT_EQ(f.validCount(), cam.params().pixels());
  for (float d : f.depth) ASSERT_NEAR(d, 2.0f, 1e-5f);
  const PointCloud c = cam.backProject(f);
  ASSERT_EQ(c.size(), f.validCount());
  EXPECT_NEAR(c.points.front().x(), (0 - 79.5) / 131.25 * 2.0, 1e-5);
  for (const auto& q : c.points) ASSERT_NEAR(q.z(), 2.0f, 1e-5f);
}

TEST(Rgbd, AxialNoiseGrowsWithTheSquareOfDepth) {
  RgbdParams p = ideal();
  p.noise = true;
  p.lateral_sigma_px = 0.0;
  p.dropout_probability = 0.0;
  const RgbdSimulator cam(p);
  for (double z : {1.0, 3.0}) {
    double mean = 0, sd = 0;
    stats(cam.render(wallAt(z), Eigen::Isometry3d::Identity(), 0.0, 5), mean, sd);
    // Incidence is ≤ 33° at the image corners; the expected σ is between the on-axis value and
    // the value at the widest angle.
    const double s0 = p.axialSigma(z, 0.0);
    EXPECT_NEAR(mean, z, 4.0 * s0 / std::sqrt(160.0 * 120.0));
    EXPECT_GT(sd, 0.95 * s0) << "z = " << z;
    EXPECT_LT(sd, 1.05 * p.axialSigma(z, 0.3)) << "z = " << z;
  }
  // σ(3 m) / σ(1 m) follows a + b (z − z₀)².
  EXPECT_NEAR(p.axialSigma(3.0) / p.axialSigma(1.0),
              (0.0012 + 0.0019 * 2.6 * 2.6) / (0.0012 + 0.0019 * 0.6 * 0.6), 1e-9);
}

TEST(Rgbd, DisparityQuantisationGivesDiscreteDepthsWithAStepGrowingWithDepth) {
  RgbdParams p = ideal();
  p.disparity_step_px = 0.125;
  const RgbdSimulator cam(p);
  const double fb = p.fx * p.baseline;
  for (double z : {1.03, 2.71}) {
    const DepthFrame f = cam.render(wallAt(z), Eigen::Isometry3d::Identity(), 0.0, 1);
    std::set<float> values(f.depth.begin(), f.depth.end());
    values.erase(0.f);
    ASSERT_FALSE(values.empty());
    for (float d : values) {
      const double k = fb / d / 0.125;  // must be an integer number of disparity steps
      EXPECT_NEAR(k, std::round(k), 1e-3) << d;
    }
    EXPECT_NEAR(*values.begin(), z, z * z * 0.125 / fb);
  }
  EXPECT_GT(p.quantize(3.0) - p.quantize(2.95) + 1e-9, 0.0);
  const double step1 = p.quantize(1.0) - fb / (fb / 1.0 + 0.125);
  const double step3 = p.quantize(3.0) - fb / (fb / 3.0 + 0.125);
  EXPECT_GT(step3, 5.0 * step1);
}

TEST(Rgbd, DepthOutsideTheRangeIsInvalid) {
  const RgbdSimulator cam(ideal());
  EXPECT_EQ(cam.render(wallAt(0.3), Eigen::Isometry3d::Identity(), 0, 1).validCount(), 0u);
  EXPECT_EQ(cam.render(wallAt(9.0), Eigen::Isometry3d::Identity(), 0, 1).validCount(), 0u);
}

TEST(Rgbd, ProjectorShadowLeavesHolesBesideForegroundObjects) {
  SceneMesh s;
  MeshBuilder b(s);
  b.aabb({-50, -50, 3}, {50, 50, 4}, Material::Wall);
  b.aabb({-0.2, -0.2, 1.0}, {0.2, 0.2, 1.2}, Material::Clutter);
  const RaycastScene scene(s);
  RgbdParams p = ideal();
  const auto without = RgbdSimulator(p).render(scene, Eigen::Isometry3d::Identity(), 0, 1);
  p.projector_shadow = true;
  const auto with = RgbdSimulator(p).render(scene, Eigen::Isometry3d::Identity(), 0, 1);
  EXPECT_EQ(without.validCount(), p.pixels());
  const std::size_t holes = p.pixels() - with.validCount();
  EXPECT_GT(holes, 50u);
  // The projector is to the right (+x), so the shadow falls left of the box on the wall.
  int left = 0, right = 0;
  for (int v = 0; v < with.height; ++v)
    for (int u = 0; u < with.width; ++u)
      if (with.at(u, v) == 0.f) (u < with.width / 2 ? left : right)++;
  EXPECT_GT(left, 10 * std::max(1, right));
}
