#pragma once
// Private: a faster equivalent of OctoMap's insertPointCloud (OccupancyOcTreeBase, 1.9).
//
// OctoMap collects the cells crossed by the beams in a hash set (KeySet), removes the end cells
// from it, then updates the cells in hash order, so consecutive updates descend the tree along
// unrelated paths. Here the cells are collected as Morton codes in a flat array, radix-sorted and
// de-duplicated, and updated in Morton order — the depth-first order of the octree — so that
// consecutive descents share most of their path and stay in cache. Every cell receives exactly the
// same single update as with insertPointCloud (same ray traversal: OctoMap's computeRayKeys; same
// rules for max range, discretisation and occupied-over-free preference), so the resulting tree
// is the same; only the work order differs.
#include <cstddef>
#include <cstdint>
#include <vector>
// OcTreeKey.h needs the standard headers above and octomap_types.h included before it.
#include <octomap/OcTreeKey.h>
#include <octomap/Pointcloud.h>
#include <octomap/octomap_types.h>

namespace obm::mapping::detail {

/// Bit i of a byte moved to bit 3·i (a 256-entry table: cheaper than shift-and-mask steps in
/// the per-cell loop).
struct SpreadTable {
  std::uint32_t t[256];
  SpreadTable() {
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t v = 0;
      for (int b = 0; b < 8; ++b) v |= ((i >> b) & 1u) << (3 * b);
      t[i] = v;
    }
  }
};
inline const SpreadTable kSpreadTable;

/// Interleaves the 16-bit key coordinates into a 48-bit Morton code, most significant level
/// first (bit 3·i+2 from k[0], 3·i+1 from k[1], 3·i from k[2] at level i).
inline std::uint64_t mortonEncode(const octomap::OcTreeKey& k) {
  const auto spread = [](std::uint64_t v) -> std::uint64_t {
    return kSpreadTable.t[v & 0xff] |
           (static_cast<std::uint64_t>(kSpreadTable.t[(v >> 8) & 0xff]) << 24);
  };
  return (spread(k[0]) << 2) | (spread(k[1]) << 1) | spread(k[2]);
}

inline octomap::OcTreeKey mortonDecode(std::uint64_t m) {
  const auto compact = [](std::uint64_t v) {
    v &= 0x249249249249ULL;
    v = (v | (v >> 2)) & 0x0c30c30c30c3ULL;
    v = (v | (v >> 4)) & 0x00f00f00f00fULL;
    v = (v | (v >> 8)) & 0x0000ff0000ffULL;
    v = (v | (v >> 16)) & 0xffffULL;
    return static_cast<octomap::key_type>(v);
  };
  return octomap::OcTreeKey(compact(m >> 2), compact(m >> 1), compact(m));
}

/// Sorts 48-bit codes in place (LSD radix sort, three 16-bit digits) and removes duplicates.
void sortUnique48(std::vector<std::uint64_t>& v, std::vector<std::uint64_t>& scratch);

/// Reused buffers (one set per map, so repeated insertions do not reallocate).
struct BatchScratch {
  std::vector<std::uint64_t> free_cells, occupied_cells, endpoints, tmp;
  std::size_t beams = 0;  ///< beams cast by the last computeBatchUpdate
  /// Direct-mapped cache of recently pushed cells: beams leave the sensor through the same cells,
  /// so most repeats are caught here before they reach the sort.
  std::vector<std::uint64_t> recent;
};

/// Computes the cells to update for `scan` seen from `origin`, exactly as OctoMap's
/// computeUpdate / computeDiscreteUpdate: `free_cells` (sorted, unique, without end cells) and
/// `occupied_cells` (sorted, unique), both as Morton codes.
template <class Tree>
void computeBatchUpdate(const Tree& tree, const octomap::Pointcloud& scan,
                        const octomap::point3d& origin, double maxrange, bool discretize,
                        BatchScratch& s) {
  s.free_cells.clear();
  s.occupied_cells.clear();
  // Discretisation: one beam to the centre of each distinct end cell (computeDiscreteUpdate).
  octomap::Pointcloud discrete;
  const octomap::Pointcloud* beams = &scan;
  if (discretize) {
    s.endpoints.clear();
    s.endpoints.reserve(scan.size());
    for (std::size_t i = 0; i < scan.size(); ++i)
      s.endpoints.push_back(mortonEncode(tree.coordToKey(scan[i])));
    sortUnique48(s.endpoints, s.tmp);
    discrete.reserve(s.endpoints.size());
    for (std::uint64_t m : s.endpoints) discrete.push_back(tree.keyToCoord(mortonDecode(m)));
    beams = &discrete;
  }
  constexpr int kRecentBits = 16;
  s.recent.assign(std::size_t{1} << kRecentBits, ~std::uint64_t{0});  // never a 48-bit code
  const auto pushFree = [&s](std::uint64_t m) {
    std::uint64_t& slot = s.recent[(m * 0x9E3779B97F4A7C15ULL) >> (64 - kRecentBits)];
    if (slot == m) return;
    slot = m;
    s.free_cells.push_back(m);
  };
  s.beams = beams->size();
  octomap::KeyRay ray;
  for (std::size_t i = 0; i < beams->size(); ++i) {
    const octomap::point3d& p = (*beams)[i];
    const bool within = maxrange < 0.0 || (p - origin).norm() <= maxrange;
    const octomap::point3d end =
        within ? p : origin + (p - origin).normalized() * static_cast<float>(maxrange);
    if (tree.computeRayKeys(origin, end, ray))
      for (const octomap::OcTreeKey& k : ray) pushFree(mortonEncode(k));
    if (within) {
      octomap::OcTreeKey key;
      if (tree.coordToKeyChecked(p, key)) s.occupied_cells.push_back(mortonEncode(key));
    }
  }
  sortUnique48(s.free_cells, s.tmp);
  sortUnique48(s.occupied_cells, s.tmp);
  // Occupied wins over free (the sets become disjoint), as in computeUpdate.
  std::size_t w = 0, j = 0;
  for (std::size_t i = 0; i < s.free_cells.size(); ++i) {
    const std::uint64_t m = s.free_cells[i];
    while (j < s.occupied_cells.size() && s.occupied_cells[j] < m) ++j;
    if (j < s.occupied_cells.size() && s.occupied_cells[j] == m) continue;
    s.free_cells[w++] = m;
  }
  s.free_cells.resize(w);
}

