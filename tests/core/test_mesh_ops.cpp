#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <tuple>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/mesh.hpp"

using namespace obm;

namespace {
TriangleMesh unitSquare() {  // two triangles in z = 0, area 1
  TriangleMesh m;
  m.name = "square";
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.faces = {{0, 1, 2}, {0, 2, 3}};
  return m;
}
}  // namespace

TEST(Mesh, AreaAppendTransformValidate) {
  auto m = unitSquare();
  EXPECT_NEAR(m.area(), 1.0, 1e-12);
  auto m2 = m;
  m2.append(unitSquare());
  EXPECT_EQ(m2.numFaces(), 4u);
  EXPECT_EQ(m2.faces[2], Eigen::Vector3i(4, 5, 6));
  EXPECT_NEAR(m2.area(), 2.0, 1e-12);
  m.faces.emplace_back(0, 1, 9);
  EXPECT_THROW(m.validate(), ContractError);
}

TEST(Mesh, SurfaceSamplesAreOnTheSurfaceAndUniform) {
  // A 1×1 square plus a 3×1 rectangle elsewhere: 25 % / 75 % of the samples by area.
  auto m = unitSquare();
  TriangleMesh r;
  r.vertices = {{10, 0, 0}, {13, 0, 0}, {13, 1, 0}, {10, 1, 0}};
  r.faces = {{0, 1, 2}, {0, 2, 3}};
  m.append(r);
  std::mt19937_64 rng(1);
  const auto c = sampleSurface(m, 20000, rng);
  int in_square = 0;
  for (const auto& p : c.points) {
    EXPECT_FLOAT_EQ(p.z(), 0.f);
    EXPECT_TRUE((p.x() >= 0 && p.x() <= 1) || (p.x() >= 10 && p.x() <= 13));
    in_square += p.x() <= 1 ? 1 : 0;
  }
  EXPECT_NEAR(in_square / 20000.0, 0.25, 0.015);
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(sampleSurface(flat, 10, rng), ContractError);
}

// voxelIds groups points by voxel, ids in order of first occurrence, with the packed-key table
// near the origin and the general one for coordinates beyond ±2^20 voxels; both must group
// exactly as the definition says (floor(p / voxel) per axis, negative coordinates included).
TEST(CloudOps, VoxelIdsGroupByFloorInFirstSeenOrderNearAndFar) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> U(-3.f, 3.f);
  for (const float offset : {0.f, 5.0e4f}) {  // 5e4 m / 0.01 m = 5e6 voxels: the general path
    std::vector<Vector3f> pts;
    for (int i = 0; i < 5000; ++i) pts.emplace_back(U(rng) + offset, U(rng), U(rng) - offset);
    pts.push_back(pts[17]);  // a duplicate joins its voxel
    const double voxel = offset > 0.f ? 0.01 : 0.25;
    std::vector<std::uint32_t> ids;
    const std::size_t m = voxelIds(pts, voxel, ids);
    ASSERT_EQ(ids.size(), pts.size());
    std::vector<Eigen::Vector3i> key_of(m);
    std::uint32_t next = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3i key((pts[i].cast<double>() * (1.0 / voxel)).array().floor().cast<int>());
      ASSERT_LE(ids[i], next) << "ids must appear in first-seen order, point " << i;
      if (ids[i] == next) {
        key_of[next++] = key;
      } else {
        EXPECT_EQ(key_of[ids[i]], key) << "point " << i << " grouped into another voxel";
      }
    }
    EXPECT_EQ(next, m);
    EXPECT_EQ(ids.back(), ids[17]);
    // Every voxel distinct: no two ids share a key.
    std::set<std::tuple<int, int, int>> keys;
    for (const auto& k : key_of) keys.emplace(k.x(), k.y(), k.z());
    EXPECT_EQ(keys.size(), m);
  }
  std::vector<std::uint32_t> ids;
  EXPECT_EQ(voxelIds({}, 0.1, ids), 0u);
  EXPECT_THROW(voxelIds({Vector3f::Zero()}, 0.0, ids), ContractError);
}

