// Spinning LiDAR model: ring layout, exact geometry without noise, noise statistics, drop-outs,
// determinism and motion distortion, in a closed cube room whose true ranges are known.
#include <gtest/gtest.h>

#include <cmath>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/geometry.hpp"
#include "obm/sim/lidar.hpp"

using namespace obm;
using namespace obm::sim;

namespace {
constexpr double kHalf = 10.0;  // cube room [-10, 10]^3

RaycastScene cubeRoom() {
  SceneMesh s;
  MeshBuilder(s).aabb(Eigen::Vector3d::Constant(-kHalf), Eigen::Vector3d::Constant(kHalf),
                      Material::Wall);
  return RaycastScene(s);
}

// Range from `o` along unit `d` to the inside of the cube room.
double trueRange(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double t = 1e30;
  for (int k = 0; k < 3; ++k) {
    if (d[k] > 1e-12) t = std::min(t, (kHalf - o[k]) / d[k]);
    if (d[k] < -1e-12) t = std::min(t, (-kHalf - o[k]) / d[k]);
  }
  return t;
}

LidarParams small() {
  LidarParams p;
  p.layout = "uniform";
  p.rings = 16;
  p.max_elevation_deg = 15.0;
  p.min_elevation_deg = -15.0;
  p.azimuth_step_deg = 1.0;
  p.threads = 2;
  return p;
}
}  // namespace

TEST(LidarLayout, Hdl64RingAngles) {
  LidarParams p;  // defaults: HDL-64E
  const auto el = p.ringElevations();
  ASSERT_EQ(el.size(), 64u);
  EXPECT_NEAR(el.front() * kRadToDeg, 2.0, 1e-9);
  EXPECT_NEAR(el.back() * kRadToDeg, -24.9, 1e-9);
  for (std::size_t i = 1; i < el.size(); ++i) EXPECT_LT(el[i], el[i - 1]) << "ring " << i;
  // Upper block: 1/3° spacing; lower block: (24.9 − 8.83)/31 ≈ 0.518°.
  for (std::size_t i = 1; i < 32; ++i)
    EXPECT_NEAR((el[i - 1] - el[i]) * kRadToDeg, 1.0 / 3.0, 1e-9);
  for (std::size_t i = 33; i < 64; ++i)
    EXPECT_NEAR((el[i - 1] - el[i]) * kRadToDeg, (24.9 - 8.83) / 31.0, 1e-9);
  EXPECT_NEAR((el[0] - el[63]) * kRadToDeg, 26.9, 1e-9);  // datasheet vertical field of view
  EXPECT_EQ(p.columns(), 2118u);                          // 360° / 0.17°
  EXPECT_EQ(p.raysPerSweep(), 64u * 2118u);               // ≈ 130k rays per sweep
  EXPECT_DOUBLE_EQ(p.max_range, 120.0);
  EXPECT_DOUBLE_EQ(p.range_noise_sigma, 0.02);

  LidarParams v;
  v.layout = "vlp16";
  const auto ev = v.ringElevations();
  ASSERT_EQ(ev.size(), 16u);
  EXPECT_NEAR(ev.front() * kRadToDeg, 15.0, 1e-9);
  EXPECT_NEAR(ev.back() * kRadToDeg, -15.0, 1e-9);
}

TEST(LidarLayout, ColumnsSpanTheFullCircleClockwiseFromBehind) {
  LidarParams p;
  p.noise = false;
  const LidarSimulator lidar(p);
  const std::size_t n = p.columns();
  const double step = 2.0 * M_PI / static_cast<double>(n);
  EXPECT_NEAR(lidar.azimuth(0), M_PI - 0.5 * step, 1e-12);
  EXPECT_NEAR(lidar.azimuth(n / 2), M_PI - (n / 2 + 0.5) * step, 1e-12);
  EXPECT_NEAR(lidar.azimuth(n - 1), -M_PI + 0.5 * step, 1e-12);
  for (std::size_t c = 0; c < n; c += 97) {
    const Eigen::Vector3f d = lidar.direction(5, c);
    EXPECT_NEAR(std::atan2(d.y(), d.x()), lidar.azimuth(c), 1e-5) << "column " << c;
    EXPECT_NEAR(d.norm(), 1.0f, 1e-6f);
    EXPECT_NEAR(std::asin(d.z()), p.ringElevations()[5], 1e-6);
  }
}

