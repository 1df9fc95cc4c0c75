// Geometry primitives and the Embree ray caster on tiny synthetic scenes with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/sim/geometry.hpp"
#include "obm/sim/scene.hpp"

using namespace obm;
using namespace obm::sim;

namespace {
// Signed volume by the divergence theorem: positive for a closed mesh with outward normals.
double signedVolume(const TriangleMesh& m) {
  double v = 0.0;
  for (const auto& f : m.faces) {
    const Eigen::Vector3d a = m.vertices[f[0]].cast<double>(), b = m.vertices[f[1]].cast<double>(),
                          c = m.vertices[f[2]].cast<double>();
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v;
}
}  // namespace

TEST(Geometry, ClosedPrimitivesHaveOutwardNormalsAndTheRightVolume) {
  {
    SceneMesh s;
    MeshBuilder(s).box(Eigen::Isometry3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(2, 3, 4), Material::Wall);
    EXPECT_NEAR(signedVolume(s.mesh), 24.0, 1e-4);
    EXPECT_EQ(s.materials.size(), s.mesh.faces.size());
  }
  {
    SceneMesh s;
    MeshBuilder(s).prism(Eigen::Isometry3d::Identity(),
                         {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}, 0.0, 1.5,
                         Material::Facade);  // L-shape, area 3
    EXPECT_NEAR(signedVolume(s.mesh), 4.5, 1e-4);
  }
  {
    SceneMesh s;
    MeshBuilder(s).cylinder(Eigen::Isometry3d::Identity(), 1.0, 1.0, 2.0, 64, Material::Metal);
    // Inscribed 64-gon: area = n/2 sin(2π/n).
    EXPECT_NEAR(signedVolume(s.mesh), 2.0 * 32.0 * std::sin(2.0 * M_PI / 64.0), 1e-3);
  }
  {
    SceneMesh s;
    MeshBuilder(s).blob(Eigen::Isometry3d::Identity(), Eigen::Vector3d(1, 1, 1), 3, 0.0, 1,
                        Material::Foliage);
    EXPECT_NEAR(signedVolume(s.mesh), 4.0 / 3.0 * M_PI, 0.05);
  }
}

TEST(Raycast, RayHitsKnownBoxAtExactRange) {
  SceneMesh s;
  MeshBuilder(s).aabb({4, -1, -1}, {6, 1, 1}, Material::Wall);
  const RaycastScene scene(s);

  const RayHit h = scene.intersect({0, 0, 0}, {1, 0, 0});
  ASSERT_TRUE(h.hit());
  EXPECT_NEAR(h.range, 4.0f, 1e-5f);
  EXPECT_NEAR(h.cos_incidence, 1.0f, 1e-6f);
  EXPECT_NEAR(h.normal.x(), -1.0f, 1e-6f);
  EXPECT_EQ(h.material, Material::Wall);

  // Non-unit directions: t is in units of the direction's length.
  EXPECT_NEAR(scene.intersect({0, 0, 0}, {2, 0, 0}).range, 2.0f, 1e-5f);
  // From above onto the top face, and an oblique ray onto the front face at (4, 0.5, 0.25).
  EXPECT_NEAR(scene.intersect({5, 0, 5}, {0, 0, -1}).range, 4.0f, 1e-5f);
  const Eigen::Vector3f d = Eigen::Vector3f(4, 0.5, 0.25).normalized();
  const RayHit ho = scene.intersect({0, 0, 0}, d);
  EXPECT_NEAR(ho.range, Eigen::Vector3f(4, 0.5, 0.25).norm(), 1e-5f);
  EXPECT_NEAR(ho.cos_incidence, d.x(), 1e-5f);
  // Misses: wrong direction, and t_max shorter than the distance.
  EXPECT_FALSE(scene.intersect({0, 0, 0}, {-1, 0, 0}).hit());
  EXPECT_FALSE(scene.intersect({0, 0, 0}, {1, 0, 0}, 0.f, 3.9f).hit());
  EXPECT_TRUE(scene.occluded({0, 0, 0}, {1, 0, 0}, 0.f, 4.1f));
  EXPECT_FALSE(scene.occluded({0, 0, 0}, {1, 0, 0}, 0.f, 3.9f));
}

TEST(Raycast, BatchedPacketsAgreeWithSingleRays) {
  SceneMesh s;
  MeshBuilder b(s);
  b.aabb({4, -1, -1}, {6, 1, 1}, Material::Wall);
  b.cylinder(Eigen::Isometry3d(Eigen::Translation3d(0, 5, -1)), 0.5, 0.5, 2.0, 16, Material::Metal);
  const RaycastScene scene(s);
  std::vector<Eigen::Vector3f> o, d;
  for (int i = 0; i < 37; ++i) {  // not a multiple of 16: exercises a partial packet
    const double a = 2.0 * M_PI * i / 37.0;
    o.emplace_back(0.f, 0.f, 0.1f * static_cast<float>(i % 3));
    d.emplace_back(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)), 0.f);
  }
  std::vector<RayHit> hits;
  scene.intersect(o, d, 0.f, 100.f, hits);
  ASSERT_EQ(hits.size(), o.size());
  int n_hit = 0;
  for (std::size_t i = 0; i < o.size(); ++i) {
    const RayHit h = scene.intersect(o[i], d[i], 0.f, 100.f);
    EXPECT_EQ(hits[i].hit(), h.hit());
    if (h.hit()) {
      ++n_hit;
      EXPECT_FLOAT_EQ(hits[i].range, h.range);
      EXPECT_EQ(hits[i].face, h.face);
    }
  }
  EXPECT_GT(n_hit, 3);
}

TEST(Raycast, RejectsAnEmptyOrInconsistentMesh) {
  EXPECT_THROW(RaycastScene(SceneMesh{}), ContractError);
  SceneMesh s;
  MeshBuilder(s).aabb({0, 0, 0}, {1, 1, 1}, Material::Wall);
  s.materials.pop_back();
  EXPECT_THROW(RaycastScene{s}, ContractError);
}
