// OccupancyMap on synthetic scans with known geometry: occupied / free / unknown cells,
// resolution, statistics, .bt / .ot round trips read back by OctoMap itself, colour, top view.
#include <gtest/gtest.h>
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <set>
#include <tuple>

#include "mapping_test_utils.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/mapping/occupancy_map.hpp"
#include "test_data.hpp"

namespace {

using obm::Isometry3d;
using obm::mapping::CellState;
using obm::mapping::MapKind;
using obm::mapping::MappingParams;
using obm::mapping::OccupancyMap;
namespace fs = std::filesystem;

constexpr double kRes = 0.2;
constexpr double kWallDistance = 5.1;  // [m] in the sensor frame: the middle of a voxel layer

// Sensor 2 m along x, −1 m along y, 0.4 m up, turned 90° about z: sensor x = world y. Every
// offset is a multiple of the resolution, so voxel boundaries stay where the scan expects them.
Isometry3d sensorPose() {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(2.0, -1.0, 0.4);
  return T;
}

MappingParams exactParams() {
  MappingParams p;
  p.resolution = kRes;
  p.max_range = 50.0;
  p.prefilter_voxel = 0.0;
  p.discretize = false;
  p.lazy_update = false;
  p.prune_every = 0;
  return p;
}

using Key = std::tuple<long, long, long>;
Key keyOf(const Eigen::Vector3d& p) {
  return {std::lround(std::floor(p.x() / kRes)), std::lround(std::floor(p.y() / kRes)),
          std::lround(std::floor(p.z() / kRes))};
}

std::set<Key> wallVoxels(const obm::PointCloud& wall, const Isometry3d& T) {
  std::set<Key> keys;
  for (const auto& p : wall.points) keys.insert(keyOf(T * p.cast<double>()));
  return keys;
}

// Checks occupied at the wall, free between sensor and wall, unknown behind and aside.
void expectWallGeometry(const OccupancyMap& map, const obm::PointCloud& wall, const Isometry3d& T) {
  for (const auto& p : wall.points)
    EXPECT_EQ(map.state(T * p.cast<double>()), CellState::Occupied) << p.transpose();
  for (double ys : {-1.5, -0.6, 0.0, 0.7, 1.6})
    for (double zs : {-0.7, 0.0, 0.6}) {
      for (double xs = 0.5; xs <= kWallDistance - 0.4; xs += 0.3) {
        const double f = xs / kWallDistance;  // a point on the beam to (wall, ys, zs)
        const Eigen::Vector3d p_s(xs, ys * f, zs * f);
        EXPECT_EQ(map.state(T * p_s), CellState::Free) << "between, sensor " << p_s.transpose();
      }
      for (double xs = kWallDistance + 0.4; xs < kWallDistance + 4.0; xs += 0.5)
        EXPECT_EQ(map.state(T * Eigen::Vector3d(xs, ys, zs)), CellState::Unknown)
            << "behind the wall at sensor x " << xs;
    }
  EXPECT_EQ(map.state(T * Eigen::Vector3d(-3.0, 0.0, 0.0)), CellState::Unknown);
  EXPECT_EQ(map.state(T * Eigen::Vector3d(2.0, 3.0, 0.0)), CellState::Unknown);
}

TEST(OccupancyMap, WallOccupiedFreeUnknownExactRays) {
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  const Isometry3d T = sensorPose();
  OccupancyMap map(exactParams());
  const auto r = map.insert(wall, T);
  EXPECT_EQ(r.points_in, wall.size());
  EXPECT_EQ(r.rays, wall.size());
  EXPECT_EQ(r.points_dropped, 0u);
  expectWallGeometry(map, wall, T);

  // Exactly the voxels holding wall points are occupied, each a leaf at the resolution.
  std::vector<Eigen::Vector3d> centers;
  std::vector<double> sizes;
  map.occupiedVoxels(centers, sizes);
  const std::set<Key> expected = wallVoxels(wall, T);
  std::set<Key> got;
  for (std::size_t i = 0; i < centers.size(); ++i) {
    EXPECT_NEAR(sizes[i], kRes, 1e-9);
    got.insert(keyOf(centers[i]));
    // Centres sit in the middle of grid cells: (k + 1/2)·resolution.
    for (int a = 0; a < 3; ++a) {
      const double k = centers[i][a] / kRes - 0.5;
      EXPECT_NEAR(k, std::round(k), 1e-6);
    }
  }
  EXPECT_EQ(got, expected);
  EXPECT_EQ(map.stats().num_occupied_leaves, expected.size());
}

TEST(OccupancyMap, WallWithFastDefaults) {
  // The speed settings (discretised end points, voxel pre-filter, lazy inner nodes) must keep the
  // same geometry on a wall.
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  const Isometry3d T = sensorPose();
  MappingParams p;  // defaults, plus the pre-filter at the resolution
  p.resolution = kRes;
  p.prefilter_voxel = kRes;
  ASSERT_TRUE(p.discretize && p.lazy_update && p.batch_update);
  OccupancyMap map(p);
  const auto r = map.insert(wall, T);
  EXPECT_LT(r.rays, wall.size());  // the pre-filter merged points
  expectWallGeometry(map, wall, T);
  std::vector<Eigen::Vector3d> centers;
  std::vector<double> sizes;
  map.occupiedVoxels(centers, sizes);
  std::set<Key> got;
  for (const auto& c : centers) got.insert(keyOf(c));
  EXPECT_EQ(got, wallVoxels(wall, T));
}

TEST(OccupancyMap, ResolutionIsRespected) {
  for (double res : {0.1, 0.25, 0.5}) {
    MappingParams p = exactParams();
    p.resolution = res;
    OccupancyMap map(p);
    map.insert(obm::test::wallCloud(4.0 + res / 2, 1.0, 1.0, res / 4), Isometry3d::Identity());
    std::vector<Eigen::Vector3d> centers;
    std::vector<double> sizes;
    map.occupiedVoxels(centers, sizes);
    ASSERT_FALSE(centers.empty());
    for (double s : sizes) EXPECT_NEAR(s, res, 1e-9);
    const Eigen::Vector3d c = map.voxelCenter(Eigen::Vector3d(0.3 * res, 1.7 * res, -0.2 * res));
    // OctoMap's coordinates are floats.
    EXPECT_NEAR(c.x(), 0.5 * res, 1e-6);
    EXPECT_NEAR(c.y(), 1.5 * res, 1e-6);
    EXPECT_NEAR(c.z(), -0.5 * res, 1e-6);
    EXPECT_NEAR(map.stats().resolution, res, 1e-12);
  }
}

TEST(OccupancyMap, MaxRangeTruncatesBeams) {
  MappingParams p = exactParams();
  p.max_range = 3.0;
  OccupancyMap map(p);
  map.insert(obm::test::wallCloud(kWallDistance, 1.0, 0.5, 0.05), Isometry3d::Identity());
  EXPECT_EQ(map.stats().num_occupied_leaves, 0u);
  EXPECT_EQ(map.state(Eigen::Vector3d(2.5, 0.0, 0.0)), CellState::Free);
  EXPECT_EQ(map.state(Eigen::Vector3d(4.0, 0.0, 0.0)), CellState::Unknown);
  EXPECT_EQ(map.state(Eigen::Vector3d(kWallDistance, 0.0, 0.0)), CellState::Unknown);
}

TEST(OccupancyMap, MinRangeAndNonFiniteDropped) {
  MappingParams p = exactParams();
  p.min_range = 1.0;
  OccupancyMap map(p);
  auto cloud = obm::test::wallCloud(kWallDistance, 0.5, 0.5, 0.1);
  const std::size_t n_wall = cloud.size();
  cloud.points.emplace_back(0.5f, 0.f, 0.f);  // self-return
  cloud.points.emplace_back(std::nanf(""), 0.f, 0.f);
  const auto r = map.insert(cloud, Isometry3d::Identity());
  EXPECT_EQ(r.points_dropped, 2u);
  EXPECT_EQ(r.rays, n_wall);
  EXPECT_NE(map.state(Eigen::Vector3d(0.5, 0.0, 0.0)), CellState::Occupied);
}

TEST(OccupancyMap, StatsVolumesConsistent) {
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  OccupancyMap map(exactParams());
  map.insert(wall, sensorPose());
  const auto s = map.stats();
  const double voxel = kRes * kRes * kRes;
  EXPECT_EQ(s.num_leaves, s.num_occupied_leaves + s.num_free_leaves);
  EXPECT_GT(s.num_nodes, s.num_leaves);
  EXPECT_NEAR(s.occupied_volume_m3, voxel * s.num_occupied_leaves, 1e-9);  // nothing pruned
  EXPECT_GT(s.free_volume_m3, 0.0);
  EXPECT_GT(s.memory_bytes, 0u);
  // Known space fits in its bounding box; occupied bounds are inside the known bounds.
  const Eigen::Vector3d e = s.bbox_max - s.bbox_min;
  EXPECT_LE(s.occupied_volume_m3 + s.free_volume_m3, e.prod() + 1e-9);
  EXPECT_TRUE((s.occupied_min.array() >= s.bbox_min.array() - 1e-9).all());
  EXPECT_TRUE((s.occupied_max.array() <= s.bbox_max.array() + 1e-9).all());
  // The wall is the far side of the known space along world +y, one voxel thick.
  EXPECT_NEAR(s.bbox_max.y(), 4.2, 1e-6);
  EXPECT_NEAR(s.occupied_min.y(), 4.0, 1e-6);
  EXPECT_NEAR(s.occupied_max.y(), 4.2, 1e-6);

  // Pruning is lossless: volumes stay, leaves do not grow.
  map.prune();
  const auto q = map.stats();
  EXPECT_NEAR(q.occupied_volume_m3, s.occupied_volume_m3, 1e-9);
  EXPECT_NEAR(q.free_volume_m3, s.free_volume_m3, 1e-9);
  EXPECT_LE(q.num_leaves, s.num_leaves);
  EXPECT_NEAR((q.bbox_max - s.bbox_max).norm(), 0.0, 1e-9);
}

TEST(OccupancyMap, LazyAndEagerUpdatesAgree) {
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  MappingParams eager = exactParams();
  MappingParams lazy = exactParams();
  lazy.lazy_update = true;
  OccupancyMap a(eager), b(lazy);
  for (int k = 0; k < 3; ++k) {
    Isometry3d T = sensorPose();
    T.translation().x() += 0.2 * k;
    a.insert(wall, T);
    b.insert(wall, T);
  }
  a.prune();
  b.prune();
  const auto sa = a.stats(), sb = b.stats();
  EXPECT_EQ(sa.num_leaves, sb.num_leaves);
  EXPECT_EQ(sa.num_nodes, sb.num_nodes);
  EXPECT_NEAR(sa.free_volume_m3, sb.free_volume_m3, 1e-9);
  EXPECT_NEAR(sa.occupied_volume_m3, sb.occupied_volume_m3, 1e-9);
}

TEST(OccupancyMap, IntegrateWithProgressAndClear) {
  const auto wall = obm::test::wallCloud(kWallDistance, 1.0, 0.5, 0.05);
  std::vector<obm::mapping::PosedCloud> clouds(3);
  for (int k = 0; k < 3; ++k) {
    clouds[k].cloud = wall;
    clouds[k].T_world_sensor.translation() = Eigen::Vector3d(0.0, 0.4 * k, 0.0);
  }
  OccupancyMap map(exactParams());
  std::vector<std::size_t> seen;
  EXPECT_EQ(map.integrate(clouds,
                          [&](std::size_t done, std::size_t total) {
                            EXPECT_EQ(total, 3u);
                            seen.push_back(done);
                            return true;
                          }),
            3u);
  EXPECT_EQ(seen, (std::vector<std::size_t>{1, 2, 3}));
  EXPECT_EQ(map.stats().num_insertions, 3u);
  EXPECT_EQ(map.state(Eigen::Vector3d(kWallDistance, 0.8 + 0.95, 0.0)), CellState::Occupied);

  // Re-integration: clear, then the same clouds at other poses; a callback can stop it.
  map.clear();
  EXPECT_TRUE(map.stats().empty());
  std::vector<obm::PointCloud> raw{wall, wall};
  std::vector<Isometry3d> poses(2, Isometry3d::Identity());
  poses[1].translation().z() = 2.0;
  EXPECT_EQ(map.integrate(raw, poses, [](std::size_t done, std::size_t) { return done < 1; }), 1u);
  EXPECT_EQ(map.stats().num_insertions, 1u);
  EXPECT_EQ(map.state(Eigen::Vector3d(kWallDistance, 0.0, 0.0)), CellState::Occupied);
  EXPECT_EQ(map.state(Eigen::Vector3d(kWallDistance, 0.0, 2.0)), CellState::Unknown);
  poses.pop_back();
  EXPECT_THROW(map.integrate(raw, poses), obm::ContractError);
}

TEST(OccupancyMap, BinaryRoundTripWithOctomap) {
  const std::string dir = obm::test::scratchDir("mapping_bt");
  OccupancyMap map(exactParams());
  map.insert(obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05), sensorPose());
  const std::string path = dir + "/wall.bt";
  map.write(path);
  const auto s = map.stats();  // after the pruning done by write()

