// Initialisation (spanning tree, chordal), the optimizer (local optimality of g2o's χ², gauge,
// incremental use) and the robust mode against injected wrong loop closures.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "obm/backend/initialization.hpp"
#include "obm/backend/metrics.hpp"
#include "test_data.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/backend/synthetic.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

using namespace obm;
using namespace obm::backend;

namespace {

SyntheticSpec sphereSpec(double st, double sr, std::uint64_t seed = 1) {
  SyntheticSpec s;
  s.dimension = 3;
  s.rings = 8;
  s.nodes_per_ring = 16;
  s.sigma_translation = st;
  s.sigma_rotation = sr;
  s.seed = seed;
  return s;
}

SyntheticSpec gridSpec(double st, double sr, std::uint64_t seed = 1, int steps = 300) {
  SyntheticSpec s;
  s.dimension = 2;
  s.steps = steps;
  s.sigma_translation = st;
  s.sigma_rotation = sr;
  s.seed = seed;
  return s;
}

double maxRotationError(const PoseGraph& a, const PoseGraph& b) {
  double m = 0;
  for (NodeId id : a.nodeIds())
    m = std::max(
        m, rotationAngle((a.isometry(id).rotation().transpose() * b.isometry(id).rotation())));
  return m;
}

}  // namespace

TEST(Initialization, ChordalRecoversNoiselessGraphExactly) {
  for (int dim : {2, 3}) {
    auto syn = makeSyntheticGraph(dim == 3 ? sphereSpec(1e-9, 1e-9) : gridSpec(1e-9, 1e-9));
    PoseGraph g = syn.graph;
    // Start from a useless guess: everything at the origin except the gauge root.
    for (auto& [id, n] : g.nodes3)
      if (id != 0) n.T_world_node = Pose3();
    for (auto& [id, n] : g.nodes2)
      if (id != 0) n.T_world_node = Pose2();
    initializeChordal(g);
    const auto ate = absoluteTrajectoryError(g, syn.ground_truth, /*align=*/false);
    EXPECT_LT(ate.max, 1e-6) << dim << "D";
    EXPECT_LT(maxRotationError(g, syn.ground_truth), 1e-6) << dim << "D";
  }
}

TEST(Initialization, SpanningTreeComposesOdometry) {
  auto syn = makeSyntheticGraph(gridSpec(0.0, 0.0));
  PoseGraph g = syn.graph;
  for (auto& [id, n] : g.nodes2)
    if (id != 0) n.T_world_node = Pose2(5, 5, 1);
  initializeSpanningTree(g, true);
  EXPECT_LT(absoluteTrajectoryError(g, syn.ground_truth, false).max, 1e-9);
}

TEST(Initialization, SpanningTreeKeepsOdometryBeyondABreakInTheChain) {
  // A noisy trajectory whose odometry chain misses one edge: the part after the break is reached
  // only through loop edges, many of them. Exactly one may bridge the gap; every odometry edge
  // must hold exactly (a loop edge taken inside the part would tear its odometry apart, which is
  // what broke the robust start on ais2klinik, whose chain has such a gap).
  auto syn = makeSyntheticGraph(gridSpec(0.05, 0.01, 3, 600));
  PoseGraph g = syn.graph;
  const auto cut = std::find_if(g.edges2.begin(), g.edges2.end(),
                                [](const Edge2& e) { return !e.is_loop && e.from == 300; });
  ASSERT_NE(cut, g.edges2.end());
  g.edges2.erase(cut);
  std::size_t odometry = 0, loops_into_second_part = 0;
  for (const auto& e : g.edges2) {
    odometry += e.is_loop ? 0 : 1;
    if (e.is_loop && (e.from > 300) != (e.to > 300)) ++loops_into_second_part;
  }
  ASSERT_GT(loops_into_second_part, 3u);
  initializeSpanningTree(g, true);
  std::size_t exact_odometry = 0, exact_loops = 0;
  for (const auto& e : g.edges2) {
    const bool exact = edgeChi2(g, e) < 1e-12;
    if (exact && !e.is_loop) ++exact_odometry;
    if (exact && e.is_loop) ++exact_loops;
  }
  EXPECT_EQ(exact_odometry, odometry);
  EXPECT_EQ(exact_loops, 1u);  // the bridge (noisy loops are not satisfied by chance)
}

