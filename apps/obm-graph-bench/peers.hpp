#pragma once
// Peers of the pose-graph benchmark. Each returns the solution's poses in a copy of the graph so
// that every optimizer is scored with the same g2o χ² (obm::backend::chi2).
#include <string>

#include "obm/backend/pose_graph.hpp"

namespace obm::bench {

struct PeerResult {
  backend::PoseGraph solution;  ///< the input graph with the peer's poses
  double time_s = 0.0;          ///< solve time [s] (no file I/O)
  double wall_s = 0.0;          ///< whole run incl. process start and file I/O (subprocess peers)
  int iterations = 0;
  bool ok = false;
  std::string note;
};

/// The Ceres `pose_graph_3d` / `pose_graph_2d` examples' formulation, re-implemented from their
/// description: residual weighted by L (Ω = L·Lᵀ, lower Cholesky factor), rotation error
/// 2·vec(q_ab_meas ⊗ q_ab_est⁻¹) (3D) / normalised angle (2D), translation error R_aᵀ(t_b − t_a) −
/// t_ab in frame a; start from the file's poses, first (lowest id) pose held constant, Levenberg–
/// Marquardt with SPARSE_NORMAL_CHOLESKY, 200 (3D) / 100 (2D) iterations, other options default.
PeerResult solveCeresExample(const backend::PoseGraph& graph);

/// MRPT's `graph-slam --levmarq` run as a subprocess on the graph written as TORO/MRPT `.graph`.
/// time_s is graph-slam's own timing of its Dijkstra initial guess + optimize_graph_spa_levmarq.
PeerResult solveMrpt(const backend::PoseGraph& graph, const std::string& work_dir,
                     const std::string& executable = "graph-slam");

}  // namespace obm::bench