  octomap::OcTree tree(0.05);
  ASSERT_TRUE(tree.readBinary(path));
  EXPECT_NEAR(tree.getResolution(), kRes, 1e-12);
  EXPECT_EQ(tree.getNumLeafNodes(), s.num_leaves);
  std::size_t occupied = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
    occupied += tree.isNodeOccupied(*it);
  EXPECT_EQ(occupied, s.num_occupied_leaves);

  // Our reader gives the same map back.
  const OccupancyMap back = OccupancyMap::read(path);
  EXPECT_EQ(back.stats().num_leaves, s.num_leaves);
  EXPECT_NEAR(back.stats().occupied_volume_m3, s.occupied_volume_m3, 1e-9);
  // Only the map itself is left in the folder (the temporary was renamed).
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);
}

TEST(OccupancyMap, FullRoundTripKeepsProbabilities) {
  const std::string dir = obm::test::scratchDir("mapping_ot");
  OccupancyMap map(exactParams());
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  map.insert(wall, sensorPose());
  map.insert(wall, sensorPose());
  const std::string path = dir + "/wall.ot";
  map.write(path);
  const auto s = map.stats();

  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(path));
  ASSERT_TRUE(any);
  auto* tree = dynamic_cast<octomap::OcTree*>(any.get());
  ASSERT_NE(tree, nullptr);
  EXPECT_EQ(tree->getNumLeafNodes(), s.num_leaves);
  const Eigen::Vector3d p_wall = sensorPose() * Eigen::Vector3d(kWallDistance, 0.1, 0.1);
  const Eigen::Vector3d p_free = sensorPose() * Eigen::Vector3d(2.0, 0.1, 0.1);
  for (const auto& p : {p_wall, p_free}) {
    const auto* node = tree->search(p.x(), p.y(), p.z());
    ASSERT_NE(node, nullptr);
    EXPECT_NEAR(node->getOccupancy(), map.occupancy(p), 1e-6);
  }
  // Two hits of p_hit = 0.7: log-odds 2·logit(0.7), not the clamped maximum-likelihood value.
  const double l = 2.0 * std::log(0.7 / 0.3);
  EXPECT_NEAR(map.occupancy(p_wall), 1.0 / (1.0 + std::exp(-l)), 1e-5);

  const OccupancyMap back = OccupancyMap::read(path);
  EXPECT_NEAR(back.occupancy(p_wall), map.occupancy(p_wall), 1e-6);
  EXPECT_EQ(back.stats().num_leaves, s.num_leaves);
}

