#include "obm/core/cloud_ops.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <cstdint>
#include <limits>
#include <unordered_map>

#include "obm/core/errors.hpp"

namespace obm {

namespace {
struct VoxelKeyHash {
  std::size_t operator()(const Eigen::Vector3i& k) const noexcept {
    // Large odd primes (Teschner et al.'s spatial hash) spread neighbouring voxels apart.
    return static_cast<std::size_t>(k.x()) * 73856093u ^
           static_cast<std::size_t>(k.y()) * 19349663u ^
           static_cast<std::size_t>(k.z()) * 83492791u;
  }
};
struct VoxelKeyEq {
  bool operator()(const Eigen::Vector3i& a, const Eigen::Vector3i& b) const noexcept {
    return a == b;
  }
};
}  // namespace

std::size_t voxelIds(const std::vector<Vector3f>& points, double voxel,
                     std::vector<std::uint32_t>& ids) {
  OBM_ASSERT(voxel > 0.0, "voxelIds: voxel must be > 0");
  OBM_ASSERT(points.size() < std::numeric_limits<std::uint32_t>::max(),
             "voxelIds: too many points");
  const std::size_t n = points.size();
  ids.resize(n);
  const double inv = 1.0 / voxel;
  std::vector<Eigen::Vector3i> keys(n);
  // Packed 21-bit coordinates (±2^20 voxels: ±31 km at 3 cm) index an open-addressing table,
  // several times faster than std::unordered_map on the mapping front-end's clouds (the local map
  // build merges ~10^5 points per keyframe); anything outside that range takes the general path.
  constexpr int kHalf = 1 << 20;
  bool packable = true;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = points[i];
    keys[i] = Eigen::Vector3i(static_cast<int>(std::floor(p.x() * inv)),
                              static_cast<int>(std::floor(p.y() * inv)),
                              static_cast<int>(std::floor(p.z() * inv)));
    packable = packable && (keys[i].array() >= -kHalf).all() && (keys[i].array() < kHalf).all();
  }
  std::uint32_t count = 0;
  if (!packable) {
    std::unordered_map<Eigen::Vector3i, std::uint32_t, VoxelKeyHash, VoxelKeyEq> index;
    index.reserve(n / 4 + 1);
    for (std::size_t i = 0; i < n; ++i) {
      auto [it, inserted] = index.try_emplace(keys[i], count);
      if (inserted) ++count;
      ids[i] = it->second;
    }
    return count;
  }
  std::size_t capacity = 16;
  while (capacity < 2 * n) capacity <<= 1;
  const int shift = 64 - static_cast<int>(std::log2(static_cast<double>(capacity)));
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::vector<std::uint64_t> slot_key(capacity, kEmpty);
  std::vector<std::uint32_t> slot_id(capacity);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = (std::uint64_t(keys[i].x() + kHalf) << 42) |
                              (std::uint64_t(keys[i].y() + kHalf) << 21) |
                              std::uint64_t(keys[i].z() + kHalf);
    std::size_t s = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (slot_key[s] != kEmpty && slot_key[s] != key) s = (s + 1) & (capacity - 1);
    if (slot_key[s] == kEmpty) {
      slot_key[s] = key;
      slot_id[s] = count++;
    }
    ids[i] = slot_id[s];
  }
  return count;
}

