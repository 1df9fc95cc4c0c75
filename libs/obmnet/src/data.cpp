#include "obm/obmnet/data.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"

namespace obm::obmnet {

std::string splitName(Split s) {
  switch (s) {
    case Split::Train:
      return "train";
    case Split::Validation:
      return "val";
    case Split::Test:
      return "test";
  }
  return "?";
}

Split splitForName(const std::string& name, double val_fraction, double test_fraction) {
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a offset basis
  for (unsigned char c : name) {
    h ^= c;
    h *= 1099511628211ull;  // FNV prime
  }
  // FNV-1a alone leaves the high bits of similar names ("obj_1", "obj_2") correlated: a
  // splitmix64 finaliser mixes every input bit into them.
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  h ^= h >> 31;
  // Top 53 bits → a double in [0, 1).
  const double u = static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
  if (u < test_fraction) return Split::Test;
  if (u < test_fraction + val_fraction) return Split::Validation;
  return Split::Train;
}

PairProtocol PairProtocol::preset(const std::string& name) {
  PairProtocol p;
  if (name == "clean") return p;
  if (name == "jitter") {
    p.jitter_sigma = 0.01;
    return p;
  }
  if (name == "outliers") {
    p.outliers = 200;
    return p;
  }
  if (name == "partial") {
    p.partial_keep = 768;
    return p;
  }
  if (name == "partial_noise") {
    p.partial_keep = 640;
    p.jitter_sigma = 0.01;
    return p;
  }
  if (name == "indoor") {
    p.num_points = 2048;
    p.partial_keep = 1536;
    return p;
  }
  if (name == "resampled") {
    p.resample = true;
    p.partial_keep = 768;
    p.jitter_sigma = 0.005;
    p.jitter_clip = 0.025;
    return p;
  }
  if (name == "icl") {
    p.num_points = 2048;
    p.partial_keep = 1536;
    p.axis_angle = true;
    return p;
  }
  throw ConfigError("unknown pair protocol '" + name +
                    "' (known: clean, jitter, outliers, partial, partial_noise, indoor, icl, "
                    "resampled)");
}

PairProtocol PairProtocol::load(const ConfigNode& node) {
  node.checkKeys({"preset", "num_points", "resample", "max_angle_deg", "axis_angle", "max_translation",
                  "partial_keep", "partial_far", "jitter_sigma", "jitter_clip", "jitter_uniform",
                  "outliers"});
  PairProtocol p;
  if (node.has("preset")) {
    try {
      p = preset(node.required<std::string>("preset"));
    } catch (const ConfigError& e) {
      throw ConfigError(node.where("preset") + ": " + e.what());
    }
  }
  node.get("num_points", p.num_points);
  node.get("resample", p.resample);
  node.get("max_angle_deg", p.max_angle_deg);
  node.get("axis_angle", p.axis_angle);
  node.get("max_translation", p.max_translation);
  node.get("partial_keep", p.partial_keep);
  node.get("partial_far", p.partial_far);
  node.get("jitter_sigma", p.jitter_sigma);
  node.get("jitter_clip", p.jitter_clip);
  node.get("jitter_uniform", p.jitter_uniform);
  node.get("outliers", p.outliers);
  if (p.num_points < 8) throw ConfigError(node.where("num_points") + ": must be >= 8");
  if (p.partial_keep < 0 || p.partial_keep > p.num_points)
    throw ConfigError(node.where("partial_keep") + ": must be in [0, num_points]");
  if (p.jitter_sigma < 0 || p.outliers < 0 || p.max_angle_deg < 0 || p.max_translation < 0)
    throw ConfigError(node.where() +
                      ": jitter_sigma, outliers, max_angle_deg, max_translation must be >= 0");
  return p;
}

namespace {

/// Indices of the `keep` points nearest to a random far point (PRNet/RIENet partial crop). With
/// `region`, also the crop's ball: its centre (the far point) and the distance of the last kept
/// point, so that other samplings of the same surface can be tested against the same region.
std::vector<std::size_t> cropNearFarPoint(const PointCloud& c, int keep, double far,
                                          std::mt19937_64& rng,
                                          std::pair<Eigen::Vector3f, float>* region = nullptr) {
  std::normal_distribution<double> G(0.0, 1.0);
  Eigen::Vector3d dir(G(rng), G(rng), G(rng));
  if (dir.norm() < 1e-12) dir = Eigen::Vector3d::UnitX();
  const Eigen::Vector3f anchor = (far * dir.normalized()).cast<float>();
  std::vector<std::size_t> idx(c.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  const auto k = static_cast<std::size_t>(keep);
  std::vector<float> d(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) d[i] = (c.points[i] - anchor).squaredNorm();
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(std::min(k, idx.size())),
                    idx.end(), [&](std::size_t a, std::size_t b) { return d[a] < d[b]; });
  idx.resize(std::min(k, idx.size()));
  if (region) {
    region->first = anchor;
    region->second = idx.empty() ? 0.0f : std::sqrt(d[idx.back()]);
  }
  std::sort(idx.begin(), idx.end());
  return idx;
}

void jitter(PointCloud& c, double sigma, double clip, std::mt19937_64& rng) {
  std::normal_distribution<double> G(0.0, sigma);
  for (auto& p : c.points)
    for (int a = 0; a < 3; ++a) p[a] += static_cast<float>(std::clamp(G(rng), -clip, clip));
}

void addOutliers(PointCloud& c, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::normal_distribution<double> G(0.0, 0.5);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3f p;
    for (int a = 0; a < 3; ++a) p[a] = static_cast<float>(std::clamp(U(rng) + G(rng), -1.0, 1.0));
    c.points.push_back(p);
  }
  c.intensity.clear();
  c.colors.clear();
}

/// The steps every generated pair ends with: the target moved by the pair's pose, both clouds
/// jittered and given outliers as the protocol asks, and named.
RegistrationPair finishPair(PointCloud src, PointCloud tgt, RegistrationPair pair,
                            const PairProtocol& protocol, std::mt19937_64& rng) {
  tgt.transform(pair.T_target_source);
  if (protocol.jitter_sigma > 0.0) {
    double f = 1.0;
    if (protocol.jitter_uniform) f = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    if (f > 0.0) {
      jitter(src, f * protocol.jitter_sigma, f * protocol.jitter_clip, rng);
      jitter(tgt, f * protocol.jitter_sigma, f * protocol.jitter_clip, rng);
    }
  }
  if (protocol.outliers > 0) {
    addOutliers(src, protocol.outliers, rng);
    addOutliers(tgt, protocol.outliers, rng);
  }
  src.frame_id = "source";
  tgt.frame_id = "target";
  pair.source = std::move(src);
  pair.target = std::move(tgt);
  return pair;
}

/// The `resample` protocol: two disjoint random halves of the object's i.i.d. surface samples,
/// each cropped around its own far point, the target moved, both jittered.
RegistrationPair makeResampledPair(const PointCloud& cloud, const PairProtocol& protocol,
                                   const Isometry3d& T_target_source, std::mt19937_64& rng) {
  const auto n = static_cast<std::size_t>(protocol.num_points);
  if (cloud.size() < 2 * n)
    throw ContractError("makePair: the resampled protocol needs 2 x " + std::to_string(n) +
                        " samples of '" + cloud.frame_id + "', it has " +
                        std::to_string(cloud.size()) + " (objects.keep_points: 2048)");
  std::vector<std::size_t> idx(cloud.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  std::shuffle(idx.begin(), idx.end(), rng);
  PointCloud src = cloud.select(std::vector<std::size_t>(idx.begin(), idx.begin() + n));
  PointCloud tgt = cloud.select(std::vector<std::size_t>(idx.begin() + n, idx.begin() + 2 * n));
  src.intensity.clear();
  src.colors.clear();
  tgt.intensity.clear();
  tgt.colors.clear();
  RegistrationPair pair;
  pair.T_target_source = T_target_source;
  if (protocol.partial_keep > 0 && protocol.partial_keep < protocol.num_points) {
    std::pair<Eigen::Vector3f, float> region_t;
    const auto is = cropNearFarPoint(src, protocol.partial_keep, protocol.partial_far, rng);
    const auto it =
        cropNearFarPoint(tgt, protocol.partial_keep, protocol.partial_far, rng, &region_t);
    src = src.select(is);
    tgt = tgt.select(it);
    // No sample is shared: a source point overlaps when its surface location lies in the
    // target's crop ball.
    std::size_t inside = 0;
    for (const auto& p : src.points)
      inside += (p - region_t.first).norm() <= region_t.second ? 1 : 0;
    pair.overlap = static_cast<double>(inside) / static_cast<double>(src.size());
  }
  return finishPair(std::move(src), std::move(tgt), std::move(pair), protocol, rng);
}

}  // namespace

RegistrationPair makePair(const PointCloud& cloud, const PairProtocol& protocol,
                          std::mt19937_64& rng) {
  OBM_ASSERT(!cloud.empty(), "makePair: empty cloud");
  RegistrationPair pair;
  PointCloud base = randomSubset(cloud, static_cast<std::size_t>(protocol.num_points), rng);
  base.intensity.clear();
  base.colors.clear();
  // The pose first, so that the same seed gives the same pose whatever the crop does.
  pair.T_target_source =
      protocol.axis_angle
          ? randomAxisAngleTransform(rng, protocol.max_angle_deg, protocol.max_translation)
          : randomRienetTransform(rng, protocol.max_angle_deg, protocol.max_translation);

  if (protocol.resample) return makeResampledPair(cloud, protocol, pair.T_target_source, rng);
  PointCloud src = base, tgt = base;
  if (protocol.partial_keep > 0 && protocol.partial_keep < static_cast<int>(base.size())) {
    const auto is = cropNearFarPoint(base, protocol.partial_keep, protocol.partial_far, rng);
    const auto it = cropNearFarPoint(base, protocol.partial_keep, protocol.partial_far, rng);
    std::vector<std::size_t> common;
    std::set_intersection(is.begin(), is.end(), it.begin(), it.end(), std::back_inserter(common));
    pair.overlap = static_cast<double>(common.size()) / static_cast<double>(is.size());
    // Shuffle the order so that index i of source and target are not correspondences.
    src = base.select(is);
    tgt = base.select(it);
  }
  src = randomSubset(src, src.size(), rng);
  tgt = randomSubset(tgt, tgt.size(), rng);
  return finishPair(std::move(src), std::move(tgt), std::move(pair), protocol, rng);
}

namespace {
/// Occupied cells of a cubic grid of size `voxel` anchored at `origin`: cell key → point indices.
std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> voxelCells(
    const PointCloud& cloud, const Eigen::Vector3f& origin, float voxel) {
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells;
  cells.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f q = (cloud.points[i] - origin) / voxel;
    const auto ix = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.x())));
    const auto iy = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.y())));
    const auto iz = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.z())));
    cells[(ix & 0x1FFFFF) | ((iy & 0x1FFFFF) << 21) | ((iz & 0x1FFFFF) << 42)].push_back(
        static_cast<std::uint32_t>(i));
  }
  return cells;
}