TEST(OccupancyMap, ColorTreeWhenColoursGiven) {
  const std::string dir = obm::test::scratchDir("mapping_color");
  OccupancyMap map(exactParams(), MapKind::Color);
  EXPECT_EQ(map.kind(), MapKind::Color);
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05, /*with_color=*/true);
  map.insert(wall, sensorPose());
  const Eigen::Vector3d p_wall = sensorPose() * Eigen::Vector3d(kWallDistance, 0.1, 0.1);
  obm::Color3u8 rgb;
  ASSERT_TRUE(map.color(p_wall, rgb));
  EXPECT_NEAR(rgb[0], 220, 2);
  EXPECT_NEAR(rgb[1], 30, 2);
  EXPECT_NEAR(rgb[2], 40, 2);

  map.write(dir + "/wall.ot");
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(dir + "/wall.ot"));
  auto* ctree = dynamic_cast<octomap::ColorOcTree*>(any.get());
  ASSERT_NE(ctree, nullptr);
  const auto* node = ctree->search(p_wall.x(), p_wall.y(), p_wall.z());
  ASSERT_NE(node, nullptr);
  EXPECT_NEAR(node->getColor().r, 220, 2);
  EXPECT_EQ(ctree->getNumLeafNodes(), map.stats().num_leaves);

  // The .bt of a colour map is an ordinary OcTree for every OctoMap reader.
  map.write(dir + "/wall.bt");
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(dir + "/wall.bt"));
  EXPECT_EQ(tree.getNumLeafNodes(), map.stats().num_leaves);
  const auto* bnode = tree.search(p_wall.x(), p_wall.y(), p_wall.z());
  ASSERT_NE(bnode, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(bnode));

  // A plain map has no colours.
  OccupancyMap plain(exactParams());
  plain.insert(wall, sensorPose());
  EXPECT_FALSE(plain.color(p_wall, rgb));
}

