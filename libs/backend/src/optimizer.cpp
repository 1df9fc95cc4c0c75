// Ceres pose-graph optimizer minimising g2o's χ² (see cost_functions.hpp for the residuals).
#include "obm/backend/optimizer.hpp"

#include <ceres/ceres.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "cost_functions.hpp"
#include "information.hpp"
#include "obm/backend/blas_threads.hpp"
#include "obm/backend/metrics.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/timer.hpp"
#include "robust_solve.hpp"

namespace obm::backend {
namespace {

constexpr const char* kLog = "backend.optimizer";
/// Graphs up to this many nodes use DENSE_SCHUR instead of SPARSE_NORMAL_CHOLESKY (optimize()).
constexpr std::size_t kDenseSchurMaxNodes = 16;

class CallbackAdapter final : public ceres::IterationCallback {
 public:
  CallbackAdapter(std::vector<IterationInfo>& out,
                  const std::function<void(const IterationInfo&)>& cb)
      : out_(out), cb_(cb) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    IterationInfo it;
    it.iteration = s.iteration;
    it.cost = 2.0 * s.cost;  // Ceres' cost is ½Σρ(‖r‖²)
    it.cost_change = 2.0 * s.cost_change;
    it.gradient_max_norm = s.gradient_max_norm;
    it.step_norm = s.step_norm;
    it.trust_region_radius = s.trust_region_radius;
    it.step_is_successful = s.step_is_successful;
    it.time_s = s.cumulative_time_in_seconds;
    out_.push_back(it);
    if (cb_) cb_(it);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::vector<IterationInfo>& out_;
  const std::function<void(const IterationInfo&)>& cb_;
};

double parseScale(const std::string& spec, const std::string& text) {
  std::size_t pos = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &pos);
  } catch (const std::exception&) {
    pos = 0;
  }
  if (pos != text.size() || !(v > 0.0) || !std::isfinite(v))
    throw ConfigError("robust loss '" + spec + "': scale must be a positive number");
  return v;
}

}  // namespace

EdgeLoss parseLoss(const std::string& spec) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  EdgeLoss l;
  if (kind == "dcs" && colon != std::string::npos && spec.substr(colon + 1) == "auto") {
    l.kind = LossKind::Dcs;
    l.scale = 0.0;  // Φ calibrated on the graph's own residuals (see Options::loop_loss)
    return l;
  }
  l.scale = colon == std::string::npos ? 1.0 : parseScale(spec, spec.substr(colon + 1));
  if (kind == "none")
    l.kind = LossKind::None;
  else if (kind == "huber")
    l.kind = LossKind::Huber;
  else if (kind == "cauchy")
    l.kind = LossKind::Cauchy;
  else if (kind == "dcs")
    l.kind = LossKind::Dcs;
  else
    throw ConfigError("unknown robust loss '" + spec +
                      "' (expected none, huber[:δ], cauchy[:c], dcs[:Φ] or dcs:auto)");
  return l;
}

std::string toString(const EdgeLoss& l) {
  std::ostringstream os;
  switch (l.kind) {
    case LossKind::Default:
      return "default";
    case LossKind::None:
      return "none";
    case LossKind::Huber:
      os << "huber:" << l.scale;
      break;
    case LossKind::Cauchy:
      os << "cauchy:" << l.scale;
      break;
    case LossKind::Dcs:
      if (l.scale <= 0.0) return "dcs:auto";
      os << "dcs:" << l.scale;
      break;
  }
  return os.str();
}