std::size_t countCells(const PointCloud& cloud, const Eigen::Vector3f& origin, float voxel) {
  std::unordered_set<std::uint64_t> keys;
  keys.reserve(cloud.size());
  for (const auto& p : cloud.points) {
    const Eigen::Vector3f q = (p - origin) / voxel;
    const auto ix = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.x())));
    const auto iy = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.y())));
    const auto iz = static_cast<std::uint64_t>(std::max(0.0f, std::floor(q.z())));
    keys.insert((ix & 0x1FFFFF) | ((iy & 0x1FFFFF) << 21) | ((iz & 0x1FFFFF) << 42));
  }
  return keys.size();
}
}  // namespace

PointCloud voxelKeypoints(const PointCloud& cloud, std::size_t n, std::mt19937_64& rng,
                          std::vector<std::size_t>* indices) {
  OBM_ASSERT(n > 0, "voxelKeypoints: n must be > 0");
  if (cloud.size() <= n) {
    if (indices) {
      indices->resize(cloud.size());
      std::iota(indices->begin(), indices->end(), std::size_t{0});
    }
    return cloud;
  }
  Eigen::Vector3f lo = cloud.points[0], hi = cloud.points[0];
  for (const auto& p : cloud.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const float extent = std::max(1e-6f, (hi - lo).maxCoeff());
  // count(v) falls as v grows; find the largest v with count(v) >= n. At v_lo = extent / 2^20
  // every point is (nearly) its own cell, so count(v_lo) >= n unless points coincide.
  float v_lo = extent / 1048576.0f, v_hi = extent;
  if (countCells(cloud, lo, v_lo) < n) v_hi = v_lo;  // duplicates: take the finest grid
  for (int it = 0; it < 18 && v_hi > v_lo * 1.02f; ++it) {
    const float mid = std::sqrt(v_lo * v_hi);
    (countCells(cloud, lo, mid) >= n ? v_lo : v_hi) = mid;
  }
  const auto cells = voxelCells(cloud, lo, v_lo);
  std::vector<const std::vector<std::uint32_t>*> list;
  list.reserve(cells.size());
  for (const auto& kv : cells) list.push_back(&kv.second);
  // Hash-map order is not portable: order the cells by their first point for determinism.
  std::sort(list.begin(), list.end(), [](const auto* a, const auto* b) { return (*a)[0] < (*b)[0]; });
  if (list.size() > n) {
    std::shuffle(list.begin(), list.end(), rng);
    list.resize(n);
    std::sort(list.begin(), list.end(),
              [](const auto* a, const auto* b) { return (*a)[0] < (*b)[0]; });
  }
  PointCloud out;
  out.frame_id = cloud.frame_id;
  out.points.reserve(list.size());
  if (indices) indices->clear();
  for (const auto* cell : list) {
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (auto i : *cell) c += cloud.points[i];
    c /= static_cast<float>(cell->size());
    out.points.push_back(c);
    if (indices) {
      std::uint32_t best = (*cell)[0];
      float best_d = std::numeric_limits<float>::max();
      for (auto i : *cell) {
        const float d = (cloud.points[i] - c).squaredNorm();
        if (d < best_d) {
          best_d = d;
          best = i;
        }
      }
      indices->push_back(best);
    }
  }
  return out;
}

namespace {

/// Calls fn(i, nbrs) for every point i with its `m` nearest points (itself included, unordered),
/// by brute force: for the network's clouds of a few thousand points.
template <typename Fn>
void forEachNeighbourhood(const PointCloud& cloud, std::size_t m, Fn&& fn) {
  const std::size_t n = cloud.size();
  std::vector<std::pair<float, std::uint32_t>> d(n);
  std::vector<std::uint32_t> nbrs(m);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    for (std::size_t j = 0; j < n; ++j)
      d[j] = {(cloud.points[j] - p).squaredNorm(), static_cast<std::uint32_t>(j)};
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(m - 1), d.end());
    for (std::size_t j = 0; j < m; ++j) nbrs[j] = d[j].second;
    fn(i, nbrs);
  }
}

}  // namespace