TEST(OccupancyMap, TopViewMatchesExtent) {
  const auto wall = obm::test::wallCloud(kWallDistance, 2.0, 1.0, 0.05);
  const Isometry3d T = sensorPose();
  OccupancyMap map(exactParams());
  map.insert(wall, T);
  const auto s = map.stats();
  const auto img = map.renderTopView();
  const auto& info = img.info;
  EXPECT_EQ(img.rgb.size(), 3u * static_cast<std::size_t>(info.width) * info.height);
  EXPECT_EQ(info.width, std::lround((s.bbox_max.x() - s.bbox_min.x()) / kRes));
  EXPECT_EQ(info.height, std::lround((s.bbox_max.y() - s.bbox_min.y()) / kRes));
  EXPECT_NEAR(info.pixel_size, kRes, 1e-12);
  EXPECT_GT(info.occupied_pixels, 0u);
  EXPECT_GT(info.free_pixels, 0u);

  const auto pixelAt = [&](const Eigen::Vector3d& p_world) {
    const int col = static_cast<int>(std::floor((p_world.x() - info.x_min) / info.pixel_size));
    const int row = static_cast<int>(std::floor((info.y_max - p_world.y()) / info.pixel_size));
    EXPECT_TRUE(col >= 0 && col < info.width && row >= 0 && row < info.height);
    return img.at(col, row);
  };
  const obm::Color3u8 white(255, 255, 255);
  const obm::Color3u8 wall_px = pixelAt(T * Eigen::Vector3d(kWallDistance, 0.1, 0.0));
  const obm::Color3u8 free_px = pixelAt(T * Eigen::Vector3d(2.5, 0.1, 0.0));
  const obm::Color3u8 unknown_px = pixelAt(T * Eigen::Vector3d(0.3, 1.9, 0.0));
  EXPECT_NE(wall_px, white);
  EXPECT_FALSE(wall_px[0] == wall_px[1] && wall_px[1] == wall_px[2]) << "occupied is coloured";
  EXPECT_EQ(free_px[0], free_px[1]);  // grey
  EXPECT_EQ(free_px[1], free_px[2]);
  EXPECT_LT(free_px[0], 255);
  EXPECT_EQ(unknown_px, white);

  // Larger pixels shrink the picture accordingly; an empty map has no picture.
  obm::mapping::TopViewOptions o;
  o.pixel_size = 2 * kRes;
  const auto half = map.renderTopView(o).info;
  EXPECT_EQ(half.width, (info.width + 1) / 2);
  // A height window below the wall's lowest voxel (world z from −0.6 m) hides it.
  obm::mapping::TopViewOptions low;
  low.z_max = -0.7;
  const auto hidden = map.renderTopView(low).info;
  EXPECT_EQ(hidden.occupied_pixels, 0u);
  OccupancyMap empty(exactParams());
  EXPECT_THROW(empty.renderTopView(), obm::ContractError);
}

