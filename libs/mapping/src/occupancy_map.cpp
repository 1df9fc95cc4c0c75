#include "obm/mapping/occupancy_map.hpp"

#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <unordered_map>

#include "obm/core/atomic_file.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"
#include "tree_access.hpp"

namespace obm::mapping {

namespace fs = std::filesystem;

namespace {

void applyParams(octomap::AbstractOccupancyOcTree& tree, const MappingParams& p) {
  tree.setProbHit(p.prob_hit);
  tree.setProbMiss(p.prob_miss);
  tree.setClampingThresMin(p.clamping_min);
  tree.setClampingThresMax(p.clamping_max);
  tree.setOccupancyThres(p.occupancy_threshold);
}

std::string lowerExtension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

OccupancyMap::Impl::Impl(const MappingParams& p, MapKind k) : params(p), kind(k) {
  params.validate();
  if (kind == MapKind::Color) {
    color = std::make_unique<octomap::ColorOcTree>(params.resolution);
    applyParams(*color, params);
  } else {
    occ = std::make_unique<octomap::OcTree>(params.resolution);
    applyParams(*occ, params);
  }
}

void OccupancyMap::Impl::ensureInnerUpdated() {
  if (!inner_dirty) return;
  // ColorOcTree::updateInnerOccupancy hides the base version (it also averages colours), so it is
  // called on the concrete type.
  visit([](auto& tree) { tree.updateInnerOccupancy(); });
  inner_dirty = false;
}

OccupancyMap::OccupancyMap(const MappingParams& params, MapKind kind)
    : impl_(std::make_unique<Impl>(params, kind)) {}
OccupancyMap::OccupancyMap(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OccupancyMap::~OccupancyMap() = default;
OccupancyMap::OccupancyMap(OccupancyMap&&) noexcept = default;
OccupancyMap& OccupancyMap::operator=(OccupancyMap&&) noexcept = default;

const MappingParams& OccupancyMap::params() const noexcept {
  return impl_->params;
}
MapKind OccupancyMap::kind() const noexcept {
  return impl_->kind;
}

InsertResult OccupancyMap::insert(const PointCloud& cloud_sensor,
                                  const Isometry3d& T_world_sensor) {
  cloud_sensor.validate();
  Timer timer;
  Impl& m = *impl_;
  const MappingParams& p = m.params;
  InsertResult r;
  r.points_in = cloud_sensor.size();

  // 1. Drop non-finite points and self-returns (in the sensor frame, where range = ‖p‖).
  std::vector<std::size_t> keep;
  keep.reserve(cloud_sensor.size());
  const float min_r2 = static_cast<float>(p.min_range * p.min_range);
  for (std::size_t i = 0; i < cloud_sensor.size(); ++i) {
    const Vector3f& q = cloud_sensor.points[i];
    if (!q.allFinite() || q.squaredNorm() < min_r2) continue;
    keep.push_back(i);
  }
  r.points_dropped = r.points_in - keep.size();
  const bool all_kept = keep.size() == cloud_sensor.size();
  PointCloud selected;
  if (!all_kept) selected = cloud_sensor.select(keep);
  const PointCloud& base = all_kept ? cloud_sensor : selected;

  // 2. Optional voxel pre-filter: one ray per voxel centroid instead of one per point.
  PointCloud filtered;
  if (p.prefilter_voxel > 0.0) filtered = voxelDownsample(base, p.prefilter_voxel);
  const PointCloud& rays = p.prefilter_voxel > 0.0 ? filtered : base;
  r.rays = rays.size();

  // 3. To the world frame, then OctoMap's scan insertion from the sensor origin.
  const Eigen::Matrix3f R = T_world_sensor.linear().cast<float>();
  const Eigen::Vector3f t = T_world_sensor.translation().cast<float>();
  octomap::Pointcloud scan;
  scan.reserve(rays.size());
  for (const Vector3f& q : rays.points) {
    const Eigen::Vector3f w = R * q + t;
    scan.push_back(w.x(), w.y(), w.z());
  }
  const octomap::point3d origin(t.x(), t.y(), t.z());
  const double maxrange = p.max_range > 0.0 ? p.max_range : -1.0;
  m.visit([&](auto& tree) {
    if (p.batch_update) {
      detail::insertBatch(tree, scan, origin, maxrange, p.lazy_update, p.discretize, m.scratch);
      r.beams = m.scratch.beams;
    } else {
      tree.insertPointCloud(scan, origin, maxrange, p.lazy_update, p.discretize);
      r.beams = p.discretize ? 0 : scan.size();  // OctoMap does not report its end cells
    }
  });
  if (p.lazy_update) m.inner_dirty = true;

  // 4. Colours. OctoMap's integrateNodeColor blends with weights (p, 0.99 − p) that do not sum to
  // one and drifts away from the true colour; instead the exact mean of this scan's points in
  // each end cell is averaged 1:1 with the cell's previous colour (OctoMap's averageNodeColor).
  if (m.kind == MapKind::Color && rays.hasColors()) {
    struct Acc {
      std::uint32_t r = 0, g = 0, b = 0, n = 0;
    };
    std::unordered_map<octomap::OcTreeKey, Acc, octomap::OcTreeKey::KeyHash> cells;
    const double max_r2 = maxrange > 0.0 ? maxrange * maxrange : -1.0;
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const octomap::point3d& w = scan[i];
      if (max_r2 > 0.0 && (w - origin).norm_sq() > max_r2) continue;
      octomap::OcTreeKey key;
      if (!m.color->coordToKeyChecked(w, key)) continue;
      Acc& a = cells[key];
      a.r += rays.colors[i][0];
      a.g += rays.colors[i][1];
      a.b += rays.colors[i][2];
      ++a.n;
    }
    for (const auto& [key, a] : cells) {
      const auto n = a.n;
      const auto mean = [n](std::uint32_t sum) {
        return static_cast<std::uint8_t>((sum + n / 2) / n);
      };
      octomap::ColorOcTreeNode* node = m.color->search(key);
      if (!node) continue;
      if (node->isColorSet())
        m.color->averageNodeColor(key, mean(a.r), mean(a.g), mean(a.b));
      else
        node->setColor(mean(a.r), mean(a.g), mean(a.b));
    }
  }

  ++m.num_insertions;
  m.num_rays += r.rays;
  if (p.prune_every > 0 && ++m.insertions_since_prune >= p.prune_every) prune();
  r.time_ms = timer.ms();
  return r;
}

std::size_t OccupancyMap::integrate(const std::vector<PosedCloud>& clouds,
                                    const IntegrateProgress& progress) {
  std::size_t done = 0;
  for (const PosedCloud& pc : clouds) {
    insert(pc.cloud, pc.T_world_sensor);
    ++done;
    if (progress && !progress(done, clouds.size())) break;
  }
  return done;
}

std::size_t OccupancyMap::integrate(const std::vector<PointCloud>& clouds_sensor,
                                    const std::vector<Isometry3d>& T_world_sensor,
                                    const IntegrateProgress& progress) {
  if (clouds_sensor.size() != T_world_sensor.size())
    throw ContractError("OccupancyMap::integrate: " + std::to_string(clouds_sensor.size()) +
                        " clouds but " + std::to_string(T_world_sensor.size()) + " poses");
  std::size_t done = 0;
  for (std::size_t i = 0; i < clouds_sensor.size(); ++i) {
    insert(clouds_sensor[i], T_world_sensor[i]);
    ++done;
    if (progress && !progress(done, clouds_sensor.size())) break;
  }
  return done;
}

void OccupancyMap::clear() {
  impl_->visit([](auto& tree) { tree.clear(); });
  impl_->inner_dirty = false;
  impl_->num_insertions = 0;
  impl_->num_rays = 0;
  impl_->insertions_since_prune = 0;
}

void OccupancyMap::prune() {
  impl_->ensureInnerUpdated();
  impl_->visit([](auto& tree) { tree.prune(); });
  impl_->insertions_since_prune = 0;
}

CellState OccupancyMap::state(const Eigen::Vector3d& p_world) const {
  impl_->ensureInnerUpdated();
  CellState s = CellState::Unknown;
  impl_->visit([&](auto& tree) {
    const auto* node = tree.search(p_world.x(), p_world.y(), p_world.z());
    if (node) s = tree.isNodeOccupied(node) ? CellState::Occupied : CellState::Free;
  });
  return s;
}

double OccupancyMap::occupancy(const Eigen::Vector3d& p_world) const {
  impl_->ensureInnerUpdated();
  double prob = -1.0;
  impl_->visit([&](auto& tree) {
    const auto* node = tree.search(p_world.x(), p_world.y(), p_world.z());
    if (node) prob = node->getOccupancy();
  });
  return prob;
}

bool OccupancyMap::color(const Eigen::Vector3d& p_world, Color3u8& rgb) const {
  if (impl_->kind != MapKind::Color) return false;
  impl_->ensureInnerUpdated();
  const auto* node = impl_->color->search(p_world.x(), p_world.y(), p_world.z());
  if (!node || !node->isColorSet()) return false;
  const auto c = node->getColor();
  rgb = Color3u8(c.r, c.g, c.b);
  return true;
}

Eigen::Vector3d OccupancyMap::voxelCenter(const Eigen::Vector3d& p_world) const {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  impl_->visit([&](auto& tree) {
    const octomap::OcTreeKey key = tree.coordToKey(p_world.x(), p_world.y(), p_world.z());
    const octomap::point3d q = tree.keyToCoord(key);
    c = Eigen::Vector3d(q.x(), q.y(), q.z());
  });
  return c;
}

void OccupancyMap::occupiedVoxels(std::vector<Eigen::Vector3d>& centers,
                                  std::vector<double>& sizes) const {
  impl_->ensureInnerUpdated();
  centers.clear();
  sizes.clear();
  impl_->visit([&](auto& tree) {
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      if (!tree.isNodeOccupied(*it)) continue;
      centers.emplace_back(it.getX(), it.getY(), it.getZ());
      sizes.push_back(it.getSize());
    }
  });
}

MapStats OccupancyMap::stats() const {
  impl_->ensureInnerUpdated();
  MapStats s;
  s.resolution = impl_->params.resolution;
  s.num_insertions = impl_->num_insertions;
  s.num_rays = impl_->num_rays;
  impl_->visit([&](auto& tree) {
    s.num_nodes = tree.size();
    s.memory_bytes = tree.memoryUsage();
    Eigen::Vector3d kmin = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d kmax = -kmin, omin = kmin, omax = kmax;
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      const double size = it.getSize();
      const double vol = size * size * size;
      const Eigen::Vector3d c(it.getX(), it.getY(), it.getZ());
      const Eigen::Vector3d lo = c.array() - 0.5 * size, hi = c.array() + 0.5 * size;
      ++s.num_leaves;
      kmin = kmin.cwiseMin(lo);
      kmax = kmax.cwiseMax(hi);
      if (tree.isNodeOccupied(*it)) {
        ++s.num_occupied_leaves;
        s.occupied_volume_m3 += vol;
        omin = omin.cwiseMin(lo);
        omax = omax.cwiseMax(hi);
      } else {
        ++s.num_free_leaves;
        s.free_volume_m3 += vol;
      }
    }
    if (s.num_leaves > 0) {
      s.bbox_min = kmin;
      s.bbox_max = kmax;
    }
    if (s.num_occupied_leaves > 0) {
      s.occupied_min = omin;
      s.occupied_max = omax;
    }
  });
  return s;
}