PointCloud neighbourMean(const PointCloud& cloud, int k) {
  OBM_ASSERT(k >= 0, "neighbourMean: k must be >= 0");
  const std::size_t n = cloud.size();
  if (k == 0 || n < 2) return cloud;
  // kk + 1: the point itself is its own nearest neighbour (distance 0).
  const auto kk = std::min<std::size_t>(static_cast<std::size_t>(k), n - 1);
  PointCloud out = cloud;
  forEachNeighbourhood(cloud, kk + 1, [&](std::size_t i, const std::vector<std::uint32_t>& nb) {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    for (const auto j : nb) sum += cloud.points[j];
    out.points[i] = sum / static_cast<float>(kk + 1);
  });
  return out;
}

std::vector<Vector3f> pcaNormals(const PointCloud& cloud, int k) {
  OBM_ASSERT(k >= 3, "pcaNormals: k must be >= 3");
  const std::size_t kk = std::min<std::size_t>(static_cast<std::size_t>(k), cloud.size());
  std::vector<Vector3f> normals(cloud.size(), Vector3f::UnitZ());
  if (kk < 3) return normals;
  forEachNeighbourhood(cloud, kk, [&](std::size_t i, const std::vector<std::uint32_t>& nb) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto j : nb) mean += cloud.points[j].cast<double>();
    mean /= static_cast<double>(kk);
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (const auto j : nb) {
      const Eigen::Vector3d q = cloud.points[j].cast<double>() - mean;
      C += q * q.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
    normals[i] = es.eigenvectors().col(0).cast<float>().normalized();
  });
  return normals;
}

