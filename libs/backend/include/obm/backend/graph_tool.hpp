#pragma once
/// \file graph_tool.hpp
/// The obm-graph tool as a class (the app's main only parses the command line): read a .g2o/.graph
/// file, optimise it, write the optimised graph atomically and a JSON report.
#include <iosfwd>
#include <string>

#include "obm/backend/graph_io.hpp"
#include "obm/backend/optimizer.hpp"

namespace obm::backend {

/// Everything one run of the tool needs.
struct GraphToolConfig {
  std::string input;             ///< .g2o or .graph file (required)
  std::string output;            ///< .g2o or .graph file written atomically (required)
  std::string report;            ///< optional JSON report path
  Options optimizer;             ///< optimizer options
  ReadOptions read;              ///< reader options (information-matrix repair)
  bool print_iterations = true;  ///< one line per LM iteration on the output stream

  /// Reads `optimizer:` (Options::load) and `io: {repair_information: bool}` of a YAML file.
  static GraphToolConfig load(const ConfigNode& node);
};

/// Runs the tool. Nothing is written when reading or optimising fails (the exception propagates);
/// outputs are written atomically (temporary file + rename).
class GraphTool {
 public:
  explicit GraphTool(GraphToolConfig config);
  /// Reads, optimises, writes; human-readable progress goes to `out`. Throws obm::Error subclasses.
  Summary run(std::ostream& out);

 private:
  GraphToolConfig cfg_;
};

/// The JSON report: {"initial_chi2", "final_chi2", "iterations", "time_s", "converged", …}.
std::string reportJson(const Summary& summary, const PoseGraph& graph, const std::string& input,
                       const std::string& output);

}  // namespace obm::backend