void OccupancyMap::writeBinary(const std::string& path) {
  prune();
  Impl& m = *impl_;
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        // OctoMap's binary layout: a text header, then two bits per child (free / occupied /
        // inner) and nothing else, so the bits of a ColorOcTree are those of the OcTree of its
        // occupancy. The header is written here (OctoMap's writeBinaryConst would print a
        // debug line) with the id "OcTree", so that OcTree::readBinary accepts either map.
        m.visit([&](auto& tree) {
          os << "# Octomap OcTree binary file\n";
          os << "# written by obmslam" << (m.kind == MapKind::Color ? " from a ColorOcTree" : "")
             << "\n";
          os << "id OcTree\n";
          os << "size " << tree.size() << "\n";
          os << "res " << std::setprecision(17) << tree.getResolution() << "\n";
          os << "data\n";
          tree.writeBinaryData(os);
        });
        // A failed stream (full disk) is reported by writeFileAtomically with the system's reason.
      },
      /*binary=*/true);
}

void OccupancyMap::writeFull(const std::string& path) {
  prune();
  Impl& m = *impl_;
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        const bool ok = m.visit([&](auto& tree) { return tree.write(os); });
        // A failed stream is reported by writeFileAtomically with the system's reason.
        if (!ok && os) throw IoError("cannot write '" + path + "': OctoMap's writer failed");
      },
      /*binary=*/true);
}

