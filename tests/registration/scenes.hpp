#pragma once
// Synthetic scenes for the registration tests: axis-aligned rectangles (walls, floors, box
// faces) sampled uniformly with a seeded RNG, in metres.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/params.hpp"

namespace obm::test {

/// Samples `n` points uniformly on the axis-aligned rectangle with corner `origin` spanned by
/// `u` and `v`.
inline void sampleRect(PointCloud& cloud, const Eigen::Vector3f& origin, const Eigen::Vector3f& u,
                       const Eigen::Vector3f& v, std::size_t n, std::mt19937_64& rng) {
  std::uniform_real_distribution<float> U(0.f, 1.f);
  for (std::size_t i = 0; i < n; ++i) cloud.push_back(origin + U(rng) * u + U(rng) * v);
}

/// The five visible faces of the box [lo, hi] standing on the floor (no bottom face), `density`
/// points per m².
inline void sampleBox(PointCloud& c, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                      double density, std::mt19937_64& rng) {
  const Eigen::Vector3f d = hi - lo;
  const Eigen::Vector3f X(d.x(), 0, 0), Y(0, d.y(), 0), Z(0, 0, d.z());
  auto n = [&](double area) { return static_cast<std::size_t>(std::max(1.0, area * density)); };
  sampleRect(c, lo, X, Z, n(d.x() * d.z()), rng);
  sampleRect(c, lo + Y, X, Z, n(d.x() * d.z()), rng);
  sampleRect(c, lo, Y, Z, n(d.y() * d.z()), rng);
  sampleRect(c, lo + X, Y, Z, n(d.y() * d.z()), rng);
  sampleRect(c, lo + Z, X, Y, n(d.x() * d.y()), rng);
}

/// A room 10 × 7 × 3 m (floor, ceiling, four walls) with two boxes on the floor, seen from a
/// sensor at the origin 1 m above the floor. Constrains all six degrees of freedom.
inline PointCloud roomScene(double density, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  PointCloud c;
  c.frame_id = "target";
  const float x0 = -4.f, x1 = 6.f, y0 = -3.f, y1 = 4.f, z0 = -1.f, z1 = 2.f;
  auto n = [&](double area) { return static_cast<std::size_t>(area * density); };
  sampleRect(c, {x0, y0, z0}, {x1 - x0, 0, 0}, {0, y1 - y0, 0}, n(70), rng);  // floor
  sampleRect(c, {x0, y0, z1}, {x1 - x0, 0, 0}, {0, y1 - y0, 0}, n(70), rng);  // ceiling
  sampleRect(c, {x0, y0, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, n(30), rng);  // walls
  sampleRect(c, {x0, y1, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, n(30), rng);
  sampleRect(c, {x0, y0, z0}, {0, y1 - y0, 0}, {0, 0, z1 - z0}, n(21), rng);
  sampleRect(c, {x1, y0, z0}, {0, y1 - y0, 0}, {0, 0, z1 - z0}, n(21), rng);
  sampleBox(c, {1.f, -1.5f, z0}, {2.2f, -0.2f, 0.2f}, density, rng);
  sampleBox(c, {-2.5f, 1.f, z0}, {-1.8f, 2.5f, 0.8f}, density, rng);
  return c;
}

/// A single 20 × 20 m plane z = −1 (the ground under a sensor): x, y and yaw are unconstrained.
inline PointCloud planeScene(double density, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  PointCloud c;
  c.frame_id = "target";
  sampleRect(c, {-10.f, -10.f, -1.f}, {20.f, 0, 0}, {0, 20.f, 0},
             static_cast<std::size_t>(400 * density), rng);
  return c;
}

/// The source of a synthetic pair: a random `fraction` of the target's points, expressed in the
/// source frame (p_source = T_target_source⁻¹ · p_target), plus isotropic Gaussian noise σ.
inline PointCloud makeSource(const PointCloud& target, const Isometry3d& T_target_source,
                             double fraction, double noise_sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N(0.0, 1.0);
  PointCloud s;
  s.frame_id = "source";
  const Isometry3d T_source_target = T_target_source.inverse();
  for (const auto& p : target.points) {
    const double keep = U(rng);
    const Eigen::Vector3d e(N(rng), N(rng), N(rng));
    if (keep > fraction) continue;
    const Eigen::Vector3d q = T_source_target * p.cast<double>() + noise_sigma * e;
    s.push_back(q.cast<float>());
  }
  return s;
}

/// Translation [m] and rotation [deg] error between two poses.
inline std::pair<double, double> poseError(const Isometry3d& A, const Isometry3d& B) {
  const Isometry3d D = A.inverse() * B;
  return {D.translation().norm(), rotationAngle(D.linear()) * kRadToDeg};
}

/// A fixed perturbation: `trans` metres along a skewed axis, `deg` degrees about another.
inline Isometry3d perturbation(double trans, double deg) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(0.6, 0.7, -0.4).normalized();
  return makeIsometry(Eigen::AngleAxisd(deg * kDegToRad, axis).toRotationMatrix(), trans * dir);
}

/// Grey level of the wall's texture at wall coordinates (x, y) [m]: smooth blobs of ~10 cm.
inline double wallTexture(double x, double y) {
  return 0.5 + 0.2 * std::sin(2.0 * M_PI * x / 0.23) * std::cos(2.0 * M_PI * y / 0.17) +
         0.15 * std::sin(2.0 * M_PI * (x + 0.6 * y) / 0.31);
}

/// A flat textured wall 1 m in front of the camera (optical frame: z forward), sampled on a
/// jittered grid of `step` with its own seed, so two samplings share no point.
inline PointCloud texturedWall(double step, unsigned seed, const Isometry3d& T_cam_wall) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.5 * step, 0.5 * step);
  PointCloud cloud;
  for (double x = -0.8; x <= 0.8; x += step)
    for (double y = -0.6; y <= 0.6; y += step) {
      const double u = x + jitter(rng), v = y + jitter(rng);
      const double g = std::clamp(wallTexture(u, v), 0.0, 1.0);
      const auto c = static_cast<std::uint8_t>(std::lround(255.0 * g));
      const Eigen::Vector3d p = T_cam_wall * Eigen::Vector3d(u, v, 0.0);
      cloud.points.push_back(p.cast<float>());
      cloud.colors.push_back(Color3u8(c, c, c));
    }
  return cloud;
}