Options Options::load(const ConfigNode& n) {
  Options o;
  n.checkKeys({"init", "max_iterations", "num_threads", "function_tolerance", "gradient_tolerance",
               "parameter_tolerance", "initial_trust_region_radius", "sparse_library", "loop_loss",
               "odometry_loss", "robust_init", "fixed"});
  if (n.has("init")) {
    try {
      o.init = parseInitMethod(n.required<std::string>("init"));
    } catch (const ConfigError& e) {
      throw ConfigError(n.where("init") + ": " + e.what());
    }
  }
  n.get("max_iterations", o.max_iterations);
  n.get("num_threads", o.num_threads);
  n.get("function_tolerance", o.function_tolerance);
  n.get("gradient_tolerance", o.gradient_tolerance);
  n.get("parameter_tolerance", o.parameter_tolerance);
  n.get("initial_trust_region_radius", o.initial_trust_region_radius);
  if (n.has("sparse_library")) {
    const auto v = n.required<std::string>("sparse_library");
    if (v == "auto")
      o.sparse_library = SparseLibrary::Auto;
    else if (v == "suite_sparse")
      o.sparse_library = SparseLibrary::SuiteSparse;
    else if (v == "cx_sparse")
      o.sparse_library = SparseLibrary::CxSparse;
    else if (v == "eigen_sparse")
      o.sparse_library = SparseLibrary::EigenSparse;
    else
      throw ConfigError(n.where("sparse_library") + ": unknown value '" + v +
                        "' (expected auto, suite_sparse, cx_sparse or eigen_sparse)");
  }
  auto loss = [&](const char* key, EdgeLoss& out) {
    if (!n.has(key)) return;
    try {
      out = parseLoss(n.required<std::string>(key));
    } catch (const ConfigError& e) {
      throw ConfigError(n.where(key) + ": " + e.what());
    }
  };
  loss("loop_loss", o.loop_loss);
  loss("odometry_loss", o.odometry_loss);
  if (n.has("robust_init")) {
    const auto v = n.required<std::string>("robust_init");
    if (v == "odometry")
      o.robust_init = RobustInit::Odometry;
    else if (v == "chordal")
      o.robust_init = RobustInit::Chordal;
    else if (v == "robust_chordal")
      o.robust_init = RobustInit::RobustChordal;
    else if (v == "best")
      o.robust_init = RobustInit::Best;
    else
      throw ConfigError(n.where("robust_init") + ": unknown value '" + v +
                        "' (expected best, odometry, chordal or robust_chordal)");
  }
  n.get("fixed", o.fixed);
  if (o.max_iterations < 0) throw ConfigError(n.where("max_iterations") + ": must be ≥ 0");
  if (o.num_threads < 0) throw ConfigError(n.where("num_threads") + ": must be ≥ 0");
  return o;
}

// ---------------------------------------------------------------------------------------------

struct Optimizer::Impl {
  Options opt;
  PoseGraph graph;
  bool initialized = false;
  std::function<void(const IterationInfo&)> callback;

  // Ceres state, rebuilt by setGraph, extended by addNode/addEdge.
  std::unique_ptr<ceres::Problem> problem;
  /// R³ × unit quaternions (Ceres' EigenQuaternionManifold) for a 3D node's (t, q) block.
  std::unique_ptr<ceres::Manifold> pose_manifold = std::make_unique<detail::PoseManifold>();
  std::map<std::pair<int, double>, std::unique_ptr<ceres::LossFunction>> losses;
  /// `dcs:auto`: the current Φ and the loss object that carries it (null until an edge uses it).
  double auto_phi = 1.0;
  detail::DcsLoss* auto_dcs = nullptr;
  std::deque<std::array<double, 7>> blocks;  // 3D: t(3) q(4: x y z w); 2D: x y θ
  std::unordered_map<NodeId, double*> block_of;
  std::size_t edges_in_problem = 0;
  std::size_t edges_with_loss = 0;  ///< residual blocks with a loss function

  explicit Impl(Options o) : opt(std::move(o)) {}

  void reset() {
    problem.reset();
    blocks.clear();
    block_of.clear();
    edges_in_problem = 0;
    edges_with_loss = 0;
  }

  ceres::Problem& ensureProblem() {
    if (!problem) {
      ceres::Problem::Options po;
      po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
      // Ceres's checks while building (a block added twice, an edge joining a node to itself,
      // sizes) repeat PoseGraph::validate and checkEdgeEnds; they are a measurable part of a tiny
      // graph's solve.
      po.disable_all_safety_checks = true;
      problem = std::make_unique<ceres::Problem>(po);
    }
    return *problem;
  }

  ceres::LossFunction* lossFor(const EdgeLoss& edge_loss, bool is_loop) {
    EdgeLoss l = edge_loss;
    if (l.kind == LossKind::Default) l = is_loop ? opt.loop_loss : opt.odometry_loss;
    if (l.kind == LossKind::None || l.kind == LossKind::Default) return nullptr;
    auto& slot = losses[{int(l.kind), l.scale}];
    if (!slot) {
      switch (l.kind) {
        case LossKind::Huber:
          slot = std::make_unique<ceres::HuberLoss>(l.scale);
          break;
        case LossKind::Cauchy:
          slot = std::make_unique<ceres::CauchyLoss>(l.scale);
          break;
        case LossKind::Dcs:
          slot = std::make_unique<detail::DcsLoss>(l.scale > 0.0 ? l.scale : auto_phi);
          if (l.scale <= 0.0) auto_dcs = static_cast<detail::DcsLoss*>(slot.get());
          break;
        default:
          break;
      }
    }
    return slot.get();
  }