void OccupancyMap::write(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".bt")
    writeBinary(path);
  else if (ext == ".ot")
    writeFull(path);
  else
    throw ConfigError("'" + path +
                      "': the map file must end in .bt (binary, maximum likelihood) "
                      "or .ot (full probabilities)");
}

OccupancyMap OccupancyMap::read(const std::string& path, const MappingParams& params) {
  if (!fs::is_regular_file(path)) throw IoError("cannot read '" + path + "': no such file");
  const std::string ext = lowerExtension(path);
  auto impl = std::make_unique<Impl>(params, MapKind::Occupancy);
  if (ext == ".bt") {
    auto tree = std::make_unique<octomap::OcTree>(params.resolution);
    if (!tree->readBinary(path))
      throw FormatError(path, 0, "OctoMap could not read this binary (.bt) tree");
    impl->occ = std::move(tree);
  } else if (ext == ".ot") {
    std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(path));
    if (!any) throw FormatError(path, 0, "OctoMap could not read this (.ot) tree");
    if (auto* c = dynamic_cast<octomap::ColorOcTree*>(any.get())) {
      any.release();
      impl->occ.reset();
      impl->color.reset(c);
      impl->kind = MapKind::Color;
    } else if (auto* o = dynamic_cast<octomap::OcTree*>(any.get())) {
      any.release();
      impl->occ.reset(o);
    } else {
      throw FormatError(path, 0,
                        "tree type '" + any->getTreeType() + "' is not OcTree or ColorOcTree");
    }
  } else {
    throw ConfigError("'" + path + "': expected a .bt or .ot file");
  }
  impl->visit([&](auto& tree) {
    impl->params.resolution = tree.getResolution();
    applyParams(tree, impl->params);
  });
  return OccupancyMap(std::move(impl));
}