TEST(CloudOps, NormalizeVoxelSubsetCrop) {
  PointCloud c;
  c.points = {{1, 1, 1}, {3, 1, 1}, {1.05f, 1.02f, 1.01f}};
  c.intensity = {1.f, 2.f, 3.f};
  auto n = c;
  normalizeToSphere(n, 1.f);
  float rmax = 0;
  for (const auto& p : n.points) rmax = std::max(rmax, p.norm());
  EXPECT_NEAR(rmax, 1.f, 1e-6);
  EXPECT_NEAR(n.centroid().norm(), 0.f, 1e-6);

  const auto v = voxelDownsample(c, 0.5);
  ASSERT_EQ(v.size(), 2u);  // points 0 and 2 share a voxel
  EXPECT_NEAR(v.points[0].x(), 1.025f, 1e-6);
  EXPECT_NEAR(v.intensity[0], 2.f, 1e-6);
  EXPECT_EQ(voxelDownsample(c, 0.0).size(), 3u);
  auto coloured = c;
  coloured.colors = {Color3u8(10, 200, 0), Color3u8(1, 2, 3), Color3u8(21, 100, 255)};
  const auto vc = voxelDownsample(coloured, 0.5);
  ASSERT_EQ(vc.colors.size(), 2u);
  EXPECT_EQ(vc.colors[0], Color3u8(16, 150, 128));  // mean of points 0 and 2, rounded
  EXPECT_EQ(vc.colors[1], Color3u8(1, 2, 3));

  std::mt19937_64 rng(2);
  std::vector<std::size_t> idx;
  const auto s = randomSubset(c, 2, rng, &idx);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_NE(idx[0], idx[1]);
  EXPECT_EQ(s.points[0], c.points[idx[0]]);
  EXPECT_EQ(randomSubset(c, 10, rng).size(), 3u);

  const auto r = cropRange(c, 0.0, 2.0);
  EXPECT_EQ(r.size(), 2u);
}

TEST(CloudOps, RemoveGroundCutsATiltedRoadAndKeepsWhatStandsOnIt) {
  // A sweep-like cloud: a road plane 1.7 m below the sensor, tilted 3° about x, with a wall and
  // two low boxes standing on it. Everything closer than 0.3 m to the road must go, nothing else.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> u(-20.f, 20.f), h(0.f, 1.f);
  const float slope = std::tan(3.f * 3.14159265f / 180.f);
  auto road_z = [&](float y) { return -1.7f + slope * y; };
  PointCloud c;
  for (int i = 0; i < 3000; ++i) {  // the road, with 2 cm of noise
    const float x = u(rng), y = u(rng);
    c.points.emplace_back(x, y, road_z(y) + 0.02f * (h(rng) - 0.5f));
  }
  std::size_t above = 0;
  for (int i = 0; i < 1500; ++i) {  // a wall at x = 8, 0.5–4 m above the road
    const float y = u(rng);
    c.points.emplace_back(8.f, y, road_z(y) + 0.5f + 3.5f * h(rng));
    ++above;
  }
  for (int i = 0; i < 200; ++i) {  // a kerb-high box top 0.4 m above the road: kept
    const float x = -5.f + h(rng), y = 3.f + h(rng);
    c.points.emplace_back(x, y, road_z(y) + 0.4f);
    ++above;
  }
  std::vector<std::size_t> kept;
  const auto cut = removeGround(c, 0.3, 1, &kept);
  EXPECT_EQ(cut.size(), above);
  ASSERT_EQ(kept.size(), cut.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    EXPECT_GE(kept[i], 3000u);
    EXPECT_EQ(cut.points[i], c.points[kept[i]]);
  }
  Eigen::Vector4d plane;
  std::mt19937_64 rng2(1);
  ASSERT_TRUE(fitGroundPlane(c, rng2, &plane));
  EXPECT_NEAR(std::acos(plane.z()) * 180.0 / 3.14159265358979, 3.0, 0.5);

  // No road in view (a wall only): nothing is cut.
  PointCloud wall;
  for (int i = 0; i < 500; ++i) wall.points.emplace_back(8.f, u(rng), 4.f * h(rng));
  EXPECT_EQ(removeGround(wall, 0.3).size(), wall.size());
}
