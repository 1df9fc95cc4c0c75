#include "obm/backend/graph_tool.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>
#include <ostream>

#include "obm/backend/metrics.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"

namespace obm::backend {

GraphToolConfig GraphToolConfig::load(const ConfigNode& node) {
  node.checkKeys({"optimizer", "io"});
  GraphToolConfig c;
  c.optimizer = Options::load(node.child("optimizer"));
  const ConfigNode io = node.child("io");
  io.checkKeys({"repair_information"});
  bool repair = false;
  io.get("repair_information", repair);
  c.read.repair = repair ? InformationRepair::Clamp : InformationRepair::Reject;
  return c;
}

GraphTool::GraphTool(GraphToolConfig config) : cfg_(std::move(config)) {}

std::string reportJson(const Summary& s, const PoseGraph& g, const std::string& input,
                       const std::string& output) {
  nlohmann::json j;
  j["initial_chi2"] = s.initial_chi2;
  j["final_chi2"] = s.final_chi2;
  j["iterations"] = s.iterations;
  j["time_s"] = s.time_s;
  j["converged"] = s.converged;
  j["init_chi2"] = s.init_chi2;
  j["init"] = toString(s.init);
  j["init_time_s"] = s.init_time_s;
  j["solve_time_s"] = s.solve_time_s;
  j["dimension"] = g.dimension;
  j["nodes"] = s.num_nodes;
  j["edges"] = s.num_edges;
  j["fixed_nodes"] = s.num_fixed;
  j["solver_message"] = s.message;
  j["input"] = input;
  j["output"] = output;
  nlohmann::json its = nlohmann::json::array();
  for (const auto& it : s.per_iteration)
    its.push_back({{"iteration", it.iteration},
                   {"cost", it.cost},
                   {"step_norm", it.step_norm},
                   {"gradient_max_norm", it.gradient_max_norm},
                   {"step_is_successful", it.step_is_successful},
                   {"time_s", it.time_s}});
  j["per_iteration"] = its;
  return j.dump(2) + "\n";
}

Summary GraphTool::run(std::ostream& out) {
  if (cfg_.input.empty()) throw ConfigError("no input file given (-i)");
  if (cfg_.output.empty()) throw ConfigError("no output file given (-o)");
  formatFromPath(cfg_.output);  // fail on an unknown output format before any work

  Timer read_timer;
  PoseGraph graph = readGraph(cfg_.input, cfg_.read);
  const double read_s = read_timer.seconds();
  char line[256];
  std::snprintf(line, sizeof line, "%s: %dD graph, %zu nodes, %zu edges (read in %.3f s)\n",
                cfg_.input.c_str(), graph.dimension, graph.numNodes(), graph.numEdges(), read_s);
  out << line;

  Optimizer opt(std::move(graph), cfg_.optimizer);
  if (cfg_.print_iterations)
    opt.setIterationCallback([&out](const IterationInfo& it) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "iter %3d  cost %.9g  d_cost %.3e  |grad| %.3e  |step| %.3e  radius %.2e  %s  "
                    "%.3f s\n",
                    it.iteration, it.cost, it.cost_change, it.gradient_max_norm, it.step_norm,
                    it.trust_region_radius, it.step_is_successful ? "ok " : "rej", it.time_s);
      out << buf;
    });
  const Summary s = opt.optimize();
  if (!s.usable) throw Error("optimisation failed: " + s.message + " (nothing written)");
  const PoseGraph& result = opt.graph();
  result.validate();  // non-finite poses would throw here, before anything is written

  std::snprintf(line, sizeof line, "initial chi2 %.9g  (after %s init: %.9g)\n", s.initial_chi2,
                toString(s.init).c_str(), s.init_chi2);
  out << line;
  std::snprintf(line, sizeof line,
                "final chi2 %.9g  iterations %d  time %.3f s (init %.3f s, solve %.3f s)  %s\n",
                s.final_chi2, s.iterations, s.time_s, s.init_time_s, s.solve_time_s,
                s.converged ? "converged" : "NOT converged");
  out << line;
  out << "solver: " << s.message << "\n";

  writeGraph(result, cfg_.output);
  out << "wrote " << cfg_.output << "\n";
  if (!cfg_.report.empty()) {
    writeTextAtomically(cfg_.report, reportJson(s, result, cfg_.input, cfg_.output));
    out << "wrote " << cfg_.report << "\n";
  }
  return s;
}

}  // namespace obm::backend