/// The textured wall's pose in the camera frame: 1 m in front of it.
inline Isometry3d wallPose() {
  Isometry3d T = Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  return T;
}

/// ICP for the wall: 5 cm gate, Huber 1 cm, no planarity filter (the wall is one plane).
inline registration::IcpParams wallParams() {
  registration::IcpParams p;
  p.max_correspondence_distance = 0.05;
  p.kernel = registration::RobustKernel::Huber;
  p.kernel_scale = 0.01;
  p.max_iterations = 60;
  p.min_planarity = 0.0;
  return p;
}

/// The refinement of obm-bench's `obmnet+icp` for objects of the unit sphere: 0.1 gate from the
/// start, Huber 0.02, PCA normals of 10 neighbours, up to 60 iterations (no polish). `unit`
/// scales the lengths as obm-bench's --unit does (its kitti protocol: 20 m, a 2 m gate).
inline registration::IcpParams unitObjectIcp(double unit = 1.0) {
  registration::IcpParams p;
  p.initial_max_correspondence_distance = 0.1 * unit;
  p.max_correspondence_distance = 0.1 * unit;
  p.kernel_scale = 0.02 * unit;
  p.normal_neighbors = 10;
  p.max_iterations = 60;
  p.min_correspondences = 20;
  p.threads = 1;
  return p;
}

/// obm-bench's search over every rotation for objects of the unit sphere (turns within 90° about
/// the centroids, ±0.3 around where they meet, 0.1 cells, 300 scored points, one shift per
/// turn), with the turns `step_deg` apart and `candidates` poses handed on.
inline registration::CorrelativeSearchParams unitObjectSearch(double step_deg, int candidates) {
  registration::CorrelativeSearchParams p;
  p.axis = "any";
  p.align_centroids = true;
  p.heading_range_deg = 90.0;
  p.heading_step_deg = step_deg;
  p.translation_range = 0.3;
  p.cell = 0.1;
  p.sample_points = 300;
  p.shifts_per_heading = 1;
  p.candidates = candidates;
  return p;
}

}  // namespace obm::test