TEST(OccupancyMap, WriteRejectsUnknownExtensionAndMissingFolder) {
  OccupancyMap map(exactParams());
  map.insert(obm::test::wallCloud(3.1, 0.5, 0.5, 0.1), Isometry3d::Identity());
  const std::string dir = obm::test::scratchDir("mapping_bad_write");
  EXPECT_THROW(map.write(dir + "/map.ply"), obm::ConfigError);
  EXPECT_THROW(map.write(dir + "/no/such/folder/map.bt"), obm::IoError);
  EXPECT_THROW(OccupancyMap::read(dir + "/missing.bt"), obm::IoError);
  // A file that is not an octree.
  { std::ofstream(dir + "/junk.bt") << "not an octree\n"; }
  EXPECT_THROW(OccupancyMap::read(dir + "/junk.bt"), obm::FormatError);
}

TEST(MappingParams, LoadFromYaml) {
  const auto node = obm::ConfigNode::fromString(
      "resolution: 0.1\nmax_range: 30\nprob_hit: 0.8\ndiscretize: false\nprefilter_voxel: 0\n",
      "mapping.yaml");
  const MappingParams p = MappingParams::load(node);
  EXPECT_DOUBLE_EQ(p.resolution, 0.1);
  EXPECT_DOUBLE_EQ(p.max_range, 30.0);
  EXPECT_DOUBLE_EQ(p.prob_hit, 0.8);
  EXPECT_FALSE(p.discretize);
  EXPECT_DOUBLE_EQ(p.prefilter_voxel, 0.0);
  EXPECT_DOUBLE_EQ(p.prob_miss, MappingParams{}.prob_miss);  // default kept

  try {
    MappingParams::load(obm::ConfigNode::fromString("resolutoin: 0.1\n", "m.yaml"));
    FAIL() << "a misspelt key must be rejected";
  } catch (const obm::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("resolutoin"), std::string::npos) << e.what();
  }
  try {
    MappingParams::load(obm::ConfigNode::fromString("prob_hit: 0.3\n", "m.yaml"));
    FAIL() << "prob_hit <= 0.5 must be rejected";
  } catch (const obm::ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("m.yaml"), std::string::npos) << msg;
    EXPECT_NE(msg.find("prob_hit"), std::string::npos) << msg;
  }
  MappingParams bad;
  bad.resolution = 0.0;
  EXPECT_THROW(OccupancyMap{bad}, obm::ConfigError);
  MappingParams coarse;
  coarse.prefilter_voxel = 2 * coarse.resolution;
  EXPECT_THROW(coarse.validate(), obm::ConfigError);
}

}  // namespace
