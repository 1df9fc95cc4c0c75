#pragma once
/// \file optimizer.hpp
/// Pose-graph optimizer (Ceres 2.1 Levenberg–Marquardt, sparse Cholesky, quaternion manifold) that
/// minimises exactly g2o's χ² = Σ eᵀΩe (see metrics.hpp): each residual is r = Lᵀe with Ω = L·Lᵀ,
/// so ‖r‖² = eᵀΩe. Usable one-shot (optimizeGraph) or incrementally (add nodes/edges, re-optimise).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "obm/backend/initialization.hpp"
#include "obm/backend/pose_graph.hpp"

namespace obm {
class ConfigNode;
}

namespace obm::backend {

/// Parses "none", "huber:δ", "cauchy:c", "dcs:Φ" (scale optional, default 1) or "dcs:auto" (Φ
/// calibrated on the graph's own residuals; EdgeLoss scale 0); throws ConfigError.
EdgeLoss parseLoss(const std::string& spec);
/// "none" / "huber:1" / ... (inverse of parseLoss).
std::string toString(const EdgeLoss& loss);

/// Optimizer parameters (YAML: see config/graph.yaml, loaded in Options::load only).
struct Options {
  InitMethod init = InitMethod::Chordal;  ///< initial guess before the first optimisation
  int max_iterations = 100;               ///< Levenberg–Marquardt iterations (upper bound)
  int num_threads = 0;                    ///< Jacobian evaluation threads; 0 = all cores
  double function_tolerance = 1e-6;       ///< stop when |Δcost|/cost < this [-]
  double gradient_tolerance = 1e-12;      ///< stop when max|gradient| (projected) < this
  double parameter_tolerance = 1e-10;     ///< stop when |Δx| < this·(|x| + this)
  /// Initial LM trust-region radius (1/μ). Large = near Gauss–Newton first steps, which converge
  /// in a few iterations from the chordal start; rejected steps shrink it.
  double initial_trust_region_radius = 1e16;
  /// Sparse Cholesky library of Ceres' SPARSE_NORMAL_CHOLESKY. Auto: SuiteSparse (CHOLMOD,
  /// supernodal) when the factor has dense fronts, else CXSparse (simplicial) — see docs.
  enum class SparseLibrary { Auto, SuiteSparse, CxSparse, EigenSparse };
  SparseLibrary sparse_library = SparseLibrary::Auto;
  /// Loss of loop edges (LossKind::Default on an edge means "use this"). `Dcs` is the
  /// outlier-robust mode: dynamic covariance scaling (Agarwal et al. ICRA 2013) with Φ = scale.
  EdgeLoss loop_loss{LossKind::None, 1.0};
  /// Loss of odometry edges whose own loss is LossKind::Default.
  EdgeLoss odometry_loss{LossKind::None, 1.0};
  /// Initialisation used instead of the plain chordal relaxation when init is Chordal and loop
  /// edges have a robust loss (least-squares chordal relaxation is pulled by wrong loops).
  enum class RobustInit {
    Odometry,       ///< the odometry spanning tree (never sees a loop edge)
    Chordal,        ///< the plain (least-squares) chordal relaxation
    RobustChordal,  ///< re-weighted chordal relaxation (initializeRobustChordal)
    Best,           ///< solve from all three; keep the solution with the lowest robust objective
  };
  RobustInit robust_init = RobustInit::Best;
  std::vector<NodeId> fixed;  ///< nodes held constant in addition to the graph's `FIX` nodes

  /// Reads the keys of `node` (all optional); throws ConfigError naming file and key.
  static Options load(const ConfigNode& node);
};

/// One Levenberg–Marquardt iteration.
struct IterationInfo {
  int iteration = 0;
  double cost = 0.0;  ///< objective Σρ(‖r‖²) (= χ² when no robust loss)
  double cost_change = 0.0;
  double gradient_max_norm = 0.0;
  double step_norm = 0.0;
  double trust_region_radius = 0.0;
  bool step_is_successful = false;
  double time_s = 0.0;  ///< cumulative since the solver started
};

/// Result of Optimizer::optimize().
struct Summary {
  double initial_chi2 = 0.0;  ///< g2o χ² of the poses given (before initialisation)
  double init_chi2 = 0.0;     ///< g2o χ² after initialisation
  double final_chi2 = 0.0;    ///< g2o χ² of the solution
  int iterations = 0;         ///< LM iterations (successful + rejected steps)
  double time_s = 0.0;        ///< initialisation + solve [s] (no file I/O)
  double init_time_s = 0.0;   ///< initialisation [s]
  double solve_time_s = 0.0;  ///< Ceres solve incl. problem set-up [s]
  double dcs_phi = 0.0;       ///< `dcs:auto`: the calibrated Φ used for the solution (else 0)
  bool converged = false;     ///< a convergence tolerance was met (not the iteration limit)
  bool usable = false;        ///< the solution is usable (converged or stopped early but valid)
  std::string message;        ///< Ceres' termination message
  InitMethod init = InitMethod::File;  ///< initialisation actually used
  std::size_t num_nodes = 0, num_edges = 0, num_fixed = 0;
  std::vector<IterationInfo> per_iteration;
};

/// Pose-graph optimizer. Owns a copy of the graph and a Ceres problem that persists between calls,
/// so the mapping app can add nodes and edges and re-optimise warm-started from the last solution.
class Optimizer {
 public:
  explicit Optimizer(Options options = {});
  Optimizer(PoseGraph graph, Options options = {});
  ~Optimizer();
  Optimizer(Optimizer&&) noexcept;
  Optimizer& operator=(Optimizer&&) noexcept;

  /// Replaces the graph (the next optimize() initialises it according to Options::init).
  void setGraph(PoseGraph graph);
  /// Adds a node with its initial guess (3D graph); throws ContractError on a duplicate id.
  void addNode(NodeId id, const Isometry3d& T_world_node);
  /// Adds a node with its initial guess (2D graph); throws ContractError on a duplicate id.
  void addNode(NodeId id, const Pose2& T_world_node);
  /// Adds an edge between existing nodes; throws ContractError otherwise or on a non-PSD Ω.
  void addEdge(const Edge3& edge);
  void addEdge(const Edge2& edge);
  /// Replaces a node's current pose (3D graph), e.g. to move a piece of the graph that was
  /// relocalised; the next optimize() starts from it. Throws ContractError if absent.
  void setPose(NodeId id, const Isometry3d& T_world_node);
  /// Holds a node constant (or releases it).
  void setFixed(NodeId id, bool fixed = true);
  /// Called after each LM iteration (e.g. for a progress line); may be empty.
  void setIterationCallback(std::function<void(const IterationInfo&)> callback);

  /// Optimises. The first call (and the first after setGraph) initialises the poses according to
  /// Options::init; later calls start from the current solution (new nodes from their guesses).
  Summary optimize();

  /// The graph with the current poses.
  const PoseGraph& graph() const;
  /// Current pose of a node (3D graph; 2D poses lifted). Throws ContractError if absent.
  Isometry3d pose(NodeId id) const;
  /// Current pose of a node of a 2D graph. Throws ContractError if absent.
  Pose2 pose2(NodeId id) const;
  const Options& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One-shot: optimises `graph` in place with `options`.
Summary optimizeGraph(PoseGraph& graph, const Options& options = {});

}  // namespace obm::backend
