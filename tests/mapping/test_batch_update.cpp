// The batch insertion (Morton-sorted cells, one depth-first pass) must build exactly the tree that
// OctoMap's own insertPointCloud builds: same structure, same log-odds, for every option.
#include <gtest/gtest.h>
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <random>
#include <sstream>

#include "batch_update.hpp"
#include "mapping_test_utils.hpp"

namespace {

using obm::mapping::detail::BatchScratch;
using obm::mapping::detail::mortonDecode;
using obm::mapping::detail::mortonEncode;

TEST(BatchUpdate, MortonCodesRoundTripAndFollowTheOctree) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> d(0, 65535);
  for (int i = 0; i < 1000; ++i) {
    const octomap::OcTreeKey k(d(rng), d(rng), d(rng));
    EXPECT_EQ(mortonDecode(mortonEncode(k)), k);
  }
  // The top 3 bits hold the highest key bits: the root's child.
  const octomap::OcTreeKey k(0x8000, 0, 0x8000);
  EXPECT_EQ(mortonEncode(k) >> 45, 0b101u);
  EXPECT_LT(mortonEncode(octomap::OcTreeKey(0x7fff, 0x7fff, 0x7fff)),
            mortonEncode(octomap::OcTreeKey(0, 0, 0x8000)));
}

TEST(BatchUpdate, SortUniqueMatchesStdSort) {
  std::mt19937_64 rng(3);
  for (std::size_t n : {0u, 1u, 100u, 5000u, 70000u}) {
    std::vector<std::uint64_t> v(n), tmp;
    for (auto& x : v) x = rng() & ((std::uint64_t{1} << 48) - 1) & ~std::uint64_t{0xff00};
    for (std::size_t i = 0; i + 1 < n; i += 3) v[i + 1] = v[i];  // duplicates
    std::vector<std::uint64_t> ref = v;
    std::sort(ref.begin(), ref.end());
    ref.erase(std::unique(ref.begin(), ref.end()), ref.end());
    obm::mapping::detail::sortUnique48(v, tmp);
    EXPECT_EQ(v, ref) << n;
  }
}

octomap::Pointcloud toWorld(const obm::PointCloud& c, const obm::Isometry3d& T) {
  octomap::Pointcloud pc;
  for (const auto& p : c.points) {
    const Eigen::Vector3d w = T * p.cast<double>();
    pc.push_back(w.x(), w.y(), w.z());
  }
  return pc;
}

std::string serialise(octomap::AbstractOcTree& tree) {
  std::ostringstream os;
  tree.write(os);
  return os.str();
}

template <class Tree>
void expectSameTrees(bool lazy, bool discretize, double maxrange, int scans = 3,
                     int prune_after = -1) {
  Tree ref(0.2), batch(0.2);
  BatchScratch scratch;
  const Eigen::Vector3d lo(-6.1, -4.3, -1.7), hi(9.3, 5.1, 2.3);
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.f, 0.03f);
  for (int k = 0; k < scans; ++k) {
    obm::Isometry3d T = obm::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.3 * (k % 3), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.9 * (k % 3), -0.35 * (k % 3), 0.1 * (k % 3));
    obm::PointCloud scan = obm::test::boxRoomScan(lo, hi, T, 120, -50.0, 50.0, 4.0);
    for (auto& p : scan.points) p += obm::Vector3f(noise(rng), noise(rng), noise(rng));
    const octomap::Pointcloud pc = toWorld(scan, T);
    const octomap::point3d origin(T.translation().x(), T.translation().y(), T.translation().z());
    ref.insertPointCloud(pc, origin, maxrange, lazy, discretize);
    obm::mapping::detail::insertBatch(batch, pc, origin, maxrange, lazy, discretize, scratch);
    if (k == prune_after) {
      ref.updateInnerOccupancy();
      batch.updateInnerOccupancy();
      ref.prune();
      batch.prune();
    }
  }
  ref.updateInnerOccupancy();
  batch.updateInnerOccupancy();
  EXPECT_EQ(ref.size(), batch.size());
  EXPECT_EQ(ref.getNumLeafNodes(), batch.getNumLeafNodes());
  EXPECT_TRUE(serialise(ref) == serialise(batch)) << "the trees differ";
  ref.prune();
  batch.prune();
  EXPECT_GT(batch.getNumLeafNodes(), 1000u);
  EXPECT_TRUE(serialise(ref) == serialise(batch)) << "the pruned trees differ";
}

TEST(BatchUpdate, SameTreeAsInsertPointCloud) {
  for (bool lazy : {true, false})
    for (bool discretize : {true, false})
      for (double maxrange : {-1.0, 6.0}) {
        SCOPED_TRACE(::testing::Message() << "lazy " << lazy << " discretize " << discretize
                                          << " maxrange " << maxrange);
        expectSameTrees<octomap::OcTree>(lazy, discretize, maxrange);
      }
  expectSameTrees<octomap::ColorOcTree>(true, true, 6.0);
}

TEST(BatchUpdate, SameTreeOverPrunedClampedSpace) {
  // Many overlapping scans clamp the free space (five misses reach clamping_min), pruning merges
  // it into large leaves, and later scans then land in pruned, clamped leaves (OctoMap's early
  // abort) and in pruned leaves that must be expanded.
  for (double maxrange : {-1.0, 6.0}) {
    SCOPED_TRACE(::testing::Message() << "maxrange " << maxrange);
    expectSameTrees<octomap::OcTree>(true, true, maxrange, 9, 5);
  }
}

}  // namespace