TEST(Initialization, ChordalBeatsOdometryOnNoisySphere) {
  auto syn = makeSyntheticGraph(sphereSpec(0.05, 0.02));
  PoseGraph odo = syn.graph, cho = syn.graph;
  initializeSpanningTree(odo, true);
  initializeChordal(cho);
  const double c_odo = chi2(odo), c_cho = chi2(cho);
  EXPECT_LT(c_cho, 0.1 * c_odo) << c_cho << " vs " << c_odo;
  EXPECT_LT(absoluteTrajectoryError(cho, syn.ground_truth).rmse,
            absoluteTrajectoryError(odo, syn.ground_truth).rmse);
}

TEST(Optimizer, SolutionIsALocalMinimumOfG2oChi2) {
  for (int dim : {2, 3}) {
    auto syn = makeSyntheticGraph(dim == 3 ? sphereSpec(0.05, 0.02) : gridSpec(0.05, 0.02));
    PoseGraph g = syn.graph;
    const Summary s = optimizeGraph(g, Options{});
    EXPECT_TRUE(s.converged) << s.message;
    EXPECT_NEAR(s.final_chi2, chi2(g), 1e-9 * s.final_chi2);
    EXPECT_LT(s.final_chi2, s.init_chi2);
    // With Ω matching the noise, χ² at the optimum ≈ (#residuals − #unknowns).
    const double dof =
        double(g.numEdges() * (dim == 3 ? 6 : 3)) - double((g.numNodes() - 1) * (dim == 3 ? 6 : 3));
    EXPECT_GT(s.final_chi2, 0.5 * dof);
    EXPECT_LT(s.final_chi2, 1.5 * dof);
    // No small move of any node lowers g2o's χ².
    std::mt19937_64 rng(9);
    std::normal_distribution<double> n(0, 1);
    const double base = chi2(g);
    for (NodeId id : {NodeId(5), NodeId(40), NodeId(100)}) {
      for (int trial = 0; trial < 6; ++trial) {
        PoseGraph p = g;
        if (dim == 3) {
          auto& T = p.nodes3.at(id).T_world_node;
          T.t += 1e-4 * Eigen::Vector3d(n(rng), n(rng), n(rng));
          T.q = (Eigen::Quaterniond(expSO3(1e-4 * Eigen::Vector3d(n(rng), n(rng), n(rng)))) * T.q)
                    .normalized();
        } else {
          auto& T = p.nodes2.at(id).T_world_node;
          T.x += 1e-4 * n(rng);
          T.y += 1e-4 * n(rng);
          T.theta += 1e-4 * n(rng);
        }
        EXPECT_GE(chi2(p), base - 1e-7 * base) << dim << "D node " << id;
      }
    }
  }
}

TEST(Optimizer, GaugeKeepsFixedNodes) {
  auto syn = makeSyntheticGraph(sphereSpec(0.05, 0.02));
  PoseGraph g = syn.graph;
  g.fixed = {3};
  const Pose3 before3 = g.nodes3.at(3).T_world_node;
  const Pose3 before0 = g.nodes3.at(0).T_world_node;
  Options o;
  o.init = InitMethod::File;
  o.fixed = {7};
  const Pose3 before7 = g.nodes3.at(7).T_world_node;
  optimizeGraph(g, o);
  EXPECT_LT((g.nodes3.at(3).T_world_node.t - before3.t).norm(), 1e-12);
  EXPECT_LT((g.nodes3.at(7).T_world_node.t - before7.t).norm(), 1e-12);
  EXPECT_GT((g.nodes3.at(0).T_world_node.t - before0.t).norm(), 1e-6);  // not fixed any more
}

