// The surface error: zero for the true pose, near zero for a symmetry of the shape, large for a
// pose the shape tells apart.
#include <gtest/gtest.h>

#include <random>

#include "obm/core/errors.hpp"
#include "obm/eval/shape_error.hpp"
#include "test_clouds.hpp"

using namespace obm;
using namespace obm::eval;

namespace {

Isometry3d turn(const Eigen::Vector3d& axis, double deg,
                const Eigen::Vector3d& t = Eigen::Vector3d::Zero()) {
  return makeIsometry(Eigen::Matrix3d(Eigen::AngleAxisd(deg * kDegToRad, axis.normalized())), t);
}

/// Uniform samples of the surface of an axis-aligned box of half-sizes (a, b, c), by area.
PointCloud boxSurface(double a, double b, double c, std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const double areas[3] = {b * c, a * c, a * b};  // faces normal to x, y, z (each twice)
  std::discrete_distribution<int> face({areas[0], areas[1], areas[2]});
  PointCloud cl;
  for (std::size_t i = 0; i < n; ++i) {
    const int f = face(rng);
    Eigen::Vector3d p(U(rng) * a, U(rng) * b, U(rng) * c);
    const double half[3] = {a, b, c};
    p[f] = (U(rng) < 0 ? -1.0 : 1.0) * half[f];
    cl.points.push_back(p.cast<float>());
  }
  return cl;
}

using test::unitSphereSamples;

}  // namespace

TEST(SurfaceError, ZeroAtTheTruthAndTheTruthMayBeAnyPose) {
  const SurfaceErrorScorer s(boxSurface(0.9, 0.5, 0.3, 2048, 1));
  const Isometry3d T = turn({1, 2, 3}, 37.0, {0.2, -0.1, 0.4});
  EXPECT_NEAR(s.error(T, T), 0.0, 1e-6);
  EXPECT_GT(s.spacing(), 0.0);
  EXPECT_LT(s.spacing(), 0.1);
}

TEST(SurfaceError, ASymmetryOfTheShapeIsNotAnError) {
  // A sphere turned by anything, a box with three different sides by 180° about an axis. (The
  // floor is the samples': 8192 of them keep it below what a 1° turn of the box gives, ≈ 0.003.)
  const SurfaceErrorScorer sphere(unitSphereSamples(8192, 2));
  const Isometry3d T = turn({0, 1, 1}, 20.0, {0.3, 0.0, 0.1});
  EXPECT_LT(sphere.error(T * turn({1, -1, 0.5}, 70.0), T), 0.003);
  const SurfaceErrorScorer box(boxSurface(0.9, 0.5, 0.3, 8192, 3));
  EXPECT_LT(box.error(T * turn({0, 0, 1}, 180.0), T), 0.003);
  EXPECT_LT(box.error(T * turn({1, 0, 0}, 180.0), T), 0.003);
}

TEST(SurfaceError, PosesTheShapeTellsApartAreErrors) {
  const SurfaceErrorScorer box(boxSurface(0.9, 0.5, 0.3, 8192, 3));
  const Isometry3d T = turn({0, 1, 1}, 20.0, {0.3, 0.0, 0.1});
  // Not a symmetry of this box: 90° about z swaps its unequal x and y sides.
  EXPECT_GT(box.error(T * turn({0, 0, 1}, 90.0), T), 0.05);
  // Small errors grow with their size: 5° is worse than 1°, which is worse than the truth.
  const double e1 = box.error(T * turn({0, 0, 1}, 1.0), T);
  const double e5 = box.error(T * turn({0, 0, 1}, 5.0), T);
  EXPECT_GT(e1, 0.001);
  EXPECT_GT(e5, 3.0 * e1);
  // A slide across a face moves points off the box's extent; one along the normal off the face.
  EXPECT_GT(box.error(T * turn({0, 0, 1}, 0.0, {0.0, 0.0, 0.05}), T), 0.02);
  EXPECT_GT(box.error(T * turn({0, 0, 1}, 0.0, {0.3, 0.0, 0.0}), T), 0.02);
  // And a sphere moved is an error, whatever it is turned by.
  const SurfaceErrorScorer sphere(unitSphereSamples(8192, 2));
  EXPECT_GT(sphere.error(T * turn({1, 0, 0}, 30.0, {0.05, 0.0, 0.0}), T), 0.02);
}

TEST(SurfaceError, TooFewSamplesAreRefusedNamingTheObject) {
  PointCloud c = unitSphereSamples(10, 4);
  c.frame_id = "teapot";
  try {
    SurfaceErrorScorer s(c);
    FAIL() << "expected ContractError";
  } catch (const ContractError& e) {
    EXPECT_NE(std::string(e.what()).find("teapot"), std::string::npos) << e.what();
  }
}