PointCloud voxelDownsample(const PointCloud& cloud, double voxel) {
  if (voxel <= 0.0) return cloud;
  struct Acc {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double isum = 0.0;
    Eigen::Vector3d csum = Eigen::Vector3d::Zero();
    std::size_t n = 0;
  };
  std::vector<std::uint32_t> ids;
  std::vector<Acc> acc(voxelIds(cloud.points, voxel, ids));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    Acc& a = acc[ids[i]];
    a.sum += cloud.points[i].cast<double>();
    if (cloud.hasIntensity()) a.isum += cloud.intensity[i];
    if (cloud.hasColors()) a.csum += cloud.colors[i].cast<double>();
    ++a.n;
  }
  PointCloud out;
  out.timestamp = cloud.timestamp;
  out.frame_id = cloud.frame_id;
  out.points.reserve(acc.size());
  if (cloud.hasIntensity()) out.intensity.reserve(acc.size());
  if (cloud.hasColors()) out.colors.reserve(acc.size());
  for (const auto& a : acc) {
    out.points.push_back((a.sum / static_cast<double>(a.n)).cast<float>());
    if (cloud.hasIntensity())
      out.intensity.push_back(static_cast<float>(a.isum / static_cast<double>(a.n)));
    if (cloud.hasColors())
      out.colors.push_back(
          (a.csum / static_cast<double>(a.n)).array().round().cast<std::uint8_t>().matrix());
  }
  return out;
}

PointCloud randomSubset(const PointCloud& cloud, std::size_t n, std::mt19937_64& rng,
                        std::vector<std::size_t>* indices_out) {
  std::vector<std::size_t> idx(cloud.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  const std::size_t m = std::min(n, idx.size());
  for (std::size_t i = 0; i < m; ++i) {
    std::uniform_int_distribution<std::size_t> U(i, idx.size() - 1);
    std::swap(idx[i], idx[U(rng)]);
  }
  idx.resize(m);
  if (indices_out) *indices_out = idx;
  return cloud.select(idx);
}

PointCloud cropRange(const PointCloud& cloud, double min_range, double max_range) {
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double r = cloud.points[i].norm();
    if (r >= min_range && r <= max_range) keep.push_back(i);
  }
  return cloud.select(keep);
}

bool fitGroundPlane(const PointCloud& cloud, std::mt19937_64& rng, Eigen::Vector4d* plane,
                    double max_tilt_deg) {
  const std::size_t n = cloud.size();
  if (n < 30) return false;
  // Candidates: the lowest third by height (the road, kerbs, the bases of walls).
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  const std::size_t m = n / 3;
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(m), order.end(),
                   [&](std::size_t a, std::size_t b) {
                     return cloud.points[a].z() < cloud.points[b].z();
                   });
  order.resize(m);
  constexpr double kThreshold = 0.15;
  const double min_nz = std::cos(max_tilt_deg * 3.14159265358979323846 / 180.0);
  std::uniform_int_distribution<std::size_t> pick(0, m - 1);
  std::size_t best_count = 0;
  Eigen::Vector4d best = Eigen::Vector4d::Zero();
  for (int it = 0; it < 100; ++it) {
    const Eigen::Vector3d a = cloud.points[order[pick(rng)]].cast<double>();
    const Eigen::Vector3d b = cloud.points[order[pick(rng)]].cast<double>();
    const Eigen::Vector3d c = cloud.points[order[pick(rng)]].cast<double>();
    Eigen::Vector3d nrm = (b - a).cross(c - a);
    const double len = nrm.norm();
    if (len < 1e-9) continue;
    nrm /= len;
    if (nrm.z() < 0.0) nrm = -nrm;
    if (nrm.z() < min_nz) continue;
    const double d = -nrm.dot(a);
    std::size_t count = 0;
    for (const auto i : order)
      if (std::abs(nrm.dot(cloud.points[i].cast<double>()) + d) < kThreshold) ++count;
    if (count > best_count) {
      best_count = count;
      best << nrm, d;
    }
  }
  if (best_count < m / 10 || best_count < 10) return false;
  *plane = best;
  return true;
}

PointCloud removeGround(const PointCloud& cloud, double band, std::uint64_t seed,
                        std::vector<std::size_t>* indices_out) {
  std::mt19937_64 rng(seed);
  Eigen::Vector4d g;
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  const bool found = fitGroundPlane(cloud, rng, &g);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!found || g.head<3>().dot(cloud.points[i].cast<double>()) + g[3] >= band) keep.push_back(i);
  if (indices_out) *indices_out = keep;
  return cloud.select(keep);
}

}  // namespace obm