TEST(Optimizer, DisconnectedComponentsAreEachAnchored) {
  PoseGraph g;
  g.dimension = 2;
  for (NodeId i = 0; i < 6; ++i) g.nodes2[i] = Node2{i, Pose2(double(i), 0.1 * double(i), 0)};
  for (NodeId i : {0, 1, 3, 4}) {
    Edge2 e;
    e.from = i;
    e.to = i + 1;
    e.T_from_to = Pose2(1, 0, 0);
    g.edges2.push_back(e);
  }
  const Summary s = optimizeGraph(g, Options{});
  EXPECT_TRUE(s.usable) << s.message;
  EXPECT_NEAR(s.final_chi2, 0.0, 1e-12);
  EXPECT_EQ(s.num_fixed, 2u);
}

TEST(Optimizer, IncrementalMatchesBatch) {
  auto syn = makeSyntheticGraph(gridSpec(0.05, 0.02, 4));
  PoseGraph batch = syn.graph;
  Options o;
  o.init = InitMethod::File;
  const Summary sb = optimizeGraph(batch, o);

  // Feed nodes in id order with the odometry guess from the current estimate, edges as soon as
  // both ends exist, re-optimising every 50 nodes (as the mapping app does).
  Optimizer inc(o);
  const auto& G = syn.graph;
  std::size_t next_edge = 0;
  std::vector<const Edge2*> pending;
  for (const auto& e : G.edges2) pending.push_back(&e);
  for (const auto& [id, n] : G.nodes2) {
    if (id == 0)
      inc.addNode(id, n.T_world_node);
    else {
      const Edge2* odo = nullptr;
      for (const auto& e : G.edges2)
        if (e.to == id && e.from == id - 1) odo = &e;
      ASSERT_NE(odo, nullptr);
      inc.addNode(id, inc.pose2(id - 1) * odo->T_from_to);
    }
    for (auto it = pending.begin(); it != pending.end();) {
      if (inc.graph().hasNode((*it)->from) && inc.graph().hasNode((*it)->to)) {
        inc.addEdge(**it);
        it = pending.erase(it);
        ++next_edge;
      } else {
        ++it;
      }
    }
    if (id % 50 == 49) inc.optimize();
  }
  const Summary si = inc.optimize();
  EXPECT_EQ(next_edge, G.edges2.size());
  EXPECT_NEAR(si.final_chi2, sb.final_chi2, 1e-6 * sb.final_chi2);
  EXPECT_LT(absoluteTrajectoryError(inc.graph(), batch).rmse, 1e-4);
}

TEST(Optimizer, SetPoseMovesAPieceTheRobustLossWouldNotReach) {
  // Node 0 fixed, 0 -> 1 a strong odometry edge, 1 -> 2 a weak bridge (sigma 1 m, 5 deg), then a
  // strong loop 0 -> 2 that puts node 2 40 m from where the chain has it. With the DCS loss a
  // residual of 40 m at the start switches the loop off; moved there with setPose first, the
  // solve starts at the loop's answer and the weak bridge takes the correction.
  auto edge = [](NodeId from, NodeId to, const Eigen::Vector3d& t, double sigma_t, double sigma_r,
                 bool loop) {
    Edge3 e;
    e.from = from;
    e.to = to;
    e.T_from_to = Pose3(t, Eigen::Quaterniond::Identity());
    Vector6d d;
    d << 1 / (sigma_t * sigma_t), 1 / (sigma_t * sigma_t), 1 / (sigma_t * sigma_t),
        1 / (sigma_r * sigma_r), 1 / (sigma_r * sigma_r), 1 / (sigma_r * sigma_r);
    e.information = d.asDiagonal();
    e.is_loop = loop;
    if (loop) e.loss = EdgeLoss{LossKind::Dcs, 1000.0};
    return e;
  };
  auto run = [&](bool set_pose) {
    Options o;
    o.init = InitMethod::File;
    Optimizer opt(o);
    const Isometry3d I = Isometry3d::Identity();
    opt.addNode(0, I);
    opt.addNode(1, Isometry3d(Eigen::Translation3d(1, 0, 0)));
    opt.addNode(2, Isometry3d(Eigen::Translation3d(2, 0, 0)));
    opt.setFixed(0);
    opt.addEdge(edge(0, 1, {1, 0, 0}, 0.01, 0.001, false));
    opt.addEdge(edge(1, 2, {1, 0, 0}, 1.0, 5.0 * kDegToRad, false));
    opt.optimize();
    opt.addEdge(edge(0, 2, {42, 0, 0}, 0.02, 0.001, true));
    if (set_pose) {
      opt.setPose(2, Isometry3d(Eigen::Translation3d(42, 0, 0)));
      EXPECT_NEAR(opt.pose(2).translation().x(), 42.0, 1e-12);
    }
    opt.optimize();
    return opt.pose(2).translation().x();
  };
  EXPECT_NEAR(run(true), 42.0, 0.05);  // the bridge pulls back 40 m · 0.02² / 1² = 0.016 m
  EXPECT_LT(run(false), 10.0);
  Optimizer empty;
  empty.addNode(0, Isometry3d::Identity());
  EXPECT_THROW(empty.setPose(7, Isometry3d::Identity()), ContractError);
}