std::string formatStats(const MapStats& s) {
  std::ostringstream os;
  os << std::fixed;
  os << "resolution      " << std::setprecision(3) << s.resolution << " m\n";
  os << "nodes           " << s.num_nodes << " (" << s.num_leaves
     << " leaves: " << s.num_occupied_leaves << " occupied, " << s.num_free_leaves << " free)\n";
  os << "occupied volume " << std::setprecision(2) << s.occupied_volume_m3 << " m3\n";
  os << "free volume     " << std::setprecision(2) << s.free_volume_m3 << " m3\n";
  os << "memory          " << std::setprecision(2)
     << static_cast<double>(s.memory_bytes) / (1024.0 * 1024.0) << " MiB\n";
  os << std::setprecision(2);
  os << "bounding box    [" << s.bbox_min.x() << ", " << s.bbox_max.x() << "] x [" << s.bbox_min.y()
     << ", " << s.bbox_max.y() << "] x [" << s.bbox_min.z() << ", " << s.bbox_max.z() << "] m";
  if (s.num_leaves > 0) {
    const Eigen::Vector3d e = s.bbox_max - s.bbox_min;
    os << " (" << e.x() << " x " << e.y() << " x " << e.z() << " m)";
  }
  os << "\n";
  return os.str();
}

}  // namespace obm::mapping