TEST(LidarLayout, ZeroRaysAndBadKeysAreConfigErrorsNamingTheKey) {
  const auto load = [](const std::string& yaml) {
    return LidarParams::load(ConfigNode::fromString(yaml, "sensor.yaml"));
  };
  try {
    load("layout: custom\nelevations_deg: []\n");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("elevations_deg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("zero rays"), std::string::npos) << e.what();
  }
  try {
    load("azimuth_step_deg: 0\n");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("azimuth_step_deg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load("layout: uniform\nrings: 0\n"), ConfigError);
  EXPECT_THROW(load("layout: hdl65\n"), ConfigError);
  EXPECT_THROW(load("rnage_noise_sigma: 0.1\n"), ConfigError);  // misspelt key
  EXPECT_EQ(load("layout: vlp16\nazimuth_step_deg: 0.2\n").raysPerSweep(), 16u * 1800u);
}

TEST(Lidar, NoiseFreePointsLieExactlyOnTheWalls) {
  const RaycastScene room = cubeRoom();
  LidarParams p = small();
  p.noise = false;
  const LidarSimulator lidar(p);
  const Eigen::Isometry3d T = makeIsometry(fromEulerZYX({0.3, 0.1, -0.05}), {1.0, -2.0, 0.5});
  const LidarSweep s = lidar.simulate(room, T, 0.0, 1);
  ASSERT_EQ(s.rays, p.raysPerSweep());
  ASSERT_EQ(s.cloud.size(), s.rays);  // closed room, no noise: every ray returns
  ASSERT_EQ(s.ring.size(), s.cloud.size());
  int quadrant[4] = {0, 0, 0, 0};  // the sweep covers all directions evenly
  for (const auto& q : s.cloud.points) ++quadrant[(q.x() > 0 ? 1 : 0) + (q.y() > 0 ? 2 : 0)];
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(quadrant[k], s.cloud.size() / 4.0, s.cloud.size() / 50.0);
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    const Eigen::Vector3d pw = T * s.cloud.points[i].cast<double>();
    EXPECT_NEAR(pw.cwiseAbs().maxCoeff(), kHalf, 2e-4) << "point " << i;
  }
}

TEST(Lidar, RangeNoiseHasTheConfiguredStatistics) {
  const RaycastScene room = cubeRoom();
  LidarParams p = small();
  p.azimuth_step_deg = 0.25;  // 16 × 1440 = 23k rays
  p.dropout_probability = 0.0;
  p.intensity_noise_sigma = 0.0;
  const LidarSimulator lidar(p);
  const Eigen::Isometry3d T = makeIsometry(Eigen::Matrix3d::Identity(), {0.5, 0.2, 0.0});
  const LidarSweep s = lidar.simulate(room, T, 0.0, 7);
  ASSERT_GT(s.cloud.size(), 20000u);
  double sum = 0, sum2 = 0;
  for (const auto& q : s.cloud.points) {
    const Eigen::Vector3d d = q.cast<double>().normalized();
    const double e = q.cast<double>().norm() - trueRange(T.translation(), d);
    sum += e;
    sum2 += e * e;
  }
  const double n = static_cast<double>(s.cloud.size());
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4.0 * 0.02 / std::sqrt(n));
  EXPECT_NEAR(sd, 0.02, 0.02 * 0.03);

  // Random drop-outs remove the configured fraction.
  p.dropout_probability = 0.2;
  const LidarSweep s2 = LidarSimulator(p).simulate(room, T, 0.0, 7);
  const double kept = static_cast<double>(s2.cloud.size()) / static_cast<double>(s2.rays);
  EXPECT_NEAR(kept, 0.8, 0.01);
}

TEST(Lidar, GrazingIncidenceLosesReturns) {
  // A sensor 0.3 m above a large floor: far floor returns hit at grazing angles and are lost.
  SceneMesh s;
  MeshBuilder(s).aabb({-200, -200, -1}, {200, 200, -0.3}, Material::Sidewalk);
  const RaycastScene floor(s);
  LidarParams p = small();
  p.range_at_10pct = 0.0;
  p.dropout_probability = 0.0;
  const LidarSweep noisy = LidarSimulator(p).simulate(floor, Eigen::Isometry3d::Identity(), 0, 3);
  p.noise = false;
  const LidarSweep ideal = LidarSimulator(p).simulate(floor, Eigen::Isometry3d::Identity(), 0, 3);
  EXPECT_LT(noisy.cloud.size(), ideal.cloud.size());
  for (const auto& q : noisy.cloud.points) {
    const double incidence = std::acos(0.3 / q.cast<double>().norm()) * kRadToDeg;
    EXPECT_LT(incidence, p.grazing_full_deg + 0.5);
  }
}

TEST(Lidar, SameSeedSameSweepForAnyThreadCount) {
  const RaycastScene room = cubeRoom();
  LidarParams p = small();
  p.dropout_probability = 0.1;
  p.threads = 1;
  const LidarSweep a = LidarSimulator(p).simulate(room, Eigen::Isometry3d::Identity(), 0.0, 42);
  p.threads = 2;
  const LidarSweep b = LidarSimulator(p).simulate(room, Eigen::Isometry3d::Identity(), 0.0, 42);
  const LidarSweep c = LidarSimulator(p).simulate(room, Eigen::Isometry3d::Identity(), 0.0, 43);
  ASSERT_EQ(a.cloud.size(), b.cloud.size());
  for (std::size_t i = 0; i < a.cloud.size(); ++i) {
    ASSERT_EQ(a.cloud.points[i], b.cloud.points[i]);
    ASSERT_EQ(a.cloud.intensity[i], b.cloud.intensity[i]);
  }
  bool differs = a.cloud.size() != c.cloud.size();
  for (std::size_t i = 0; !differs && i < a.cloud.size(); ++i)
    differs = a.cloud.points[i] != c.cloud.points[i];
  EXPECT_TRUE(differs);
}

TEST(Lidar, MotionDistortionMeasuresFromThePoseAtEachFiringTime) {
  const RaycastScene room = cubeRoom();
  LidarParams p = small();
  p.noise = false;
  p.motion_distortion = true;
  const LidarSimulator lidar(p);
  // 10 m/s forward and 90°/s yaw: 1 m and 9° during the sweep.
  const PoseAtTime pose = [](double t) {
    return makeIsometry(fromEulerZYX({0.5 * M_PI * t, 0, 0}), {10.0 * t, 0.0, 0.0});
  };
  const LidarSweep s = lidar.simulate(room, pose, 0.0, 1);
  ASSERT_EQ(s.time_offset.size(), s.cloud.size());
  EXPECT_NEAR(lidar.columnTimeOffset(0), -0.05, 1e-3);
  EXPECT_NEAR(lidar.columnTimeOffset(p.columns() - 1), 0.05, 1e-3);
  double max_err_sweep_pose = 0.0;
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    const Eigen::Vector3d q = s.cloud.points[i].cast<double>();
    // Exact with the pose at the firing time ...
    EXPECT_NEAR((pose(s.time_offset[i]) * q).cwiseAbs().maxCoeff(), kHalf, 2e-4);
    // ... while the sweep's single pose misplaces the early and late columns.
    max_err_sweep_pose =
        std::max(max_err_sweep_pose, std::fabs((pose(0.0) * q).cwiseAbs().maxCoeff() - kHalf));
  }
  EXPECT_GT(max_err_sweep_pose, 0.3);
}