  double* addBlock(NodeId id) {
    auto& b = blocks.emplace_back();
    b.fill(0.0);
    double* p = b.data();
    block_of[id] = p;
    auto& pr = ensureProblem();
    if (graph.is3D()) {
      pr.AddParameterBlock(p, 7, pose_manifold.get());
    } else {
      pr.AddParameterBlock(p, 3);
    }
    return p;
  }

  void addResidual(std::size_t k) {
    auto& pr = ensureProblem();
    if (graph.is3D()) {
      const Edge3& e = graph.edges3[k];
      double* a = block_of.at(e.from);
      double* b = block_of.at(e.to);
      auto* cost = new detail::EdgeSe3Cost(e.T_from_to.t, e.T_from_to.q,
                                           detail::sqrtInformation<6>(e.information));
      ceres::LossFunction* loss = lossFor(e.loss, e.is_loop);
      edges_with_loss += loss ? 1 : 0;
      pr.AddResidualBlock(cost, loss, a, b);
    } else {
      const Edge2& e = graph.edges2[k];
      auto* cost = new detail::EdgeSe2Cost(e.T_from_to.x, e.T_from_to.y, e.T_from_to.theta,
                                           detail::sqrtInformation<3>(e.information));
      ceres::LossFunction* loss = lossFor(e.loss, e.is_loop);
      edges_with_loss += loss ? 1 : 0;
      pr.AddResidualBlock(cost, loss, block_of.at(e.from), block_of.at(e.to));
    }
  }

  /// Adds the parameter/residual blocks for nodes and edges not yet in the problem.
  void syncProblem() {
    for (NodeId id : graph.nodeIds())
      if (!block_of.count(id)) addBlock(id);
    for (; edges_in_problem < graph.numEdges(); ++edges_in_problem) addResidual(edges_in_problem);
  }

  void posesToBlocks() {
    if (graph.is3D()) {
      for (const auto& [id, n] : graph.nodes3) {
        double* p = block_of.at(id);
        Eigen::Map<Eigen::Vector3d> t(p);
        Eigen::Map<Eigen::Quaterniond> q(p + 3);
        t = n.T_world_node.t;
        q = n.T_world_node.q.normalized();
      }
    } else {
      for (const auto& [id, n] : graph.nodes2) {
        double* p = block_of.at(id);
        p[0] = n.T_world_node.x;
        p[1] = n.T_world_node.y;
        p[2] = n.T_world_node.theta;
      }
    }
  }

  void blocksToPoses() {
    if (graph.is3D()) {
      for (auto& [id, n] : graph.nodes3) {
        const double* p = block_of.at(id);
        n.T_world_node = Pose3(Eigen::Vector3d(p[0], p[1], p[2]),
                               Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized());
      }
    } else {
      for (auto& [id, n] : graph.nodes2) {
        const double* p = block_of.at(id);
        n.T_world_node = Pose2(p[0], p[1], p[2]);  // θ wrapped to (−π, π]
      }
    }
  }

  /// Gauge: the fixed nodes, plus the lowest id of every connected component without one.
  std::vector<bool> gaugeFixed(const std::vector<NodeId>& ids,
                               const std::unordered_map<NodeId, int>& index) const {
    const int n = int(ids.size());
    std::vector<int> parent(n);
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    auto unite = [&](NodeId a, NodeId b) { parent[find(index.at(a))] = find(index.at(b)); };
    if (graph.is3D())
      for (const auto& e : graph.edges3) unite(e.from, e.to);
    else
      for (const auto& e : graph.edges2) unite(e.from, e.to);
    std::vector<bool> fixed(n, false), comp_fixed(n, false);
    auto fix = [&](NodeId id) {
      const auto it = index.find(id);
      if (it == index.end())
        throw ContractError("fixed node " + std::to_string(id) + " does not exist");
      fixed[it->second] = true;
      comp_fixed[find(it->second)] = true;
    };
    for (NodeId id : graph.fixed) fix(id);
    for (NodeId id : opt.fixed) fix(id);
    for (int i = 0; i < n; ++i)  // ids ascending: the first node seen in a component is its lowest
      if (!comp_fixed[find(i)]) {
        comp_fixed[find(i)] = true;
        fixed[i] = true;
      }
    return fixed;
  }