TEST(Optimizer, RobustModeRejectsWrongLoops) {
  for (int dim : {2, 3}) {
    auto syn =
        makeSyntheticGraph(dim == 3 ? sphereSpec(0.05, 0.01, 2) : gridSpec(0.05, 0.01, 2, 1500));
    PoseGraph clean = syn.graph;
    optimizeGraph(clean, Options{});
    const double ate_clean = absoluteTrajectoryError(clean, syn.ground_truth).rmse;

    PoseGraph bad = syn.graph;
    const std::size_t n_wrong = injectWrongLoops(bad, 0.1, 77);
    ASSERT_GT(n_wrong, 3u);
    PoseGraph plain = bad, robust = bad;
    optimizeGraph(plain, Options{});
    Options ro;
    // Φ at the 99 % quantile of the χ² of a correct edge (calibrated noise: χ²(6) resp. χ²(3)).
    ro.loop_loss = parseLoss(dim == 3 ? "dcs:16.8" : "dcs:11.3");
    const Summary s = optimizeGraph(robust, ro);
    EXPECT_TRUE(s.usable);
    const double ate_plain = absoluteTrajectoryError(plain, syn.ground_truth).rmse;
    const double ate_robust = absoluteTrajectoryError(robust, syn.ground_truth).rmse;
    EXPECT_LT(ate_robust, 2.0 * ate_clean)
        << dim << "D clean " << ate_clean << " robust " << ate_robust;
    EXPECT_GT(ate_plain, 2.0 * ate_clean) << dim << "D plain " << ate_plain;
  }
}