RegistrationPair makeScanPair(const PointCloud& source_scan, const PointCloud& target_scan,
                              const Isometry3d& T_target_source, double voxel, int num_points,
                              std::mt19937_64& rng, bool voxel_keypoints, int surface_points) {
  RegistrationPair pair;
  const auto n = static_cast<std::size_t>(num_points);
  const PointCloud target_voxels = voxelDownsample(target_scan, voxel);
  if (voxel_keypoints) {
    pair.source = voxelKeypoints(voxelDownsample(source_scan, voxel), n, rng);
    pair.target = voxelKeypoints(target_voxels, n, rng);
  } else {
    pair.source = randomSubset(voxelDownsample(source_scan, voxel), n, rng);
    pair.target = randomSubset(target_voxels, n, rng);
  }
  if (surface_points > 0) {
    // A copy of the generator: the pair's other draws stay those of a pair without surfaces.
    std::mt19937_64 surface_rng = rng;
    surface_rng.discard(7);
    pair.target_surface =
        voxelKeypoints(target_voxels, static_cast<std::size_t>(surface_points), surface_rng);
    pair.target_normals = pcaNormals(pair.target_surface, 10);
  }
  pair.T_target_source = T_target_source;
  pair.overlap = -1.0;  // unknown for real scans
  return pair;
}