  /// The sparse Cholesky back-end. Ceres 2.1 always runs CHOLMOD supernodal, which pays off only
  /// when the factor has dense fronts; otherwise a simplicial factorization (CXSparse) is faster.
  /// Like CHOLMOD's own automatic switch (supernodal when flops / nnz(L) ≥ 40), decide from a
  /// symbolic-size estimate: a Cholesky factorization (AMD ordering) of the node-level graph
  /// Laplacian, one scalar per node (microseconds to a few milliseconds).
  ceres::SparseLinearAlgebraLibraryType sparseLibrary(
      const std::unordered_map<NodeId, int>& index) const {
    switch (opt.sparse_library) {
      case Options::SparseLibrary::SuiteSparse:
        return ceres::SUITE_SPARSE;
      case Options::SparseLibrary::EigenSparse:
        return ceres::EIGEN_SPARSE;
      case Options::SparseLibrary::CxSparse:
#ifndef CERES_NO_CXSPARSE
        return ceres::CX_SPARSE;
#else
        return ceres::EIGEN_SPARSE;
#endif
      case Options::SparseLibrary::Auto:
        break;
    }
    const int n = int(index.size());
    // Small graphs: every library factors them in microseconds; the fill-in estimate below
    // would cost more than it can save.
    if (n < 200) {
#ifndef CERES_NO_CXSPARSE
      return ceres::CX_SPARSE;
#else
      return ceres::EIGEN_SPARSE;
#endif
    }
    std::vector<Eigen::Triplet<double>> tr;
    tr.reserve(n + 4 * graph.numEdges());
    for (int i = 0; i < n; ++i) tr.emplace_back(i, i, 1.0);
    auto add = [&](NodeId a, NodeId b) {
      const int i = index.at(a), j = index.at(b);
      tr.emplace_back(i, j, -1.0);
      tr.emplace_back(j, i, -1.0);
      tr.emplace_back(i, i, 1.0);
      tr.emplace_back(j, j, 1.0);
    };
    if (graph.is3D())
      for (const auto& e : graph.edges3) add(e.from, e.to);
    else
      for (const auto& e : graph.edges2) add(e.from, e.to);
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(tr.begin(), tr.end());
    Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> llt(A);
    if (llt.info() != Eigen::Success) return ceres::SUITE_SPARSE;
    const Eigen::SparseMatrix<double> L = llt.matrixL();
    double flops = 0.0;
    for (int c = 0; c < L.outerSize(); ++c) {
      const double k = double(L.col(c).nonZeros());
      flops += k * k;
    }
    const double ratio = flops / std::max<double>(1.0, double(L.nonZeros()));
    OBM_LOG_DEBUG(kLog, "factor estimate: nnz(L) " << L.nonZeros() << " for " << n
                                                   << " nodes, flops/nnz " << ratio);
#ifndef CERES_NO_CXSPARSE
    return ratio >= 30.0 ? ceres::SUITE_SPARSE : ceres::CX_SPARSE;
#else
    return ratio >= 30.0 ? ceres::SUITE_SPARSE : ceres::EIGEN_SPARSE;
#endif
  }