/// Applies one update (`occupied` → prob_hit, else prob_miss) to every cell of the sorted, unique
/// Morton codes [b, e) below `node` (at `depth`), in one depth-first pass instead of one descent
/// from the root per cell. Mirrors OccupancyOcTreeBase::updateNode / updateNodeRecurs with lazy
/// evaluation: a pruned leaf whose value is already clamped in the update's direction is left
/// alone (updateNode's early abort), otherwise it is expanded; missing children are created.
template <class Tree, class Node>
void updateSortedRecurs(Tree& tree, Node* node, bool just_created, unsigned depth,
                        const std::uint64_t* b, const std::uint64_t* e, float update) {
  const unsigned max_depth = tree.getTreeDepth();
  if (!just_created && !tree.nodeHasChildren(node)) {
    const float l = node->getLogOdds();
    if ((update >= 0.f && l >= tree.getClampingThresMaxLog()) ||
        (update <= 0.f && l <= tree.getClampingThresMinLog()))
      return;
    if (depth == max_depth) {
      tree.updateNodeLogOdds(node, update);
      return;
    }
    tree.expandNode(node);
  } else if (depth == max_depth) {
    tree.updateNodeLogOdds(node, update);
    return;
  }
  // Codes of one child are contiguous: its 3-bit digit at this level is the same.
  const unsigned shift = 3 * (max_depth - 1 - depth);
  while (b != e) {
    const std::uint64_t digit = (*b >> shift) & 7;
    const std::uint64_t* run = b + 1;
    while (run != e && ((*run >> shift) & 7) == digit) ++run;
    // Morton digit bits are (k0, k1, k2) from high to low; OctoMap's child index has k0 in bit 0.
    const unsigned pos =
        static_cast<unsigned>(((digit >> 2) & 1) | (((digit >> 1) & 1) << 1) | ((digit & 1) << 2));
    bool created = false;
    if (!tree.nodeChildExists(node, pos)) {
      tree.createNodeChild(node, pos);
      created = true;
    }
    updateSortedRecurs(tree, tree.getNodeChild(node, pos), created, depth + 1, b, run, update);
    b = run;
  }
}

/// Updates every cell of the sorted, unique codes as hit (`occupied`) or miss.
template <class Tree>
void applySorted(Tree& tree, const std::vector<std::uint64_t>& codes, bool occupied,
                 bool lazy_eval) {
  if (codes.empty()) return;
  if (!lazy_eval) {
    // Eager mode prunes and refreshes inner nodes along every path: leave that to OctoMap.
    for (std::uint64_t m : codes) tree.updateNode(mortonDecode(m), occupied, false);
    return;
  }
  std::size_t first = 0;
  if (!tree.getRoot()) {  // only OctoMap can create the root: let it insert the first cell
    tree.updateNode(mortonDecode(codes[0]), occupied, true);
    first = 1;
  }
  if (first == codes.size()) return;
  const float update = occupied ? tree.getProbHitLog() : tree.getProbMissLog();
  updateSortedRecurs(tree, tree.getRoot(), false, 0, codes.data() + first,
                     codes.data() + codes.size(), update);
}

/// insertPointCloud(scan, origin, maxrange, lazy_eval, discretize) with the cells updated in
/// Morton order: free cells first, then occupied ones, as OctoMap does.
template <class Tree>
void insertBatch(Tree& tree, const octomap::Pointcloud& scan, const octomap::point3d& origin,
                 double maxrange, bool lazy_eval, bool discretize, BatchScratch& s) {
  computeBatchUpdate(tree, scan, origin, maxrange, discretize, s);
  applySorted(tree, s.free_cells, false, lazy_eval);
  applySorted(tree, s.occupied_cells, true, lazy_eval);
}

}  // namespace obm::mapping::detail
