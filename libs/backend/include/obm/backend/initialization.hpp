#pragma once
/// \file initialization.hpp
/// Initial guesses of the node poses: as read from the file, by composing edges along a spanning
/// tree (odometry first), or by chordal relaxation (rotation averaging, then translations by linear
/// least squares), which brings hard graphs into the basin of the global optimum.
#include <string>

#include "obm/backend/pose_graph.hpp"

namespace obm::backend {

enum class InitMethod {
  File,      ///< keep the poses as they are (the file's vertices)
  Spanning,  ///< compose measurements along a breadth-first spanning tree, odometry edges first
  Chordal,   ///< chordal relaxation (Carlone et al. ICRA 2015, Martinec & Pajdla CVPR 2007)
};

/// "file" | "spanning" | "chordal"; throws ConfigError otherwise.
InitMethod parseInitMethod(const std::string& s);
std::string toString(InitMethod m);

/// Sets every node to the composition of measurements along a breadth-first spanning tree rooted at
/// the fixed node (or lowest id) of each connected component. Odometry edges (consecutive ids) are
/// expanded before loop edges so the tree follows the trajectory. When `skip_loops` is true, loop
/// edges are used only to reach nodes that odometry cannot reach.
void initializeSpanningTree(PoseGraph& graph, bool skip_loops = false);

/// Chordal relaxation. Rotations: min Σ w_ij ‖R_j − R_i·R_ij‖²_F over unconstrained 3×3 (2×2 in 2D)
/// matrices with the component's root fixed, projected onto SO(3)/SO(2); w_ij from the rotational
/// block of Ω. Translations: min Σ ‖t_j − t_i − R_i·t_ij‖²_W with W the translational information
/// rotated into the world frame. Both are sparse linear least-squares problems (Cholesky). The
/// root of each connected component keeps its pose (gauge).
void initializeChordal(PoseGraph& graph);

/// Outlier-resistant chordal relaxation: iteratively re-weighted chordal relaxations where each
/// loop edge's weight is the DCS weight min(1, 2Φ'/(Φ' + χ²))² of its g2o χ² at the previous
/// estimate, with Φ' shrinking from 4^(iterations−1)·Φ to Φ (graduated, so early contaminated
/// estimates only discard gross outliers). Odometry edges keep full weight.
void initializeRobustChordal(PoseGraph& graph, double phi, int iterations = 6);

/// Dispatches on `method`.
void initialize(PoseGraph& graph, InitMethod method);

}  // namespace obm::backend