  Summary optimize() {
    const ScopedSingleThreadedBlas one_blas_thread;  // see blas_threads.hpp
    Timer total;
    Summary s;
    graph.validate();
    s.initial_chi2 = chi2(graph);
    s.num_nodes = graph.numNodes();
    s.num_edges = graph.numEdges();

    // Initial guesses to try (robust_solve.cpp): the configured initialisation on the first
    // solve, the current poses after.
    const std::vector<Start> starts = chooseStarts(opt, !initialized);
    if (!initialized) {
      s.init = opt.init;
      initialized = true;
    }
    // The loop loss's Φ. `dcs:auto` starts by trusting the information matrices (Φ = χ²_0.99 of
    // the edge's degrees of freedom) and is calibrated by RobustSolve.
    const bool auto_dcs_mode = opt.loop_loss.kind == LossKind::Dcs && opt.loop_loss.scale <= 0.0;
    if (auto_dcs_mode) {
      auto_phi = chi2Quantile99(graph.is3D());
      if (auto_dcs) auto_dcs->setPhi(auto_phi);
    }
    const double phi = opt.loop_loss.kind == LossKind::Dcs
                           ? (auto_dcs_mode ? auto_phi : opt.loop_loss.scale)
                           : opt.loop_loss.scale * opt.loop_loss.scale;

    syncProblem();
    const bool plain_least_squares = edges_with_loss == 0;
    const auto ids = graph.nodeIds();
    std::unordered_map<NodeId, int> index;
    index.reserve(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i) index[ids[i]] = int(i);
    const auto fixed = gaugeFixed(ids, index);
    for (std::size_t i = 0; i < ids.size(); ++i) {
      double* p = block_of.at(ids[i]);
      if (fixed[i])
        problem->SetParameterBlockConstant(p);
      else
        problem->SetParameterBlockVariable(p);
      s.num_fixed += fixed[i] ? 1 : 0;
    }

    if (graph.numEdges() == 0 || opt.max_iterations == 0) {
      Timer init_timer;
      if (starts.front() == Start::Spanning) initialize(graph, InitMethod::Spanning);
      if (starts.front() == Start::Chordal || starts.front() == Start::RobustChordal)
        initialize(graph, InitMethod::Chordal);
      s.init_time_s = init_timer.seconds();
      s.init_chi2 = s.final_chi2 = chi2(graph);
      s.converged = graph.numEdges() == 0;
      s.usable = true;
      s.message = graph.numEdges() == 0 ? "no edges" : "max_iterations = 0";
      s.time_s = total.seconds();
      return s;
    }

    ceres::Solver::Options so;
    so.minimizer_type = ceres::TRUST_REGION;
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    // A graph of a handful of nodes: Ceres's dense Schur complement (an independent set of nodes
    // eliminated block by block, the rest factorised densely) costs less per iteration than the
    // sparse Cholesky's symbolic bookkeeping. Crossover measured on sub-graphs of smallGrid3D:
    // 16 nodes equal, 25 nodes 5 % slower (docs/benchmarks.md, pose graph).
    if (graph.numNodes() <= kDenseSchurMaxNodes) so.linear_solver_type = ceres::DENSE_SCHUR;
    so.sparse_linear_algebra_library_type = sparseLibrary(index);
    so.max_num_iterations = opt.max_iterations;
    // A good start (chordal relaxation) makes Gauss–Newton-sized first steps pay off; LM shrinks
    // the region on a rejected step.
    so.initial_trust_region_radius = opt.initial_trust_region_radius;
    so.function_tolerance = opt.function_tolerance;
    so.gradient_tolerance = opt.gradient_tolerance;
    so.parameter_tolerance = opt.parameter_tolerance;
    // Threads only pay off when there is enough Jacobian work per iteration. (The core count is
    // read from sysfs on every call, a measurable part of a tiny graph's solve: cached.)
    static const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
    so.num_threads = opt.num_threads > 0 ? opt.num_threads : hw;
    if (opt.num_threads == 0 && graph.numEdges() < 2000) so.num_threads = 1;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    CallbackAdapter cb(s.per_iteration, callback);
    so.callbacks.push_back(&cb);

    auto solve_once = [&]() {
      posesToBlocks();
      ceres::Solver::Summary cs;
      ceres::Solve(so, problem.get(), &cs);
      blocksToPoses();
      OBM_LOG_DEBUG(kLog, cs.FullReport());
      SolveOutcome o;
      o.usable = cs.IsSolutionUsable();
      o.converged = cs.termination_type == ceres::CONVERGENCE;
      o.initial_cost = cs.initial_cost;
      o.final_cost = cs.final_cost;
      o.iterations = cs.num_successful_steps + cs.num_unsuccessful_steps;
      o.message = cs.message;
      return o;
    };
    auto set_phi = [&](double value) {
      auto_phi = value;
      if (auto_dcs) auto_dcs->setPhi(value);
    };
    RobustSolve(graph, opt, plain_least_squares, solve_once, set_phi, s).run(starts, phi);
    s.time_s = total.seconds();
    s.final_chi2 = chi2(graph);
    return s;
  }

  void checkEdgeEnds(NodeId from, NodeId to) const {
    if (!graph.hasNode(from))
      throw ContractError("edge source node " + std::to_string(from) + " does not exist");
    if (!graph.hasNode(to))
      throw ContractError("edge target node " + std::to_string(to) + " does not exist");
    if (from == to) throw ContractError("edge joins node " + std::to_string(from) + " to itself");
  }
};

Optimizer::Optimizer(Options options) : impl_(std::make_unique<Impl>(std::move(options))) {}
Optimizer::Optimizer(PoseGraph graph, Options options) : Optimizer(std::move(options)) {
  setGraph(std::move(graph));
}
Optimizer::~Optimizer() = default;
Optimizer::Optimizer(Optimizer&&) noexcept = default;
Optimizer& Optimizer::operator=(Optimizer&&) noexcept = default;

