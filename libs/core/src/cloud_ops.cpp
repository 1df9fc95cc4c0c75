#include "obm/core/cloud_ops.hpp"

#include <cmath>
#include <numeric>
#include <unordered_map>

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

PointCloud voxelDownsample(const PointCloud& cloud, double voxel) {
  if (voxel <= 0.0) return cloud;
  struct Acc {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double isum = 0.0;
    Eigen::Vector3d csum = Eigen::Vector3d::Zero();
    std::size_t n = 0;
  };
  std::unordered_map<Eigen::Vector3i, std::size_t, VoxelKeyHash, VoxelKeyEq> index;
  std::vector<Acc> acc;
  index.reserve(cloud.size() / 4 + 1);
  const double inv = 1.0 / voxel;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud.points[i];
    const Eigen::Vector3i key(static_cast<int>(std::floor(p.x() * inv)),
                              static_cast<int>(std::floor(p.y() * inv)),
                              static_cast<int>(std::floor(p.z() * inv)));
    auto [it, inserted] = index.try_emplace(key, acc.size());
    if (inserted) acc.emplace_back();
    Acc& a = acc[it->second];
    a.sum += p.cast<double>();
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

}  // namespace obm