TEST(Optimizer, AutoDcsCalibratesPhiOnMisScaledInformation) {
  // The information matrices understate the precision 10⁴-fold (as parking-garage's do): a
  // correct edge's χ² is ~10⁻⁴·dof, so Φ = χ²_0.99(dof) lets every wrong loop through with full
  // weight, while dcs:auto measures the scale on the residuals and rejects them.
  for (int dim : {2, 3}) {
    auto syn =
        makeSyntheticGraph(dim == 3 ? sphereSpec(0.05, 0.01, 2) : gridSpec(0.05, 0.01, 2, 1500));
    auto scaleInformation = [](PoseGraph& g) {
      for (auto& e : g.edges3) e.information *= 1e-4;
      for (auto& e : g.edges2) e.information *= 1e-4;
    };
    scaleInformation(syn.graph);
    PoseGraph clean = syn.graph;
    optimizeGraph(clean, Options{});
    const double ate_clean = absoluteTrajectoryError(clean, syn.ground_truth).rmse;

    PoseGraph bad = syn.graph;
    ASSERT_GT(injectWrongLoops(bad, 0.1, 77), 3u);
    PoseGraph fixed_phi = bad, auto_phi = bad;
    Options fo;
    fo.loop_loss = parseLoss(dim == 3 ? "dcs:16.8" : "dcs:11.3");
    optimizeGraph(fixed_phi, fo);
    Options ao;
    ao.loop_loss = parseLoss("dcs:auto");
    EXPECT_EQ(toString(ao.loop_loss), "dcs:auto");
    const Summary s = optimizeGraph(auto_phi, ao);
    EXPECT_TRUE(s.usable);
    // The calibrated Φ is of the order of the scaled χ² quantile (10⁻⁴·16.8 resp. 10⁻⁴·11.3).
    EXPECT_GT(s.dcs_phi, 1e-5) << dim << "D";
    EXPECT_LT(s.dcs_phi, 1e-2) << dim << "D";
    const double ate_fixed = absoluteTrajectoryError(fixed_phi, syn.ground_truth).rmse;
    const double ate_auto = absoluteTrajectoryError(auto_phi, syn.ground_truth).rmse;
    EXPECT_LT(ate_auto, 2.0 * ate_clean) << dim << "D clean " << ate_clean << " auto " << ate_auto;
    EXPECT_GT(ate_fixed, 2.0 * ate_clean) << dim << "D fixed-Φ " << ate_fixed;
  }
}

TEST(Optimizer, OptionsLoadFromYaml) {
  const auto node = ConfigNode::fromString(
      "init: spanning\nmax_iterations: 7\nnum_threads: 1\nloop_loss: cauchy:2.5\nfixed: [3, 4]\n",
      "graph.yaml");
  const Options o = Options::load(node);
  EXPECT_EQ(o.init, InitMethod::Spanning);
  EXPECT_EQ(o.max_iterations, 7);
  EXPECT_EQ(o.loop_loss.kind, LossKind::Cauchy);
  EXPECT_EQ(o.loop_loss.scale, 2.5);
  EXPECT_EQ(o.fixed, (std::vector<NodeId>{3, 4}));
  EXPECT_THROW(Options::load(ConfigNode::fromString("loop_loss: bogus\n", "g.yaml")), ConfigError);
  EXPECT_THROW(Options::load(ConfigNode::fromString("max_iteration: 3\n", "g.yaml")), ConfigError);
  EXPECT_THROW(parseLoss("huber:-1"), ConfigError);
  EXPECT_EQ(Options::load(ConfigNode::fromString("robust_init: odometry\n", "g.yaml")).robust_init,
            Options::RobustInit::Odometry);
  EXPECT_EQ(Options::load(ConfigNode::fromString("sparse_library: suite_sparse\n", "g.yaml"))
                .sparse_library,
            Options::SparseLibrary::SuiteSparse);
  EXPECT_THROW(Options::load(ConfigNode::fromString("robust_init: maybe\n", "g.yaml")),
               ConfigError);
  // The shipped config file loads.
  // Every sparse library gives the same solution.
  auto syn = makeSyntheticGraph(gridSpec(0.05, 0.02, 6));
  double reference = -1;
  for (auto lib : {Options::SparseLibrary::Auto, Options::SparseLibrary::SuiteSparse,
                   Options::SparseLibrary::CxSparse, Options::SparseLibrary::EigenSparse}) {
    PoseGraph g = syn.graph;
    Options lo;
    lo.sparse_library = lib;
    const Summary s = optimizeGraph(g, lo);
    if (reference < 0) reference = s.final_chi2;
    EXPECT_NEAR(s.final_chi2, reference, 1e-7 * reference);
  }
  const Options shipped = Options::load(
      ConfigNode::loadFile(obm::test::sourceDir() + "/config/graph.yaml").child("optimizer"));
  EXPECT_EQ(shipped.init, InitMethod::Chordal);
}