void Optimizer::setGraph(PoseGraph graph) {
  graph.validate();
  impl_->reset();
  impl_->graph = std::move(graph);
  impl_->initialized = false;
}

void Optimizer::addNode(NodeId id, const Isometry3d& T_world_node) {
  auto& g = impl_->graph;
  if (g.numNodes() == 0 && g.numEdges() == 0) g.dimension = 3;
  OBM_ASSERT(g.is3D(), "addNode(Isometry3d) on a 2D graph");
  OBM_ASSERT(!g.hasNode(id), "node " + std::to_string(id) + " already exists");
  OBM_ASSERT(T_world_node.matrix().allFinite(), "node " + std::to_string(id) + ": non-finite pose");
  g.nodes3.emplace(id, Node3{id, Pose3::fromIsometry(T_world_node)});
  if (impl_->problem) impl_->addBlock(id);
}

void Optimizer::setPose(NodeId id, const Isometry3d& T_world_node) {
  auto& g = impl_->graph;
  OBM_ASSERT(g.is3D(), "setPose(Isometry3d) on a 2D graph");
  const auto it = g.nodes3.find(id);
  OBM_ASSERT(it != g.nodes3.end(), "node " + std::to_string(id) + " does not exist");
  OBM_ASSERT(T_world_node.matrix().allFinite(), "node " + std::to_string(id) + ": non-finite pose");
  it->second.T_world_node = Pose3::fromIsometry(T_world_node);
}

void Optimizer::addNode(NodeId id, const Pose2& T_world_node) {
  auto& g = impl_->graph;
  if (g.numNodes() == 0 && g.numEdges() == 0) g.dimension = 2;
  OBM_ASSERT(!g.is3D(), "addNode(Pose2) on a 3D graph");
  OBM_ASSERT(!g.hasNode(id), "node " + std::to_string(id) + " already exists");
  g.nodes2.emplace(id, Node2{id, T_world_node});
  if (impl_->problem) impl_->addBlock(id);
}

void Optimizer::addEdge(const Edge3& edge) {
  auto& g = impl_->graph;
  OBM_ASSERT(g.is3D(), "addEdge(Edge3) on a 2D graph");
  impl_->checkEdgeEnds(edge.from, edge.to);
  Edge3 e = edge;
  const auto st = detail::checkInformation<6>(e.information, false);
  if (st != detail::InfoStatus::Ok)
    throw ContractError("edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) + ": " +
                        detail::describe(st));
  g.edges3.push_back(e);
}

void Optimizer::addEdge(const Edge2& edge) {
  auto& g = impl_->graph;
  OBM_ASSERT(!g.is3D(), "addEdge(Edge2) on a 3D graph");
  impl_->checkEdgeEnds(edge.from, edge.to);
  Edge2 e = edge;
  const auto st = detail::checkInformation<3>(e.information, false);
  if (st != detail::InfoStatus::Ok)
    throw ContractError("edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) + ": " +
                        detail::describe(st));
  g.edges2.push_back(e);
}

void Optimizer::setFixed(NodeId id, bool fixed) {
  OBM_ASSERT(impl_->graph.hasNode(id), "node " + std::to_string(id) + " does not exist");
  if (fixed)
    impl_->graph.fixed.insert(id);
  else
    impl_->graph.fixed.erase(id);
}

void Optimizer::setIterationCallback(std::function<void(const IterationInfo&)> cb) {
  impl_->callback = std::move(cb);
}

Summary Optimizer::optimize() {
  return impl_->optimize();
}
const PoseGraph& Optimizer::graph() const {
  return impl_->graph;
}
Isometry3d Optimizer::pose(NodeId id) const {
  return impl_->graph.isometry(id);
}
Pose2 Optimizer::pose2(NodeId id) const {
  OBM_ASSERT(!impl_->graph.is3D(), "pose2() on a 3D graph");
  const auto it = impl_->graph.nodes2.find(id);
  OBM_ASSERT(it != impl_->graph.nodes2.end(), "node " + std::to_string(id) + " does not exist");
  return it->second.T_world_node;
}
const Options& Optimizer::options() const {
  return impl_->opt;
}

Summary optimizeGraph(PoseGraph& graph, const Options& options) {
  Optimizer o(std::move(graph), options);
  const Summary s = o.optimize();
  graph = o.graph();
  return s;
}

}  // namespace obm::backend
