// obm-graph: pose-graph optimisation of a .g2o / .graph file (see docs/obm-graph.md).
#include <CLI/CLI.hpp>
#include <iostream>

#include "../common/cli.hpp"
#include "obm/backend/graph_tool.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"

int main(int argc, char** argv) {
  using namespace obm::backend;
  CLI::App app{
      "obm-graph: optimises a pose graph (g2o .g2o or TORO/MRPT .graph, 2D or 3D detected from the "
      "file) by minimising g2o's chi2 with Ceres, and writes the optimised graph atomically."};
  std::string input, output, report, config, init, robust, log_level;
  int max_iters = -1, threads = -1;
  std::vector<long long> fix;
  bool repair = false, quiet = false;
  app.add_option("-i,--input", input, "input pose graph (.g2o or .graph)")->required();
  app.add_option("-o,--output", output, "optimised graph to write (.g2o or .graph, atomic)")
      ->required();
  app.add_option("-c,--config", config, "YAML options (see config/graph.yaml); flags override it");
  app.add_option("--init", init,
                 "initial guess: file (vertices as read), spanning (odometry spanning tree) or "
                 "chordal (chordal relaxation) [default: chordal]");
  app.add_option("--robust", robust,
                 "loss of loop edges: none, huber:D, cauchy:C, dcs:PHI (outlier-robust dynamic "
                 "covariance scaling) or dcs:auto (PHI calibrated on the graph's residuals) "
                 "[default: none]");
  app.add_option("--max-iters", max_iters, "maximum Levenberg-Marquardt iterations [default: 100]");
  app.add_option("--threads", threads,
                 "threads for Jacobian evaluation, 0 = all cores [default: 0]");
  app.add_option("--fix", fix,
                 "hold node ID constant (repeatable; default: the file's FIX nodes, "
                 "else the lowest id of each connected component)");
  app.add_option("--report", report,
                 "write a JSON report (initial_chi2, final_chi2, iterations, "
                 "time_s, converged, per-iteration costs)");
  app.add_flag("--repair-information", repair,
               "clamp negative eigenvalues of information matrices (with a warning) instead of "
               "rejecting the file");
  app.add_flag("-q,--quiet", quiet, "no per-iteration lines");
  obm::apps::addLogLevelOption(app, log_level, "warn");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-graph", [&] {
    obm::setLogLevel(obm::parseLogLevel(log_level));
    GraphToolConfig cfg;
    if (!config.empty()) cfg = GraphToolConfig::load(obm::ConfigNode::loadFile(config));
    cfg.input = input;
    cfg.output = output;
    cfg.report = report;
    if (!init.empty()) cfg.optimizer.init = parseInitMethod(init);
    if (!robust.empty()) cfg.optimizer.loop_loss = parseLoss(robust);
    if (max_iters >= 0) cfg.optimizer.max_iterations = max_iters;
    if (threads >= 0) cfg.optimizer.num_threads = threads;
    for (long long id : fix) cfg.optimizer.fixed.push_back(id);
    if (repair) cfg.read.repair = InformationRepair::Clamp;
    cfg.print_iterations = !quiet;
    GraphTool tool(cfg);
    tool.run(std::cout);
    return 0;
  });
}
