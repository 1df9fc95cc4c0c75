// Initial guesses: spanning tree (composition of measurements) and chordal relaxation.
#include "obm/backend/initialization.hpp"

#include <Eigen/SVD>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <deque>
#include <numeric>
#include <unordered_map>

#include "obm/backend/metrics.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"

namespace obm::backend {
namespace {

constexpr const char* kLog = "backend.init";

/// Edges as (from, to) index pairs over the sorted node ids, with the loop flag.
struct Topology {
  std::vector<NodeId> ids;
  std::unordered_map<NodeId, int> index;
  std::vector<std::pair<int, int>> edges;
  std::vector<bool> loop;
  std::vector<int> component;  ///< per node
  std::vector<int> root;       ///< per component: node index of the gauge root
};

int findRoot(std::vector<int>& parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

Topology topology(const PoseGraph& g) {
  Topology t;
  t.ids = g.nodeIds();
  t.index.reserve(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i) t.index[t.ids[i]] = int(i);
  const std::size_t m = g.numEdges();
  t.edges.reserve(m);
  for (std::size_t k = 0; k < m; ++k) {
    const NodeId from = g.is3D() ? g.edges3[k].from : g.edges2[k].from;
    const NodeId to = g.is3D() ? g.edges3[k].to : g.edges2[k].to;
    const bool loop = g.is3D() ? g.edges3[k].is_loop : g.edges2[k].is_loop;
    const auto a = t.index.find(from), b = t.index.find(to);
    OBM_ASSERT(
        a != t.index.end() && b != t.index.end(),
        "edge " + std::to_string(from) + " -> " + std::to_string(to) + " names a missing node");
    t.edges.emplace_back(a->second, b->second);
    t.loop.push_back(loop);
  }
  std::vector<int> parent(t.ids.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (const auto& [a, b] : t.edges) parent[findRoot(parent, a)] = findRoot(parent, b);
  // Component numbering in id order; the root is the first fixed node, else the lowest id.
  std::unordered_map<int, int> comp_of_rep;
  t.component.resize(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i) {
    const int rep = findRoot(parent, int(i));
    auto it = comp_of_rep.find(rep);
    if (it == comp_of_rep.end()) {
      it = comp_of_rep.emplace(rep, int(t.root.size())).first;
      t.root.push_back(int(i));
    }
    t.component[i] = it->second;
  }
  std::vector<bool> has_fixed(t.root.size(), false);
  for (NodeId f : g.fixed) {
    const auto it = t.index.find(f);
    if (it == t.index.end()) continue;
    const int c = t.component[it->second];
    if (!has_fixed[c]) {
      t.root[c] = it->second;
      has_fixed[c] = true;
    }
  }
  return t;
}

Pose3 compose(const Pose3& a, const Pose3& b) {
  const Eigen::Quaterniond qa = a.q.normalized();
  return Pose3(a.t + qa * b.t, (qa * b.q.normalized()).normalized());
}
Pose3 inverse(const Pose3& a) {
  const Eigen::Quaterniond qi = a.q.normalized().conjugate();
  return Pose3(-(qi * a.t), qi);
}

/// Assembles and solves a block-sparse symmetric system H·X = B (B with K columns) over the free
/// nodes; block size D.
template <int D, int K>
class BlockSystem {
 public:
  using Block = Eigen::Matrix<double, D, D>;
  using Rhs = Eigen::Matrix<double, D, K>;
  explicit BlockSystem(int n_free)
      : n_(n_free),
        dense_(D * n_free <= kMaxDense),
        rhs_(Eigen::MatrixXd::Zero(D * n_free, K)) {
    if (dense_) H_ = Eigen::MatrixXd::Zero(D * n_free, D * n_free);
  }
  void addH(int i, int j, const Block& b) {
    if (dense_) {
      H_.template block<D, D>(D * i, D * j) += b;
      return;
    }
    for (int r = 0; r < D; ++r)
      for (int c = 0; c < D; ++c)
        if (b(r, c) != 0.0) trip_.emplace_back(D * i + r, D * j + c, b(r, c));
  }
  void addB(int i, const Rhs& b) { rhs_.template block<D, K>(D * i, 0) += b; }
  /// Returns false when the system is singular.
  bool solve(Eigen::MatrixXd& x) const {
    if (dense_) {
      // Tiny graphs: a dense factorisation beats the sparse one's ordering and symbolic steps.
      // The anchored, weighted graph Laplacian is positive definite exactly when the graph is
      // connected to a gauge root; Cholesky fails otherwise (the caller falls back).
      const Eigen::LLT<Eigen::MatrixXd> llt(H_);
      if (llt.info() != Eigen::Success) return false;
      x = llt.solve(rhs_);
      return x.allFinite();
    }
    Eigen::SparseMatrix<double> H(D * n_, D * n_);
    H.setFromTriplets(trip_.begin(), trip_.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(H);
    if (ldlt.info() != Eigen::Success) return false;
    x = ldlt.solve(rhs_);
    return ldlt.info() == Eigen::Success && x.allFinite();
  }

 private:
  static constexpr int kMaxDense = 64;  ///< unknowns up to which H is assembled densely
  int n_;
  bool dense_;
  Eigen::MatrixXd H_;                       ///< dense H (small systems)
  std::vector<Eigen::Triplet<double>> trip_;  ///< sparse H (larger systems)
  Eigen::MatrixXd rhs_;
};

/// Maps node index → free-variable index (−1 for the gauge roots).
std::vector<int> freeIndex(const Topology& t, int& n_free) {
  std::vector<int> f(t.ids.size(), 0);
  for (int r : t.root) f[r] = -1;
  n_free = 0;
  for (auto& v : f)
    if (v == 0) v = n_free++;
  return f;
}

double robustFloor(std::vector<double> w) {
  if (w.empty()) return 0.0;
  std::nth_element(w.begin(), w.begin() + long(w.size() / 2), w.end());
  return 1e-6 * std::max(w[w.size() / 2], 1e-300);
}

bool chordal3(PoseGraph& g, const Topology& t, const std::vector<double>& scale) {
  int n_free = 0;
  const auto fidx = freeIndex(t, n_free);
  const std::size_t m = t.edges.size();
  std::vector<Eigen::Matrix3d> Rz(m);
  std::vector<double> w(m);
  for (std::size_t k = 0; k < m; ++k) {
    Rz[k] = g.edges3[k].T_from_to.q.normalized().toRotationMatrix();
    w[k] = g.edges3[k].information.bottomRightCorner<3, 3>().trace() / 3.0;
  }
  const double floor = robustFloor(w);
  for (std::size_t k = 0; k < m; ++k) w[k] = std::max(w[k], floor) * scale[k];
  std::vector<Eigen::Matrix3d> R(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i)
    R[i] = g.nodes3.at(t.ids[i]).T_world_node.q.normalized().toRotationMatrix();

  // Rotations. Each row k of R_j = row k of R_i · R_ij, i.e. x_j = R_ijᵀ·x_i for x = (row k)ᵀ:
  // the three rows share one system with three right-hand sides (the columns of Rᵀ).
  {
    BlockSystem<3, 3> sys(n_free);
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    for (std::size_t k = 0; k < m; ++k) {
      const auto [i, j] = t.edges[k];
      const Eigen::Matrix3d A = Rz[k].transpose();
      const int fi = fidx[i], fj = fidx[j];
      if (fi >= 0) sys.addH(fi, fi, w[k] * I);
      if (fj >= 0) sys.addH(fj, fj, w[k] * I);
      if (fi >= 0 && fj >= 0) {
        sys.addH(fi, fj, -w[k] * A.transpose());
        sys.addH(fj, fi, -w[k] * A);
      } else if (fi < 0 && fj >= 0) {
        sys.addB(fj, w[k] * A * R[i].transpose());
      } else if (fi >= 0 && fj < 0) {
        sys.addB(fi, w[k] * A.transpose() * R[j].transpose());
      }
    }
    Eigen::MatrixXd x;
    if (n_free > 0 && !sys.solve(x)) return false;
    for (std::size_t i = 0; i < t.ids.size(); ++i) {
      if (fidx[i] < 0) continue;
      const Eigen::Matrix3d M = x.block<3, 3>(3 * fidx[i], 0).transpose();
      R[i] = orthonormalize(M);
    }
  }
  // Translations: t_j − t_i = R_i·t_ij, weighted by the translational information in the world
  // frame, W = (R_i·R_ij)·Ω_tt·(R_i·R_ij)ᵀ (g2o's translation error is expressed in frame i·ij).
  std::vector<Eigen::Vector3d> tr(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i) tr[i] = g.nodes3.at(t.ids[i]).T_world_node.t;
  {
    BlockSystem<3, 1> sys(n_free);
    for (std::size_t k = 0; k < m; ++k) {
      const auto [i, j] = t.edges[k];
      const Eigen::Matrix3d Rw = R[i] * Rz[k];
      Eigen::Matrix3d W =
          scale[k] * Rw * g.edges3[k].information.topLeftCorner<3, 3>() * Rw.transpose();
      W = 0.5 * (W + W.transpose()).eval();
      const Eigen::Vector3d c = R[i] * g.edges3[k].T_from_to.t;
      const int fi = fidx[i], fj = fidx[j];
      if (fi >= 0) sys.addH(fi, fi, W);
      if (fj >= 0) sys.addH(fj, fj, W);
      if (fi >= 0 && fj >= 0) {
        sys.addH(fi, fj, -W);
        sys.addH(fj, fi, -W);
        sys.addB(fj, W * c);
        sys.addB(fi, -W * c);
      } else if (fi < 0 && fj >= 0) {
        sys.addB(fj, W * (c + tr[i]));
      } else if (fi >= 0 && fj < 0) {
        sys.addB(fi, W * (tr[j] - c));
      }
    }
    Eigen::MatrixXd x;
    if (n_free > 0 && !sys.solve(x)) return false;
    for (std::size_t i = 0; i < t.ids.size(); ++i)
      if (fidx[i] >= 0) tr[i] = x.block<3, 1>(3 * fidx[i], 0);
  }
  for (std::size_t i = 0; i < t.ids.size(); ++i) {
    if (fidx[i] < 0) continue;
    auto& p = g.nodes3.at(t.ids[i]).T_world_node;
    p = Pose3(tr[i], Eigen::Quaterniond(R[i]).normalized());
  }
  return true;
}

Eigen::Matrix2d rot2(double th) {
  const double c = std::cos(th), s = std::sin(th);
  return (Eigen::Matrix2d() << c, -s, s, c).finished();
}

bool chordal2(PoseGraph& g, const Topology& t, const std::vector<double>& scale) {
  int n_free = 0;
  const auto fidx = freeIndex(t, n_free);
  const std::size_t m = t.edges.size();
  std::vector<double> w(m);
  for (std::size_t k = 0; k < m; ++k) w[k] = g.edges2[k].information(2, 2);
  const double floor = robustFloor(w);
  for (std::size_t k = 0; k < m; ++k) w[k] = std::max(w[k], floor) * scale[k];
  std::vector<double> th(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i) th[i] = g.nodes2.at(t.ids[i]).T_world_node.theta;
  // Rotations as unit complex numbers z = (cos θ, sin θ): z_j = R(θ_ij)·z_i.
  {
    BlockSystem<2, 1> sys(n_free);
    const Eigen::Matrix2d I = Eigen::Matrix2d::Identity();
    for (std::size_t k = 0; k < m; ++k) {
      const auto [i, j] = t.edges[k];
      const Eigen::Matrix2d A = rot2(g.edges2[k].T_from_to.theta);
      const int fi = fidx[i], fj = fidx[j];
      if (fi >= 0) sys.addH(fi, fi, w[k] * I);
      if (fj >= 0) sys.addH(fj, fj, w[k] * I);
      const Eigen::Vector2d zi(std::cos(th[i]), std::sin(th[i])),
          zj(std::cos(th[j]), std::sin(th[j]));
      if (fi >= 0 && fj >= 0) {
        sys.addH(fi, fj, -w[k] * A.transpose());
        sys.addH(fj, fi, -w[k] * A);
      } else if (fi < 0 && fj >= 0) {
        sys.addB(fj, w[k] * A * zi);
      } else if (fi >= 0 && fj < 0) {
        sys.addB(fi, w[k] * A.transpose() * zj);
      }
    }
    Eigen::MatrixXd x;
    if (n_free > 0 && !sys.solve(x)) return false;
    for (std::size_t i = 0; i < t.ids.size(); ++i)
      if (fidx[i] >= 0) th[i] = std::atan2(x(2 * fidx[i] + 1, 0), x(2 * fidx[i], 0));
  }
  std::vector<Eigen::Vector2d> tr(t.ids.size());
  for (std::size_t i = 0; i < t.ids.size(); ++i) {
    const auto& p = g.nodes2.at(t.ids[i]).T_world_node;
    tr[i] = Eigen::Vector2d(p.x, p.y);
  }
  {
    BlockSystem<2, 1> sys(n_free);
    for (std::size_t k = 0; k < m; ++k) {
      const auto [i, j] = t.edges[k];
      const auto& Z = g.edges2[k].T_from_to;
      const Eigen::Matrix2d Ri = rot2(th[i]), Rw = Ri * rot2(Z.theta);
      Eigen::Matrix2d W =
          scale[k] * Rw * g.edges2[k].information.topLeftCorner<2, 2>() * Rw.transpose();
      W = 0.5 * (W + W.transpose()).eval();
      const Eigen::Vector2d c = Ri * Eigen::Vector2d(Z.x, Z.y);
      const int fi = fidx[i], fj = fidx[j];
      if (fi >= 0) sys.addH(fi, fi, W);
      if (fj >= 0) sys.addH(fj, fj, W);
      if (fi >= 0 && fj >= 0) {
        sys.addH(fi, fj, -W);
        sys.addH(fj, fi, -W);
        sys.addB(fj, W * c);
        sys.addB(fi, -W * c);
      } else if (fi < 0 && fj >= 0) {
        sys.addB(fj, W * (c + tr[i]));
      } else if (fi >= 0 && fj < 0) {
        sys.addB(fi, W * (tr[j] - c));
      }
    }
    Eigen::MatrixXd x;
    if (n_free > 0 && !sys.solve(x)) return false;
    for (std::size_t i = 0; i < t.ids.size(); ++i)
      if (fidx[i] >= 0) tr[i] = x.block<2, 1>(2 * fidx[i], 0);
  }
  for (std::size_t i = 0; i < t.ids.size(); ++i) {
    if (fidx[i] < 0) continue;
    auto& p = g.nodes2.at(t.ids[i]).T_world_node;
    p.x = tr[i].x();
    p.y = tr[i].y();
    p.theta = th[i];
  }
  return true;
}

}  // namespace

InitMethod parseInitMethod(const std::string& s) {
  if (s == "file") return InitMethod::File;
  if (s == "spanning") return InitMethod::Spanning;
  if (s == "chordal") return InitMethod::Chordal;
  throw ConfigError("unknown initialisation '" + s + "' (expected file, spanning or chordal)");
}

std::string toString(InitMethod m) {
  switch (m) {
    case InitMethod::File:
      return "file";
    case InitMethod::Spanning:
      return "spanning";
    case InitMethod::Chordal:
      return "chordal";
  }
  return "?";
}

void initializeSpanningTree(PoseGraph& g, bool skip_loops) {
  const Topology t = topology(g);
  const int n = int(t.ids.size());
  // adjacency: (edge index, neighbour, edge goes from this node)
  struct Adj {
    int edge, other;
    bool forward;
  };
  std::vector<std::vector<Adj>> adj(n);
  for (int k = 0; k < int(t.edges.size()); ++k) {
    const auto [a, b] = t.edges[k];
    adj[a].push_back({k, b, true});
    adj[b].push_back({k, a, false});
  }
  for (auto& v : adj)  // odometry edges first
    std::stable_sort(v.begin(), v.end(),
                     [&](const Adj& x, const Adj& y) { return !t.loop[x.edge] && t.loop[y.edge]; });
  // 0-1 BFS, a node's parent fixed when the node is first taken from the queue. With
  // `skip_loops` odometry edges cost 0 and go to the front: each odometry-connected part of the
  // trajectory is flooded along its own odometry from the first node reached, before any other
  // loop edge into it is considered, so the tree crosses as few loop edges as possible and never
  // uses a loop edge inside a part (where the chain is broken, one loop edge bridges the gap).
  // Without `skip_loops`: plain breadth-first (fewest hops).
  struct Item {
    int node, parent, edge;
  };
  std::vector<int> parent_edge(n, -1), parent(n, -1);
  std::vector<char> done(n, 0);
  for (int root : t.root) {
    std::deque<Item> dq{{root, -1, -1}};
    while (!dq.empty()) {
      const Item it = dq.front();
      dq.pop_front();
      if (done[it.node]) continue;
      done[it.node] = 1;
      parent[it.node] = it.parent;
      parent_edge[it.node] = it.edge;
      for (const Adj& a : adj[it.node]) {
        if (done[a.other]) continue;
        if (skip_loops && !t.loop[a.edge])
          dq.push_front({a.other, it.node, a.edge});
        else
          dq.push_back({a.other, it.node, a.edge});
      }
    }
  }
  // Compose along the tree in an order where parents come first (depth-first from each root).
  std::vector<std::vector<int>> children(n);
  for (int v = 0; v < n; ++v)
    if (parent[v] >= 0) children[parent[v]].push_back(v);
  for (int root : t.root) {
    std::vector<int> stack{root};
    while (!stack.empty()) {
      const int u = stack.back();
      stack.pop_back();
      for (int c : children[u]) {
        const int k = parent_edge[c];
        const bool forward = t.edges[k].first == u;
        if (g.is3D()) {
          const Pose3& Xu = g.nodes3.at(t.ids[u]).T_world_node;
          const Pose3& Z = g.edges3[k].T_from_to;
          g.nodes3.at(t.ids[c]).T_world_node = forward ? compose(Xu, Z) : compose(Xu, inverse(Z));
        } else {
          const Pose2& Xu = g.nodes2.at(t.ids[u]).T_world_node;
          const Pose2& Z = g.edges2[k].T_from_to;
          Pose2 Xc = forward ? Xu * Z : Xu * Z.inverse();
          g.nodes2.at(t.ids[c]).T_world_node = Pose2(Xc.x, Xc.y, Xc.theta);
        }
        stack.push_back(c);
      }
    }
  }
}

void initializeChordal(PoseGraph& g) {
  if (g.numNodes() == 0) return;
  const Topology t = topology(g);
  const std::vector<double> ones(t.edges.size(), 1.0);
  const bool ok = g.is3D() ? chordal3(g, t, ones) : chordal2(g, t, ones);
  if (!ok) {
    OBM_LOG_WARN(kLog, "chordal relaxation: singular system; falling back to the spanning tree");
    initializeSpanningTree(g, false);
  }
}

void initializeRobustChordal(PoseGraph& g, double phi, int iterations) {
  if (g.numNodes() == 0) return;
  const Topology t = topology(g);
  const PoseGraph start = g;
  std::vector<double> scale(t.edges.size(), 1.0);
  // Graduated: the DCS scale starts at mu·Φ and shrinks to Φ, so that the first (contaminated)
  // estimates only discard gross outliers.
  double mu = std::pow(4.0, iterations - 1);
  for (int it = 0; it < iterations; ++it, mu = std::max(1.0, mu / 4.0)) {
    PoseGraph trial = start;
    const bool ok = g.is3D() ? chordal3(trial, t, scale) : chordal2(trial, t, scale);
    if (!ok) break;
    g = std::move(trial);
    if (it + 1 == iterations) break;
    const double p = mu * phi;
    for (std::size_t k = 0; k < t.edges.size(); ++k) {
      if (!t.loop[k]) continue;
      const double c = g.is3D() ? edgeChi2(g, g.edges3[k]) : edgeChi2(g, g.edges2[k]);
      const double s = std::min(1.0, 2.0 * p / (p + c));
      scale[k] = s * s;
    }
  }
}

void initialize(PoseGraph& g, InitMethod m) {
  switch (m) {
    case InitMethod::File:
      return;
    case InitMethod::Spanning:
      initializeSpanningTree(g, true);
      return;
    case InitMethod::Chordal:
      initializeChordal(g);
      return;
  }
}

}  // namespace obm::backend
