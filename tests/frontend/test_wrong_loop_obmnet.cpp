// A wrong loop candidate of the LiDAR network matcher, as its own confidence weighs it, against
// the robust pose-graph back-end (docs/obm-map.md, "Confidence: the information of each edge"):
// a sweep of another place registered against the first sweep of a real KITTI drive is claimed
// as a loop between the drive's first and last node. The edge carries the information the
// front-end would give it (Ω of the match, floored); with the loop loss of map_kitti.yaml
// (DCS, Φ = 1000) the graph keeps the odometry, with plain least squares the edge drags it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "edge_information.hpp"
#include "lidar_settings.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/backend/pose_graph.hpp"
#include "obm/frontend/params.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/point_cloud_io.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/obmnet_matcher.hpp"
#include "test_data.hpp"

namespace obm::frontend {
namespace {

TEST(FrontendObmNet, AWrongLoopOfTheNetworkMatcherIsSwitchedOffByTheRobustBackEnd) {
  OBM_REQUIRE_SHARED_DATA("kitti/raw_drive_22/velodyne/000010.bin");
  OBM_REQUIRE_SHARED_DATA("real_pairs/lidar_small_gicp/source.ply");
  const std::string d = test::sharedDataDir() + "/kitti/raw_drive_22/velodyne/";
  constexpr int kNodes = 11;  // sweeps 0..10, ~8 m of street
  std::vector<PointCloud> sweeps;
  for (int i = 0; i < kNodes; ++i)
    sweeps.push_back(test::lidarCloud(io::readKittiVelodyne(d + io::kittiScanFileName(i))));

  const registration::IcpParams icp = test::lidarIcp();
  const registration::ConfidenceParams conf = test::lidarConfidence();
  const registration::IcpMatcher odometry(icp, conf);
  Isometry3d step = Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0.8, 0.0, 0.0);

  // The odometry chain: nodes at the chained ICP poses, edges with the tracking's information.
  backend::PoseGraph graph;
  Isometry3d T_world_node = Isometry3d::Identity();
  graph.nodes3[0] = {0, backend::Pose3::fromIsometry(T_world_node)};
  const TrackingParams tracking;
  for (int i = 1; i < kNodes; ++i) {
    const registration::MatchResult r = odometry.match(sweeps[i], sweeps[i - 1], step);
    ASSERT_GT(r.inlier_ratio, 0.7) << "odometry " << i << " -> " << i - 1;
    T_world_node = T_world_node * r.T_target_source;
    graph.nodes3[i] = {i, backend::Pose3::fromIsometry(T_world_node)};
    backend::Edge3 e;
    e.from = i - 1;
    e.to = i;
    e.T_from_to = backend::Pose3::fromIsometry(r.T_target_source);
    e.information = odometryEdgeInformation(tracking, &r, false);
    graph.edges3.push_back(e);
  }
  graph.fixed.insert(0);
  const Isometry3d T_0_last = T_world_node;

  // The wrong candidate: a sweep of another place registered against sweep 0 by the network +
  // ICP matcher with the small LiDAR model, from the identity (as a loop candidate comes).
  registration::ObmNetMatcherParams net;
  net.network.model_path = obm::test::modelsDir() + "obmnet_lidar_small.pt";
  net.network.threads = 1;
  net.pre_align = false;
  net.keep_init_if_better = false;
  const registration::ObmNetIcpMatcher matcher(net, icp, conf);
  const PointCloud elsewhere = test::lidarCloud(io::readPointCloud(
      test::sharedDataDir() + "/real_pairs/lidar_small_gicp/source.ply"));
  const registration::MatchResult wrong = matcher.match(elsewhere, sweeps[0]);
  const LoopClosureParams loops;
  backend::Edge3 loop;
  loop.from = 0;
  loop.to = kNodes - 1;
  loop.T_from_to = backend::Pose3::fromIsometry(wrong.T_target_source);
  loop.information = loopEdgeInformation(loops, wrong);
  loop.is_loop = true;
  graph.edges3.push_back(loop);
  const double claimed_error =
      (wrong.T_target_source.translation() - T_0_last.translation()).norm();
  std::printf("wrong loop: quality %.3f, inlier ratio %.3f, information (t) %.0f %.0f %.0f; it "
              "claims node %d %.2f m from where the odometry puts it\n",
              wrong.quality, wrong.inlier_ratio, loop.information(0, 0), loop.information(1, 1),
              loop.information(2, 2), kNodes - 1, claimed_error);
  ASSERT_GT(claimed_error, 2.0) << "the candidate must be wrong for this test to mean anything";
  // The right loop between the same nodes, started from the odometry as the front-end starts a
  // candidate's verification: its confidence gives it more information than the wrong one's.
  const registration::MatchResult right = matcher.match(sweeps[kNodes - 1], sweeps[0], T_0_last);
  const Matrix6d right_information = loopEdgeInformation(loops, right);
  const double right_t = right_information.topLeftCorner<3, 3>().trace();
  const double wrong_t = loop.information.topLeftCorner<3, 3>().trace();
  std::printf("right loop: quality %.3f, inlier ratio %.3f, %.3f m from the odometry, information "
              "(t) %.0f %.0f %.0f\n",
              right.quality, right.inlier_ratio,
              (right.T_target_source.translation() - T_0_last.translation()).norm(),
              right_information(0, 0), right_information(1, 1), right_information(2, 2));
  EXPECT_GT(right.quality, wrong.quality);
  EXPECT_GT(right_t, 2.0 * wrong_t) << "the wrong loop's confidence must weigh it less";

  auto solveAndDrift = [&](const backend::EdgeLoss& loss) {
    backend::PoseGraph g = graph;
    backend::Options o;
    o.init = backend::InitMethod::File;
    o.num_threads = 1;
    o.loop_loss = loss;
    backend::optimizeGraph(g, o);
    double drift = 0.0;  // the largest move of a node from the odometry's pose
    for (const auto& [id, node] : g.nodes3)
      drift = std::max(drift, (node.T_world_node.t - graph.nodes3.at(id).T_world_node.t).norm());
    return drift;
  };
  const double robust = solveAndDrift(loops.loss);
  const double plain = solveAndDrift({backend::LossKind::None, 1.0});
  std::printf("largest node move: robust loss (%s) %.4f m, least squares %.3f m\n",
              backend::toString(loops.loss).c_str(), robust, plain);
  EXPECT_LT(robust, 0.05) << "the robust back-end must switch the wrong loop off";
  EXPECT_GT(plain, 0.5) << "without it the wrong loop drags the graph (else the test is void)";
}

}  // namespace
}  // namespace obm::frontend
