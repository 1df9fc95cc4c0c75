#pragma once
/// \file synthetic.hpp
/// Synthetic pose graphs with known ground truth (for tests and the robustness benchmark), and the
/// injection of wrong loop closures.
#include <cstdint>

#include "obm/backend/pose_graph.hpp"

namespace obm::backend {

/// Parameters of a synthetic graph.
struct SyntheticSpec {
  int dimension = 3;  ///< 3: rings on a sphere (like sphere2500); 2: grid walk (like manhattan)
  int rings = 10;     ///< 3D: rings of the sphere
  int nodes_per_ring = 20;          ///< 3D: nodes per ring
  double radius = 10.0;             ///< 3D: sphere radius [m]
  int steps = 400;                  ///< 2D: steps of the grid walk
  double grid_step = 1.0;           ///< 2D: step length [m]
  double loop_radius = 0.6;         ///< 2D: loop closures between grid points closer than this [m]
  double sigma_translation = 0.05;  ///< measurement noise std [m]
  double sigma_rotation = 0.01;     ///< measurement noise std [rad]
  std::uint64_t seed = 1;
};

/// A noisy graph and its ground truth (same ids). Measurements are ground-truth relative poses
/// perturbed by the noise of `spec`; Ω is the matching diagonal information in g2o's error units
/// (rotation part 4/σ², since vec(q) ≈ θ/2). The graph's node poses are the odometry chain.
struct SyntheticGraph {
  PoseGraph graph;
  PoseGraph ground_truth;
};
SyntheticGraph makeSyntheticGraph(const SyntheticSpec& spec);

/// Replaces `fraction` of the loop edges (is_loop) by wrong ones: random node pairs that are not
/// consecutive, with a random measurement (translation up to `max_translation` per axis, random
/// rotation), keeping the replaced edge's information. Returns how many were replaced.
std::size_t injectWrongLoops(PoseGraph& graph, double fraction, std::uint64_t seed,
                             double max_translation = 5.0);

}  // namespace obm::backend