PairNormalization PairNormalization::compute(const PointCloud& source, const PointCloud& target,
                                             double radius, bool shared) {
  OBM_ASSERT(!source.empty() && !target.empty(), "PairNormalization: empty cloud");
  OBM_ASSERT(radius > 0.0, "PairNormalization: radius must be > 0");
  PairNormalization n;
  n.centroid_target = target.centroid().cast<double>();
  n.centroid_source = shared ? n.centroid_target : source.centroid().cast<double>();
  double r = 0.0;
  for (const auto& p : source.points)
    r = std::max(r, (p.cast<double>() - n.centroid_source).norm());
  for (const auto& p : target.points)
    r = std::max(r, (p.cast<double>() - n.centroid_target).norm());
  n.scale = r > 0.0 ? radius / r : 1.0;
  return n;
}

void PairNormalization::applySource(PointCloud& c) const {
  const Eigen::Vector3f cs = centroid_source.cast<float>();
  const auto s = static_cast<float>(scale);
  for (auto& p : c.points) p = s * (p - cs);
}

void PairNormalization::applyTarget(PointCloud& c) const {
  const Eigen::Vector3f ct = centroid_target.cast<float>();
  const auto s = static_cast<float>(scale);
  for (auto& p : c.points) p = s * (p - ct);
}

Isometry3d PairNormalization::denormalize(const Isometry3d& T_hat) const {
  // q = c_t + T̂(s(p − c_s))/s  ⇒  R = R̂, t = c_t + t̂/s − R̂ c_s.
  Isometry3d T = Isometry3d::Identity();
  T.linear() = T_hat.linear();
  T.translation() =
      centroid_target + T_hat.translation() / scale - T_hat.linear() * centroid_source;
  return T;
}

Isometry3d PairNormalization::normalize(const Isometry3d& T) const {
  Isometry3d T_hat = Isometry3d::Identity();
  T_hat.linear() = T.linear();
  T_hat.translation() = scale * (T.translation() - centroid_target + T.linear() * centroid_source);
  return T_hat;
}

}  // namespace obm::obmnet
