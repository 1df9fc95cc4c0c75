// obm-graph-bench: obm-graph's optimizer side by side with the Ceres pose_graph example's
// formulation and MRPT's graph-slam --levmarq on the standard pose-graph datasets, every solution
// scored with the same g2o χ²; then the robustness experiment (10 % wrong loop closures).
// Prints Markdown tables (docs/benchmarks.md, "Pose graph (obm-graph)").
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "../common/cli.hpp"
#include "obm/backend/graph_io.hpp"
#include "obm/backend/metrics.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/backend/synthetic.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "peers.hpp"

using namespace obm;
using namespace obm::backend;
using obm::bench::PeerResult;

namespace {

struct Run {
  double chi2 = 0, time_s = 0;
  int iterations = 0;
  bool ok = false;
};

/// Best of the runs: load from other processes only ever adds time.
double best(const std::vector<double>& v) {
  return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end());
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

/// χ² with 4 significant digits, or a dash.
std::string chi(double v, bool ok) {
  return ok ? fmt("%.4g", v) : "failed";
}

Run runOurs(const PoseGraph& g, const Options& o, int repeat, PoseGraph* solution = nullptr) {
  Run r;
  std::vector<double> times;
  for (int i = 0; i < repeat; ++i) {
    PoseGraph work = g;
    const Summary s = optimizeGraph(work, o);
    times.push_back(s.time_s);
    r.chi2 = chi2(work);
    r.iterations = s.iterations;
    r.ok = s.usable;
    if (solution) *solution = std::move(work);
  }
  r.time_s = best(times);
  return r;
}

template <typename F>
Run runPeer(const PoseGraph& g, int repeat, F solve, std::string* note = nullptr) {
  Run r;
  std::vector<double> times;
  for (int i = 0; i < repeat; ++i) {
    const PeerResult p = solve(g);
    times.push_back(p.time_s);
    r.chi2 = chi2(p.solution);
    r.iterations = p.iterations;
    r.ok = p.ok;
    if (note) *note = p.note;
  }
  r.time_s = best(times);
  return r;
}

/// DCS weight of each edge at the solution, for counting which loops the robust mode rejected.
double dcsWeight(double chi, double phi) {
  const double k = std::min(1.0, 2.0 * phi / (phi + chi));
  return k * k;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"obm-graph-bench: pose-graph optimizers side by side, scored with g2o's chi2"};
  std::string data = "../shared/data/posegraph", work = "/tmp/obm-graph-bench", out_md,
              graph_slam = "graph-slam";
  std::vector<std::string> datasets = {
      "sphere2500", "parking-garage", "smallGrid3D", "tinyGrid3D", "sphere_bignoise_vertex3",
      "intel",      "manhattan",      "ais2klinik",  "kitti_05"};
  int repeat = 5, threads = 0;
  bool no_mrpt = false, no_ceres = false, no_robust = false;
  std::string robust_real = "dcs:auto";
  double wrong_fraction = 0.1;
  app.add_option("--data", data,
                 "folder with the .g2o datasets [default: ../shared/data/posegraph]");
  app.add_option("--datasets", datasets, "dataset names (file stems) [default: all nine]")
      ->delimiter(',');
  app.add_option("--repeat", repeat,
                 "runs per optimizer (at least 25 on graphs under 1000 edges); the shortest time "
                 "is reported [default: 5]");
  app.add_option("--threads", threads, "obm-graph threads, 0 = automatic [default: 0]");
  app.add_option("--work", work,
                 "scratch folder for the MRPT files [default: /tmp/obm-graph-bench]");
  app.add_option("--graph-slam", graph_slam, "MRPT graph-slam executable [default: graph-slam]");
  app.add_option("--robust", robust_real,
                 "robust loss of the robustness runs [default: dcs:auto]; with a fixed Φ the "
                 "synthetic graphs use\n"
                 "their calibrated χ²_0.99 (dcs:16.8 in 3D, dcs:11.3 in 2D)");
  bool no_synthetic = false;
  app.add_flag("--no-synthetic", no_synthetic,
               "skip the synthetic graphs of the robustness experiment (real graphs only)");
  app.add_option("--wrong-fraction", wrong_fraction,
                 "fraction of loop edges replaced [default: 0.1]");
  app.add_flag("--no-mrpt", no_mrpt, "skip MRPT graph-slam");
  app.add_flag("--no-ceres", no_ceres, "skip the Ceres example formulation");
  app.add_flag("--no-robust", no_robust, "skip the robustness experiment");
  app.add_option("--out", out_md, "also write the Markdown to this file (atomically)");
  CLI11_PARSE(app, argc, argv);

