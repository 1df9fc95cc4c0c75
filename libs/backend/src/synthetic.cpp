#include "obm/backend/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "obm/backend/initialization.hpp"
#include "obm/core/errors.hpp"

namespace obm::backend {
namespace {

Pose3 relative3(const Pose3& a, const Pose3& b) {
  const Eigen::Quaterniond qa = a.q.normalized();
  return Pose3(qa.conjugate() * (b.t - a.t), (qa.conjugate() * b.q.normalized()).normalized());
}

Pose3 perturb3(const Pose3& p, std::mt19937_64& rng, double st, double sr) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d dt(st * n(rng), st * n(rng), st * n(rng));
  const Eigen::Vector3d dr(sr * n(rng), sr * n(rng), sr * n(rng));
  const Eigen::Quaterniond dq(expSO3(dr));
  return Pose3(p.t + dt, (p.q.normalized() * dq).normalized());
}

}  // namespace

SyntheticGraph makeSyntheticGraph(const SyntheticSpec& spec) {
  OBM_ASSERT(spec.dimension == 2 || spec.dimension == 3, "dimension must be 2 or 3");
  std::mt19937_64 rng(spec.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  SyntheticGraph out;
  out.graph.dimension = out.ground_truth.dimension = spec.dimension;
  const double st = spec.sigma_translation, sr = spec.sigma_rotation;
  if (spec.dimension == 3) {
    OBM_ASSERT(spec.rings >= 2 && spec.nodes_per_ring >= 3, "need ≥ 2 rings of ≥ 3 nodes");
    Matrix6d info = Matrix6d::Zero();
    info.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() / (st * st);
    info.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * 4.0 / (sr * sr);
    // Ground truth: ring k at polar angle φ_k, node j at azimuth ψ_j; the frame's x axis follows
    // the walking direction, z points outwards.
    const int R = spec.rings, M = spec.nodes_per_ring;
    NodeId id = 0;
    for (int k = 0; k < R; ++k) {
      const double phi = M_PI * (k + 1) / (R + 1);
      for (int j = 0; j < M; ++j, ++id) {
        const double psi = 2.0 * M_PI * j / M;
        const Eigen::Vector3d up(std::sin(phi) * std::cos(psi), std::sin(phi) * std::sin(psi),
                                 std::cos(phi));
        const Eigen::Vector3d fwd(-std::sin(psi), std::cos(psi), 0.0);
        Eigen::Matrix3d Rm;
        Rm.col(0) = fwd;
        Rm.col(2) = up;
        Rm.col(1) = up.cross(fwd);
        out.ground_truth.nodes3[id] =
            Node3{id, Pose3(spec.radius * up, Eigen::Quaterniond(Rm).normalized())};
      }
    }
    auto addEdge = [&](NodeId a, NodeId b) {
      Edge3 e;
      e.from = a;
      e.to = b;
      e.T_from_to = perturb3(relative3(out.ground_truth.nodes3.at(a).T_world_node,
                                       out.ground_truth.nodes3.at(b).T_world_node),
                             rng, st, sr);
      e.information = info;
      e.is_loop = isLoopByIds(a, b);
      out.graph.edges3.push_back(e);
    };
    const NodeId N = NodeId(R) * M;
    for (NodeId i = 0; i + 1 < N; ++i) addEdge(i, i + 1);
    for (int k = 1; k < R; ++k)
      for (int j = 0; j < M; ++j) addEdge(NodeId(k - 1) * M + j, NodeId(k) * M + j);
    out.graph.nodes3 = out.ground_truth.nodes3;
  } else {
    Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
    info(0, 0) = info(1, 1) = 1.0 / (st * st);
    info(2, 2) = 1.0 / (sr * sr);
    // Ground truth: a random walk on a grid (turning by multiples of 90°), Manhattan-world style.
    std::uniform_int_distribution<int> turn(0, 9);
    double x = 0, y = 0, th = 0;
    for (int i = 0; i <= spec.steps; ++i) {
      out.ground_truth.nodes2[i] = Node2{i, Pose2(x, y, th)};
      const int t = turn(rng);
      if (t == 0) th += M_PI / 2;
      if (t == 1) th -= M_PI / 2;
      th = wrapAngle(th);
      x += spec.grid_step * std::round(std::cos(th));
      y += spec.grid_step * std::round(std::sin(th));
    }
    auto addEdge = [&](NodeId a, NodeId b) {
      const Pose2& A = out.ground_truth.nodes2.at(a).T_world_node;
      const Pose2& B = out.ground_truth.nodes2.at(b).T_world_node;
      const Pose2 rel = A.inverse() * B;
      Edge2 e;
      e.from = a;
      e.to = b;
      e.T_from_to = Pose2(rel.x + st * n01(rng), rel.y + st * n01(rng), rel.theta + sr * n01(rng));
      e.information = info;
      e.is_loop = isLoopByIds(a, b);
      out.graph.edges2.push_back(e);
    };
    for (NodeId i = 0; i < spec.steps; ++i) addEdge(i, i + 1);
    for (NodeId i = 0; i <= spec.steps; ++i)
      for (NodeId j = 0; j + 2 < i; ++j) {
        const Pose2& A = out.ground_truth.nodes2.at(j).T_world_node;
        const Pose2& B = out.ground_truth.nodes2.at(i).T_world_node;
        if (std::hypot(A.x - B.x, A.y - B.y) < spec.loop_radius) addEdge(j, i);
      }
    out.graph.nodes2 = out.ground_truth.nodes2;
  }
  initializeSpanningTree(out.graph, /*skip_loops=*/true);  // the noisy odometry chain
  return out;
}

std::size_t injectWrongLoops(PoseGraph& g, double fraction, std::uint64_t seed, double max_t) {
  std::mt19937_64 rng(seed);
  std::vector<std::size_t> loops;
  for (std::size_t k = 0; k < g.numEdges(); ++k)
    if (g.is3D() ? g.edges3[k].is_loop : g.edges2[k].is_loop) loops.push_back(k);
  std::shuffle(loops.begin(), loops.end(), rng);
  const std::size_t n = std::size_t(std::llround(fraction * double(loops.size())));
  const auto ids = g.nodeIds();
  OBM_ASSERT(ids.size() >= 3, "need at least 3 nodes");
  std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
  std::uniform_real_distribution<double> ut(-max_t, max_t), ua(-M_PI, M_PI);
  for (std::size_t r = 0; r < n && r < loops.size(); ++r) {
    NodeId a, b;
    do {
      a = ids[pick(rng)];
      b = ids[pick(rng)];
    } while (!isLoopByIds(a, b) || a == b);
    if (g.is3D()) {
      Edge3& e = g.edges3[loops[r]];
      e.from = a;
      e.to = b;
      Eigen::Quaterniond q(Eigen::Vector4d(ua(rng), ua(rng), ua(rng), ua(rng)).normalized());
      e.T_from_to = Pose3(Eigen::Vector3d(ut(rng), ut(rng), ut(rng)), q);
    } else {
      Edge2& e = g.edges2[loops[r]];
      e.from = a;
      e.to = b;
      e.T_from_to = Pose2(ut(rng), ut(rng), ua(rng));
    }
  }
  return std::min(n, loops.size());
}

}  // namespace obm::backend