namespace {

/// A ring of `n` poses on a circle of radius 10 whose odometry overstates every turn by
/// `bias_deg` (so the chain does not close), and 5 loop edges across the closing gap
/// (node n−1−k → node k) that are exact (`wrong_loops` = false) or random.
PoseGraph biasedRing(int n, double bias_deg, bool wrong_loops) {
  PoseGraph g;
  g.dimension = 2;
  std::vector<Pose2> truth;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    truth.emplace_back(10.0 * std::cos(a), 10.0 * std::sin(a), a + M_PI / 2);
  }
  const Eigen::Matrix3d info = Eigen::Vector3d(100.0, 100.0, 1e4).asDiagonal();
  Pose2 chain = truth[0];
  for (int i = 0; i < n; ++i) {
    g.nodes2[i] = Node2{i, chain};
    if (i + 1 == n) break;
    Pose2 z = truth[i].inverse() * truth[i + 1];
    z.theta += bias_deg * M_PI / 180.0;
    g.edges2.push_back(Edge2{i, i + 1, z, info, {}, false});
    chain = chain * z;
  }
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 5; ++k) {
    const int a = n - 1 - k, b = k;
    Pose2 z = truth[a].inverse() * truth[b];
    if (wrong_loops) z = Pose2(8.0 * u(rng), 8.0 * u(rng), M_PI * u(rng));
    g.edges2.push_back(Edge2{a, b, z, info, {}, true});
  }
  g.fixed.insert(0);
  return g;
}

std::size_t activeLoops(const PoseGraph& g, double phi) {
  std::size_t on = 0;
  for (const auto& e : g.edges2) on += e.is_loop && edgeChi2(g, e) <= 3.0 * phi ? 1 : 0;
  return on;
}

}  // namespace

// The robust mode assumes most loops are right. Here Φ is small against the odometry's 0.5° bias
// per step, so the odometry start's solution — every loop switched off, the chain fitting exactly
// (objective ≈ 15 here) — has a lower DCS objective than the chordal starts' solution that closes
// the loops (≈ 29); the starts that keep the loops must still win.
TEST(RobustStarts, AStartThatSwitchesMostLoopsOffLosesToOneThatKeepsThem) {
  const double phi = 1.0;
  const PoseGraph ring = biasedRing(40, 0.5, false);
  Options opt;
  opt.loop_loss = EdgeLoss{LossKind::Dcs, phi};
  opt.robust_init = Options::RobustInit::Best;
  Optimizer best(ring, opt);
  const auto s = best.optimize();
  ASSERT_TRUE(s.usable);
  EXPECT_GE(activeLoops(best.graph(), phi), 3u) << s.message;

  // The odometry start alone: its solution switches the loops off and has the lower objective,
  // which is why the objective alone must not decide.
  opt.robust_init = Options::RobustInit::Odometry;
  Optimizer odo(ring, opt);
  ASSERT_TRUE(odo.optimize().usable);
  EXPECT_LE(activeLoops(odo.graph(), phi), 2u);
}

// When every start switches the loops off (they are all wrong), the lowest objective decides:
// the odometry chain, untouched by the wrong loops.
TEST(RobustStarts, WhenNoStartKeepsMostLoopsTheLowestObjectiveWins) {
  const double phi = 1.0;
  const PoseGraph ring = biasedRing(40, 1.5, true);
  Options opt;
  opt.loop_loss = EdgeLoss{LossKind::Dcs, phi};
  Optimizer best(ring, opt);
  const auto s = best.optimize();
  ASSERT_TRUE(s.usable);
  EXPECT_EQ(activeLoops(best.graph(), phi), 0u) << s.message;
  double worst = 0.0;  // distance from the odometry chain (the file's poses)
  for (const auto& [id, n] : best.graph().nodes2) {
    const auto& o = ring.nodes2.at(id).T_world_node;
    worst = std::max(worst, std::hypot(n.T_world_node.x - o.x, n.T_world_node.y - o.y));
  }
  EXPECT_LT(worst, 0.05) << s.message;
}