  return apps::runMain("obm-graph-bench", apps::OtherExceptions::Error, [&] {
    setLogLevel(LogLevel::Warn);
    ensureDirectory(work);
    Options ours;
    ours.num_threads = threads;
    std::ostringstream md;
    md << "| dataset | dim | nodes | edges | χ² start | **obm-graph χ²** | it | time [ms] | "
          "Ceres-example χ² | it | "
          "time [ms] | MRPT graph-slam χ² | it | time [ms] | χ² ≤ best peer | time / faster peer "
          "|\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    struct RealSet {
      std::string name;
      PoseGraph graph, clean;
    };
    std::vector<RealSet> loaded;
    for (const auto& name : datasets) {
      const std::string path = data + "/" + name + ".g2o";
      std::cerr << "[bench] " << name << "\n";
      RealSet rs{name, readG2o(path), {}};
      const PoseGraph& g = rs.graph;
      const int runs = g.numEdges() < 1000 ? std::max(repeat, 25) : repeat;
      const Run o = runOurs(g, ours, runs, &rs.clean);
      Run c, m;
      std::string mrpt_note;
      if (!no_ceres)
        c = runPeer(g, runs, [](const PoseGraph& x) { return bench::solveCeresExample(x); });
      if (!no_mrpt)
        m = runPeer(
            g, repeat, [&](const PoseGraph& x) { return bench::solveMrpt(x, work, graph_slam); },
            &mrpt_note);
      double best = std::numeric_limits<double>::infinity(), fastest = best;
      for (const Run* p : {&c, &m})
        if (p->ok) {
          best = std::min(best, p->chi2);
          fastest = std::min(fastest, p->time_s);
        }
      md << "| " << name << " | " << g.dimension << "D | " << g.numNodes() << " | " << g.numEdges()
         << " | " << fmt("%.4g", chi2(g)) << " | **" << chi(o.chi2, o.ok) << "** | " << o.iterations
         << " | " << fmt("%.4g", 1e3 * o.time_s) << " | " << (no_ceres ? "–" : chi(c.chi2, c.ok))
         << " | " << c.iterations << " | " << fmt("%.4g", 1e3 * c.time_s) << " | "
         << (no_mrpt ? "–" : chi(m.chi2, m.ok)) << " | " << m.iterations << " | "
         << fmt("%.4g", 1e3 * m.time_s) << " | "
         << (std::isfinite(best) ? (o.chi2 <= best ? "yes" : "**no**") : "–") << " | "
         << (std::isfinite(fastest) ? fmt("%.2f", o.time_s / fastest) : "–") << " |\n";
      if (!no_mrpt && !m.ok) std::cerr << "[bench] MRPT on " << name << ": " << mrpt_note << "\n";
      loaded.push_back(std::move(rs));
    }

    if (!no_robust) {
      // Synthetic graphs with ground truth: calibrated noise, so Φ is the 99 % quantile of a
      // correct edge's χ² (χ²(6) = 16.8, χ²(3) = 11.3).
      md << "\n**Robustness, synthetic graphs with ground truth** — " << int(100 * wrong_fraction)
         << " % of the loop edges replaced by random wrong ones; ATE (RMSE, m, after rigid "
            "alignment) "
            "against the ground truth.\n\n"
            "| graph | nodes | loops | wrong | ATE clean | ATE robust (corrupted) | robust / clean "
            "| ATE "
            "non-robust (corrupted) | wrong loops rejected | good loops rejected |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n";
      struct Syn {
        std::string name;
        SyntheticSpec spec;
        std::string loss;
      };
      SyntheticSpec sphere;
      sphere.dimension = 3;
      sphere.rings = 50;
      sphere.nodes_per_ring = 50;
      sphere.radius = 25.0;
      sphere.sigma_translation = 0.05;
      sphere.sigma_rotation = 0.01;
      SyntheticSpec grid;
      grid.dimension = 2;
      grid.steps = 3000;
      grid.sigma_translation = 0.05;
      grid.sigma_rotation = 0.01;
      const bool auto_phi = robust_real == "dcs:auto";
      std::vector<Syn> synthetic{
          Syn{"sphere (3D, 50×50)", sphere, auto_phi ? robust_real : "dcs:16.8"},
          Syn{"grid walk (2D)", grid, auto_phi ? robust_real : "dcs:11.3"}};
      if (no_synthetic) synthetic.clear();
      for (const Syn& s : synthetic) {
        std::cerr << "[bench] robustness " << s.name << "\n";
        const SyntheticGraph syn = makeSyntheticGraph(s.spec);
        PoseGraph clean = syn.graph;
        optimizeGraph(clean, ours);
        PoseGraph bad = syn.graph;
        const std::size_t n_wrong = injectWrongLoops(bad, wrong_fraction, 2024);
        PoseGraph plain = bad, robust = bad;
        optimizeGraph(plain, ours);
        Options ro = ours;
        ro.loop_loss = parseLoss(s.loss);
        const Summary rsum = optimizeGraph(robust, ro);
        const double phi_used = ro.loop_loss.scale > 0.0 ? ro.loop_loss.scale : rsum.dcs_phi;
        std::size_t loops = 0, rej_wrong = 0, rej_good = 0;
        for (std::size_t k = 0; k < bad.numEdges(); ++k) {
          const bool loop = bad.is3D() ? bad.edges3[k].is_loop : bad.edges2[k].is_loop;
          if (!loop) continue;
          ++loops;
          const bool wrong = bad.is3D() ? (bad.edges3[k].from != syn.graph.edges3[k].from ||
                                           bad.edges3[k].to != syn.graph.edges3[k].to)
                                        : (bad.edges2[k].from != syn.graph.edges2[k].from ||
                                           bad.edges2[k].to != syn.graph.edges2[k].to);
          const double c =
              bad.is3D() ? edgeChi2(robust, bad.edges3[k]) : edgeChi2(robust, bad.edges2[k]);
          const bool rejected = dcsWeight(c, phi_used) < 0.1;
          if (rejected && wrong) ++rej_wrong;
          if (rejected && !wrong) ++rej_good;
        }
        const double a_clean = absoluteTrajectoryError(clean, syn.ground_truth).rmse;
        const double a_rob = absoluteTrajectoryError(robust, syn.ground_truth).rmse;
        const double a_plain = absoluteTrajectoryError(plain, syn.ground_truth).rmse;
        md << "| " << s.name << " (`--robust " << s.loss << "`"
           << (auto_phi ? fmt(", Φ = %.3g", phi_used) : std::string()) << ") | " << bad.numNodes()
           << " | " << loops << " | " << n_wrong << " | " << fmt("%.4f", a_clean) << " | "
           << fmt("%.4f", a_rob) << " | " << fmt("%.2f", a_rob / a_clean) << " | "
           << fmt("%.3f", a_plain) << " | " << rej_wrong << " / " << n_wrong << " | " << rej_good
           << " / " << (loops - n_wrong) << " |\n";
      }

      md << "\n**Robustness, real graphs** — same corruption; no ground truth, so the ATE is taken "
            "against the clean graph's own solution (how far the wrong loops drag the map).\n\n"
            "| dataset | loops | wrong | ATE robust `--robust "
         << robust_real
         << "` | ATE non-robust | χ² of the "
            "original edges (robust / clean) | Φ (dcs:auto) |\n|---|---|---|---|---|---|---|\n";
      for (const RealSet& rs : loaded) {
        std::cerr << "[bench] robustness " << rs.name << "\n";
        PoseGraph bad = rs.graph;
        const std::size_t n_wrong = injectWrongLoops(bad, wrong_fraction, 2024);
        std::size_t loops = 0;
        for (std::size_t k = 0; k < bad.numEdges(); ++k)
          loops += (bad.is3D() ? bad.edges3[k].is_loop : bad.edges2[k].is_loop) ? 1 : 0;
        PoseGraph plain = bad, robust = bad;
        optimizeGraph(plain, ours);
        Options ro = ours;
        ro.loop_loss = parseLoss(robust_real);
        const Summary rsum = optimizeGraph(robust, ro);
        PoseGraph scored = rs.graph;  // the robust poses scored on the uncorrupted edges
        scored.copyPosesFrom(robust);
        md << "| " << rs.name << " | " << loops << " | " << n_wrong << " | "
           << fmt("%.4f", absoluteTrajectoryError(robust, rs.clean).rmse) << " | "
           << fmt("%.3f", absoluteTrajectoryError(plain, rs.clean).rmse) << " | "
           << fmt("%.4g", chi2(scored)) << " / " << fmt("%.4g", chi2(rs.clean)) << " | "
           << (rsum.dcs_phi > 0.0 ? fmt("%.3g", rsum.dcs_phi) : std::string("–")) << " |\n";
      }
    }
    std::cout << md.str();
    if (!out_md.empty()) writeTextAtomically(out_md, md.str());
    return 0;
  });
}
