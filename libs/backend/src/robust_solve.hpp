#pragma once
// The robust-solve strategy of Optimizer::optimize(): which initial guesses to try, solving from
// each and keeping the lowest robust objective, and the calibration of `dcs:auto`'s Φ
// (docs/obm-graph.md, "Robust loop edges"). The plain solve (Ceres problem, one Solve) stays in
// optimizer.cpp and is handed in as a callback, so this file holds only the decisions.
#include <functional>
#include <string>
#include <vector>

#include "obm/backend/optimizer.hpp"
#include "obm/backend/pose_graph.hpp"

namespace obm::backend {

/// χ²_0.99 and the median of χ² with a pose edge's degrees of freedom (6 in 3D, 3 in 2D): the
/// `dcs:auto` calibration's Φ = ŝ·χ²_0.99, ŝ = median loop-edge χ² / median χ².
inline double chi2Quantile99(bool is3d) { return is3d ? 16.8119 : 11.3449; }
inline double chi2Median(bool is3d) { return is3d ? 5.34812 : 2.36597; }

/// An initial guess of the solve.
enum class Start { AsIs, File, Spanning, Chordal, RobustChordal };

/// The starts of a graph's first solve: the configured initialisation, or in a robust mode with
/// the chordal default and robust_init = best, three starts whose solutions compete on the robust
/// objective. Later solves continue from the current poses (Start::AsIs).
std::vector<Start> chooseStarts(const Options& opt, bool first_solve);

/// What one Ceres solve from the current poses reports.
struct SolveOutcome {
  bool usable = false;
  bool converged = false;
  double initial_cost = 0.0;  ///< Ceres' ½·(robustified) cost at the start
  double final_cost = 0.0;    ///< Ceres' ½·(robustified) cost at the end
  int iterations = 0;         ///< successful + rejected steps
  std::string message;
};

/// Runs the strategy on `graph` (which holds the poses to start from and receives the solution).
class RobustSolve {
 public:
  /// `solve_once` solves from the graph's current poses and writes the result back into it;
  /// `set_phi` hands a new `dcs:auto` Φ to the loss functions. `plain_least_squares`: no edge has
  /// a loss function (χ² is then 2 × Ceres's cost).
  RobustSolve(PoseGraph& graph, const Options& opt, bool plain_least_squares,
              std::function<SolveOutcome()> solve_once, std::function<void(double)> set_phi,
              Summary& summary);

  /// Solves from `starts`; with `dcs:auto`, re-calibrates Φ on the loop edges' residuals and
  /// solves again (graduated, warm-started) until Φ settles, then lets fresh starts at the final Φ
  /// compete with the graduated solution. `phi` is the loop loss's Φ to begin with.
  void run(const std::vector<Start>& starts, double phi);

 private:
  bool mostLoopsActive() const;
  void solveStarts(const std::vector<Start>& list, bool incumbent);

  PoseGraph& graph_;
  const Options& opt_;
  bool plain_least_squares_;
  std::function<SolveOutcome()> solve_once_;
  std::function<void(double)> set_phi_;
  Summary& s_;
  double phi_ = 1.0;
  PoseGraph start_graph_;
  PoseGraph best_graph_;
  double best_cost_ = 0.0;
  std::string best_name_;
  bool best_active_ = false;
};

}  // namespace obm::backend
