#pragma once
// Synthetic clouds shared by the unit tests.
#include <cstdint>
#include <random>

#include "obm/core/point_cloud.hpp"

namespace obm::test {

/// n i.i.d. points uniform on the unit sphere about the origin (normalised Gaussian draws).
inline PointCloud unitSphereSamples(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> G(0.f, 1.f);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i)
    c.points.push_back(Vector3f(G(rng), G(rng), G(rng)).normalized());
  return c;
}

}  // namespace obm::test
