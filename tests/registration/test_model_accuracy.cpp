// The shipped models judged on pairs of their own kind that share no sample, with the network's
// own pose checked as well as the pose after ICP. A model that stops registering its data fails
// here. The pairs are few so that the test stays fast. Each shipped model is told from an
// untrained network of its shape by at least one of them (scripts/check_models_matter.sh), and
// each bound is set from the measured value with the margin its comment states.
//  - objects (obmnet_objects.pt, obmnet_objects_noise.pt): partial and jittered pairs of the
//    unseen CGAL objects, the networks alone;
//  - indoor (obmnet_indoor.pt, obm-map's): pairs of its own protocol made from real RGB-D frames,
//    the network alone;
//  - LiDAR (obmnet_lidar_small.pt, the lidar preset's and obm-map's): the real outdoor scan pair
//    of the shared data, as given and turned by 120°;
//  - LiDAR (obmnet_lidar_small.pt): the real outdoor pair turned every 45° about z, with every yaw
//    hypothesis refined and blind headings (loop candidates without a heading prior);
//  - LiDAR (obmnet_lidar_small.pt): real KITTI sweeps five apart (~4 m), against the chain of
//    consecutive ICP registrations (the sweeps have no ground truth);
//  - LiDAR (obmnet_lidar_small.pt): real KITTI sweeps ten apart (~8 m), the network's
//    correspondences given to RANSAC against its weighted SVD;
//  - LiDAR (obmnet_lidar_small.pt): real KITTI sweeps ten apart, the start's heading preferred and
//    a consensus floor (the start kept between sweeps of different places);
//  - LiDAR (obmnet_lidar_small.pt): simulated sweeps 20 apart and revisits of the benchmark drive,
//    the yaw hypotheses ranked by their RANSAC consensus against their fitness;
//  - indoor (obmnet_indoor.pt): pairs of different real RGB-D frames (Open3D's five);
//  - indoor (obmnet_indoor_frames.pt, trained on frame pairs with a spatial prior): the same
//    pairs moved, and unmoved against obmnet_indoor.pt's, the networks alone;
//  - objects (obmnet_objects_normals.pt): noisy crops of low overlap, the matcher with starts from
//    a search over every rotation against without.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <vector>

#include "obm/core/cloud_ops.hpp"
#include "obm/datasets/fragment_source.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/io/point_cloud_io.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/obmnet/data.hpp"
#include "obm/obmnet/object_set.hpp"
#include "obm/obmnet/registrar.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/obmnet_matcher.hpp"
#include "obm/sim/lidar.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/simulator.hpp"
#include "lidar_settings.hpp"
#include "scenes.hpp"
#include "seed_five_drive.hpp"
#include "test_data.hpp"

namespace obm {
namespace {

const std::string kModels = obm::test::modelsDir();
constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

double rreDeg(const Isometry3d& T, const Isometry3d& gt) {
  return Eigen::AngleAxisd(T.linear().transpose() * gt.linear()).angle() * kDegPerRad;
}
double rte(const Isometry3d& T, const Isometry3d& gt) {
  return (T.translation() - gt.translation()).norm();
}

registration::ObmNetMatcherParams netParams(const std::string& model) {
  registration::ObmNetMatcherParams p;
  p.network.model_path = model;
  p.network.threads = 1;
  p.pre_align = false;
  p.keep_init_if_better = false;
  return p;
}

using test::lidarCloud;
using test::lidarConfidence;
using test::lidarIcp;

/// The real outdoor LiDAR pair of the shared data (`real_pairs/lidar_small_gicp`) as the LiDAR
/// models see it, with its reference pose T_target_source.
struct RealPair {
  Isometry3d gt;
  PointCloud source, target;
};
RealPair realOutdoorPair() {
  const std::string d = test::sharedDataDir() + "/real_pairs/lidar_small_gicp/";
  return {test::readMatrix4(d + "T_target_source.txt"),
          lidarCloud(io::readPointCloud(d + "source.ply")),
          lidarCloud(io::readPointCloud(d + "target.ply"))};
}

}  // namespace

namespace {

/// Rotation errors [deg] of an object model alone (no ICP) and of the identity on the same eight
/// `resampled` pairs of unseen objects (independent samplings, 768-point crops, ≤ 45°), printed
/// per pair. Empty when the meshes are not at hand ($OBM_CGAL_DATA unset).
struct ObjectErrors {
  std::vector<double> network, identity;
};
/// The object set of the CGAL meshes (nullopt when $OBM_CGAL_DATA is unset), `keep_points`
/// surface samples per object.
std::optional<obmnet::ObjectSet> cgalObjectSet(int keep_points) {
  const char* env = std::getenv("OBM_CGAL_DATA");
  if (env == nullptr) return std::nullopt;
  std::vector<TriangleMesh> meshes;
  for (const auto& e : std::filesystem::directory_iterator(env))
    if (e.path().extension() == ".off") {
      meshes.push_back(io::readMesh(e.path().string()));
      meshes.back().name = e.path().stem().string();
    }
  std::sort(meshes.begin(), meshes.end(),
            [](const TriangleMesh& a, const TriangleMesh& b) { return a.name < b.name; });
  obmnet::ObjectSetOptions o;
  o.keep_points = keep_points;
  return obmnet::buildObjectSet(meshes, o);
}

/// The model alone on eight pairs of the unseen objects made by `protocol` (first object first),
/// from `keep_points` samples per object (2048 for `resampled`: disjoint halves; 1024 for the
/// shared-sample protocols, as obm-bench), the network fed `num_points` per cloud (0: the model's).
ObjectErrors objectModelOnUnseenPairs(const std::string& model,
                                      const std::string& protocol = "resampled",
                                      int keep_points = 2048, int num_points = 768) {
  const auto objects = cgalObjectSet(keep_points);
  if (!objects) return {};
  const auto& set = *objects;
  EXPECT_GE(set.test.size(), 8u);
  if (set.test.size() < 8u) return {};
  const auto proto = obmnet::PairProtocol::preset(protocol);
  std::mt19937_64 rng(1);
  obmnet::ObmNetRegistrar::Options ro;
  ro.model_path = model;
  ro.threads = 1;
  ro.num_points = num_points;
  const obmnet::ObmNetRegistrar net(ro);
  ObjectErrors e;
  for (int i = 0; i < 8; ++i) {
    const auto& object = set.test[static_cast<std::size_t>(i)];
    const auto pair = obmnet::makePair(object, proto, rng);
    const auto r = net.align(pair.source, pair.target);
    e.network.push_back(rreDeg(r.T_target_source, pair.T_target_source));
    e.identity.push_back(rreDeg(Isometry3d::Identity(), pair.T_target_source));
    std::printf("%s: network RRE %.2f deg, RTE %.3f; identity RRE %.2f deg\n",
                object.frame_id.c_str(), e.network.back(),
                rte(r.T_target_source, pair.T_target_source), e.identity.back());
  }
  return e;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

void printMedians(const ObjectErrors& e) {
  std::printf("median RRE: network %.2f deg, identity %.2f deg\n", median(e.network),
              median(e.identity));
}

}  // namespace

TEST(ModelAccuracy, ObjectModelOnPartialPairsOfUnseenObjects) {
  // obm-bench's default object model (obmnet_objects.pt, the demo of scripts/run.sh) alone on
  // RIENet's `partial` pairs (768 of 1024 shared samples per cloud, turned up to 45°) of the
  // unseen objects. Measured (median RRE of eight): the shipped model 1.99°; an untrained network
  // of the same shape (tests/untrained_like, seed 7) 71.1°; not moving 49.2°. Bound 3.5° (1.8×).
  OBM_REQUIRE_CGAL_DATA();
  const auto e = objectModelOnUnseenPairs(kModels + "obmnet_objects.pt", "partial", 1024, 0);
  ASSERT_FALSE(e.network.empty());
  printMedians(e);
  EXPECT_LT(median(e.network), 3.5) << "median network RRE [deg]";
}

TEST(ModelAccuracy, NoiseModelOnJitteredPairsOfUnseenObjects) {
  // obm-bench's model for the noisy protocols (obmnet_objects_noise.pt) alone on `jitter` pairs
  // (shared samples with Gaussian jitter) of the unseen objects. Measured (median RRE of eight):
  // the shipped model 1.25°; an untrained network of the same shape (tests/untrained_like, seed 7)
  // 31.1°; not moving 44.7°. Bound 2.5° (2×).
  OBM_REQUIRE_CGAL_DATA();
  const auto e = objectModelOnUnseenPairs(kModels + "obmnet_objects_noise.pt", "jitter", 1024, 0);
  ASSERT_FALSE(e.network.empty());
  printMedians(e);
  EXPECT_LT(median(e.network), 2.5) << "median network RRE [deg]";
}

TEST(ModelAccuracy, EdgeNormalsModelOnIndependentSamplingsOfUnseenObjects) {
  OBM_REQUIRE_CGAL_DATA();
  const auto e = objectModelOnUnseenPairs(kModels + "obmnet_objects_normals.pt");
  ASSERT_FALSE(e.network.empty());
  // Measured with the shipped model (epoch 7; the objects_resampled preset's): median 18.6°
  // against the identity's 47.4° (0.39×; the earlier obmnet_objects_resampled.pt: 22.6°, 0.48×),
  // three of the eight pairs within 10° by the network alone (1.1°, 4.0°, 4.3°; the earlier
  // model: one).
  int close = 0;
  for (double r : e.network) close += r < 10.0 ? 1 : 0;
  EXPECT_LT(median(e.network), 0.5 * median(e.identity))
      << "median network RRE " << median(e.network) << "°, identity " << median(e.identity) << "°";
  EXPECT_GE(close, 3) << "pairs the network alone brings within 10°";
}

TEST(ModelAccuracy, SearchOverEveryRotationRegistersLowOverlapObjectPairs) {
  // partial_noise pairs (shared samples, σ = 0.01, crops) of the unseen objects below 0.6
  // overlap, where the network's start is what is missing (docs/benchmarks.md, "Every rotation
  // for objects"): the matcher of obm-bench's obmnet+icp, then with 32 poses (25° apart) of a
  // search over every rotation (±90° in steps of 7.5°, ±0.3 around the centroids) chosen on the
  // target's tangent planes at 1 cm.
  OBM_REQUIRE_CGAL_DATA();
  const auto objects = cgalObjectSet(1024);
  ASSERT_TRUE(objects.has_value());
  const auto proto = obmnet::PairProtocol::preset("partial_noise");
  std::mt19937_64 rng(1);
  std::vector<obmnet::RegistrationPair> pairs;
  std::vector<std::string> names;
  for (std::size_t i = 0; pairs.size() < 8 && i < 10 * objects->test.size(); ++i) {
    const auto& object = objects->test[i % objects->test.size()];
    auto pair = obmnet::makePair(object, proto, rng);
    if (pair.overlap >= 0.6) continue;
    pairs.push_back(std::move(pair));
    names.push_back(object.frame_id);
  }
  ASSERT_EQ(pairs.size(), 8u);
  // obm-bench's refinement of the unit-sphere objects, with its polish of shared-sample pairs.
  registration::IcpParams icp = test::unitObjectIcp();
  icp.polish_max_correspondence_distance = 0.05;
  registration::ConfidenceParams conf;
  conf.inlier_threshold = 0.05;
  conf.min_sigma = 0.001;
  auto p = netParams(kModels + "obmnet_objects_normals.pt");
  p.overlap_stage_keep = 0.5;
  const registration::ObmNetIcpMatcher plain(p, icp, conf);
  p.search_candidates = 32;
  p.search = test::unitObjectSearch(7.5, 32);
  p.search.min_separation_deg = 25.0;
  p.choice_plane_distance = 0.01;
  const registration::ObmNetIcpMatcher searched(p, icp, conf);
  int ok_plain = 0, ok_search = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& pair = pairs[k];
    const auto a = plain.match(pair.source, pair.target, Isometry3d::Identity());
    const auto b = searched.match(pair.source, pair.target, Isometry3d::Identity());
    const bool oa = rreDeg(a.T_target_source, pair.T_target_source) < 1.0 &&
                    rte(a.T_target_source, pair.T_target_source) < 0.1;
    const bool ob = rreDeg(b.T_target_source, pair.T_target_source) < 1.0 &&
                    rte(b.T_target_source, pair.T_target_source) < 0.1;
    ok_plain += oa ? 1 : 0;
    ok_search += ob ? 1 : 0;
    std::printf("%s (overlap %.2f): RRE %.2f -> %.2f deg\n", names[k].c_str(), pair.overlap,
                rreDeg(a.T_target_source, pair.T_target_source),
                rreDeg(b.T_target_source, pair.T_target_source));
  }
  std::printf("registered (RRE < 1 deg, RTE < 0.1): %d -> %d of 8\n", ok_plain, ok_search);
  // Measured: 2 -> 5 of 8 (blobby_3cc, elk, homer gained; cylinder, whose turns about its own
  // axis fit alike, itemb and knot lost by both).
  EXPECT_GE(ok_search, ok_plain + 2);
  EXPECT_GE(ok_search, 5);
}

TEST(ModelAccuracy, LidarModelOnTheRealOutdoorPair) {
  // The lidar preset's model (obmnet_lidar_small.pt) and its ICP on the real outdoor pair (0.5 m
  // apart), as given and with the source turned by 120° about z. Measured: the network alone
  // 8.24° / 1.81 m and 2.86° / 2.53 m (not moving: 0.7° / 0.50 m and 120.7° / 0.50 m), with ICP
  // 0.161° / 0.007 m both. Its four yaw hypotheses find the heading, not the metres: an untrained
  // network of its shape (tests/untrained_like, seed 7) is as close here (3.77° / 2.41 m and
  // 1.61° / 1.91 m), so this pair checks the matcher, and the model is judged by the tests on
  // real sweeps below. Bounds: rotation 10° (the turned pair's identity fails), after ICP 1° /
  // 0.3 m.
  OBM_REQUIRE_SHARED_DATA("real_pairs/lidar_small_gicp/T_target_source.txt");
  const auto [gt, source, target] = realOutdoorPair();
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  const registration::ObmNetMatcher network(netParams(kModels + "obmnet_lidar_small.pt"), icp,
                                            conf);
  const registration::ObmNetIcpMatcher refined(netParams(kModels + "obmnet_lidar_small.pt"), icp,
                                               conf);
  // Both sweeps turned apart by 120° about z: the identity is no prior any more.
  Isometry3d turn = Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(120.0 / kDegPerRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const PointCloud turned = source.transformed(turn, "source_turned");
  const Isometry3d gt_turned = gt * turn.inverse();
  for (const auto& [cloud, truth] :
       {std::pair<const PointCloud*, Isometry3d>{&source, gt}, {&turned, gt_turned}}) {
    const registration::MatchResult a = network.match(*cloud, target);
    const registration::MatchResult b = refined.match(*cloud, target);
    std::printf("network RRE %.2f deg RTE %.2f m; +ICP RRE %.3f deg RTE %.3f m; identity RRE %.1f deg RTE %.2f m\n",
                rreDeg(a.T_target_source, truth), rte(a.T_target_source, truth),
                rreDeg(b.T_target_source, truth), rte(b.T_target_source, truth),
                rreDeg(Isometry3d::Identity(), truth), rte(Isometry3d::Identity(), truth));
    EXPECT_LT(rreDeg(a.T_target_source, truth), 10.0);
    EXPECT_LT(rreDeg(b.T_target_source, truth), 1.0);
    EXPECT_LT(rte(b.T_target_source, truth), 0.3);
  }
}

TEST(ModelAccuracy, SmallLidarModelAndBlindHeadingsRegisterTheRealPairFromAnyHeading) {
  // The real outdoor pair (0.5 m apart) with the source turned about z every 45°: a loop candidate
  // seen from any direction. Three ways to register it without a heading prior:
  //  - the network's four yaw hypotheses, each refined by ICP (refine_hypotheses: 0);
  //  - ICP from the four blind headings 0°, 90°, 180°, 270° (init_headings: 4, no network pose);
  //  - both competing (what a user sets for loop candidates; docs/registration.md).
  // Measured: the network's poses are a few metres off on this pair, so its hypotheses register
  // the turns off the 90° grid (135°, 225°, 315°) and the blind headings those on it; together
  // they register seven of the eight turns (45° is neither's). Asserted: the union registers at
  // least seven, and more than either alone.
  OBM_REQUIRE_SHARED_DATA("real_pairs/lidar_small_gicp/T_target_source.txt");
  const auto [gt, source, target] = realOutdoorPair();
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  registration::ObmNetMatcherParams p = netParams(kModels + "obmnet_lidar_small.pt");
  p.refine_hypotheses = 0;
  const registration::ObmNetIcpMatcher network(p, icp, conf);
  p.init_headings = 4;
  const registration::ObmNetIcpMatcher both(p, icp, conf);
  const registration::IcpMatcher plain(icp, conf);
  auto registered = [](const Isometry3d& T, const Isometry3d& truth) {
    return rreDeg(T, truth) < 1.0 && rte(T, truth) < 0.3;
  };
  int n_network = 0, n_blind = 0, n_both = 0;
  for (int step = 0; step < 8; ++step) {
    const double deg = 45.0 * step;
    Isometry3d turn = Isometry3d::Identity();
    turn.linear() =
        Eigen::AngleAxisd(deg / kDegPerRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const PointCloud turned = source.transformed(turn, "source_turned");
    const Isometry3d truth = gt * turn.inverse();
    const registration::MatchResult a = network.match(turned, target);
    const registration::MatchResult c = both.match(turned, target);
    // The blind headings alone: the inlier ratio chooses, as in the matcher.
    registration::MatchResult b;
    for (int h = 0; h < 4; ++h) {
      Isometry3d start = Isometry3d::Identity();
      start.linear() =
          Eigen::AngleAxisd(h * 90.0 / kDegPerRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const registration::MatchResult r = plain.match(turned, target, start);
      if (h == 0 || r.inlier_ratio > b.inlier_ratio) b = r;
    }
    std::printf(
        "turned %3.0f deg: network hypotheses + ICP RRE %6.3f deg RTE %6.3f m; blind "
        "headings RRE %6.3f deg RTE %6.3f m; both RRE %6.3f deg RTE %6.3f m\n",
        deg, rreDeg(a.T_target_source, truth), rte(a.T_target_source, truth),
        rreDeg(b.T_target_source, truth), rte(b.T_target_source, truth),
        rreDeg(c.T_target_source, truth), rte(c.T_target_source, truth));
    n_network += registered(a.T_target_source, truth);
    n_blind += registered(b.T_target_source, truth);
    n_both += registered(c.T_target_source, truth);
  }
  EXPECT_GE(n_both, 7) << "registered of 8 turns by the network's hypotheses and blind headings";
  EXPECT_GT(n_both, n_network) << "the blind headings must add to the network's hypotheses";
  EXPECT_GT(n_both, n_blind) << "the network's hypotheses must add to the blind headings";
}

TEST(ModelAccuracy, SmallLidarModelOnRealKittiSweepsFiveApart) {
  // Real HDL-64E sweeps of a city drive, 0.8 m apart: the pairs (i+5 -> i) are ~4 m apart, where
  // ICP from the identity stalls (docs/benchmarks.md, "Real KITTI sweeps"). The reference is the
  // chain of the five consecutive ICP registrations (each started 0.8 m ahead, within its basin).
  OBM_REQUIRE_SHARED_DATA("kitti/raw_drive_22/velodyne/000021.bin");
  const std::string d = test::sharedDataDir() + "/kitti/raw_drive_22/velodyne/";
  auto sweep = [&](std::size_t i) {
    return lidarCloud(io::readKittiVelodyne(d + io::kittiScanFileName(i)));
  };
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  const registration::IcpMatcher chain_icp(icp, conf);
  const std::string model = kModels + "obmnet_lidar_small.pt";
  const registration::ObmNetMatcher network(netParams(model), icp, conf);
  const registration::ObmNetIcpMatcher refined(netParams(model), icp, conf);
  Isometry3d step = Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0.8, 0.0, 0.0);
  double net_t = 0.0, identity_t = 0.0;
  int n = 0;
  for (const std::size_t i : {std::size_t{0}, std::size_t{8}, std::size_t{16}}) {
    Isometry3d reference = Isometry3d::Identity();  // T_i_(i+5)
    for (std::size_t j = i; j < i + 5; ++j) {
      const registration::MatchResult r = chain_icp.match(sweep(j + 1), sweep(j), step);
      ASSERT_GT(r.inlier_ratio, 0.7) << "chain " << j + 1 << " -> " << j;
      reference = reference * r.T_target_source;
    }
    const PointCloud source = sweep(i + 5), target = sweep(i);
    const registration::MatchResult a = network.match(source, target);
    const registration::MatchResult b = refined.match(source, target);
    const registration::MatchResult c = chain_icp.match(source, target);
    std::printf("sweeps %zu->%zu (%.2f m): network RRE %.2f deg RTE %.2f m; +ICP RRE %.3f deg RTE "
                "%.3f m; ICP from the identity RRE %.2f deg RTE %.2f m\n",
                i + 5, i, reference.translation().norm(), rreDeg(a.T_target_source, reference),
                rte(a.T_target_source, reference), rreDeg(b.T_target_source, reference),
                rte(b.T_target_source, reference), rreDeg(c.T_target_source, reference),
                rte(c.T_target_source, reference));
    EXPECT_LT(rreDeg(b.T_target_source, reference), 1.0) << "sweeps " << i + 5 << " -> " << i;
    EXPECT_LT(rte(b.T_target_source, reference), 0.3) << "sweeps " << i + 5 << " -> " << i;
    EXPECT_LT(rreDeg(a.T_target_source, reference), 10.0) << "sweeps " << i + 5 << " -> " << i;
    net_t += rte(a.T_target_source, reference);
    identity_t += reference.translation().norm();
    ++n;
  }
  // The network alone moves the source towards the target: closer than not moving.
  EXPECT_LT(net_t / n, identity_t / n) << "mean translation error of the network alone [m]";
}

TEST(ModelAccuracy, SmallLidarModelWithRansacOnRealKittiSweepsTenApart) {
  // Real sweeps ten apart (~8 m), where the weighted SVD is pulled off by the network's wrong
  // matches: its own correspondences given to RANSAC (ransac_iterations) must do better, alone and
  // before ICP. Reference: the chain of the ten consecutive ICP registrations, as above.
  OBM_REQUIRE_SHARED_DATA("kitti/raw_drive_22/velodyne/000021.bin");
  const std::string d = test::sharedDataDir() + "/kitti/raw_drive_22/velodyne/";
  auto sweep = [&](std::size_t i) {
    return lidarCloud(io::readKittiVelodyne(d + io::kittiScanFileName(i)));
  };
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  const registration::IcpMatcher chain_icp(icp, conf);
  const std::string model = kModels + "obmnet_lidar_small.pt";
  registration::ObmNetMatcherParams with = netParams(model);
  with.network.ransac_iterations = 5000;
  const registration::ObmNetMatcher svd_alone(netParams(model), icp, conf);
  const registration::ObmNetMatcher ransac_alone(with, icp, conf);
  const registration::ObmNetIcpMatcher svd_icp(netParams(model), icp, conf);
  const registration::ObmNetIcpMatcher ransac_icp(with, icp, conf);
  Isometry3d step = Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0.8, 0.0, 0.0);
  auto ok = [](const Isometry3d& T, const Isometry3d& ref) {
    return rreDeg(T, ref) < 1.0 && rte(T, ref) < 0.3;
  };
  double t_svd = 0.0, t_ransac = 0.0, t_identity = 0.0;
  int ok_svd = 0, ok_ransac = 0, n = 0;
  for (const std::size_t i : {std::size_t{0}, std::size_t{4}, std::size_t{7}, std::size_t{11}}) {
    Isometry3d reference = Isometry3d::Identity();  // T_i_(i+10)
    for (std::size_t j = i; j < i + 10; ++j) {
      const registration::MatchResult r = chain_icp.match(sweep(j + 1), sweep(j), step);
      ASSERT_GT(r.inlier_ratio, 0.7) << "chain " << j + 1 << " -> " << j;
      reference = reference * r.T_target_source;
    }
    const PointCloud source = sweep(i + 10), target = sweep(i);
    const Isometry3d a = svd_alone.match(source, target).T_target_source;
    const Isometry3d b = ransac_alone.match(source, target).T_target_source;
    const Isometry3d c = svd_icp.match(source, target).T_target_source;
    const Isometry3d e = ransac_icp.match(source, target).T_target_source;
    std::printf("sweeps %zu->%zu (%.2f m): network alone, SVD RRE %.2f deg RTE %.2f m, with RANSAC "
                "RRE %.2f deg RTE %.2f m; +ICP, SVD RRE %.3f deg RTE %.3f m, with RANSAC RRE %.3f "
                "deg RTE %.3f m\n",
                i + 10, i, reference.translation().norm(), rreDeg(a, reference), rte(a, reference),
                rreDeg(b, reference), rte(b, reference), rreDeg(c, reference), rte(c, reference),
                rreDeg(e, reference), rte(e, reference));
    t_svd += rte(a, reference);
    t_ransac += rte(b, reference);
    t_identity += reference.translation().norm();
    ok_svd += ok(c, reference);
    ok_ransac += ok(e, reference);
    ++n;
  }
  EXPECT_LT(t_ransac / n, 0.6 * t_svd / n) << "mean RTE of the network alone with RANSAC [m]";
  EXPECT_LT(t_ransac / n, 0.25 * t_identity / n) << "against not moving [m]";
  EXPECT_GE(ok_ransac, 3) << "of " << n << " registered within 1° and 0.3 m with RANSAC + ICP";
  EXPECT_GT(ok_ransac, ok_svd) << "RANSAC + ICP against the weighted SVD + ICP";
}

TEST(ModelAccuracy, SmallLidarModelKeepsTheStartsHeadingAndTheStartWithoutConsensus) {
  // The two guards of the network alone on sweeps far apart (docs/benchmarks.md, "The start's
  // heading and a consensus floor"), on real sweeps ten apart (~8 m):
  //  - start_heading_margin: a turned hypothesis must score more than the factor times the
  //    start's heading. With the source turned round the network finds the turn (margin 1); with
  //    a prohibitive margin it keeps the start's heading, so the pose stays turned round;
  //  - min_consensus: between sweeps of two different places (the outdoor pair of the shared data
  //    against a KITTI street) the network's matches agree on nothing, and with the floor the
  //    start comes back unchanged; between the right sweeps the floor changes nothing.
  OBM_REQUIRE_SHARED_DATA("kitti/raw_drive_22/velodyne/000021.bin");
  OBM_REQUIRE_SHARED_DATA("real_pairs/lidar_small_gicp/T_target_source.txt");
  const std::string d = test::sharedDataDir() + "/kitti/raw_drive_22/velodyne/";
  auto sweep = [&](std::size_t i) {
    return lidarCloud(io::readKittiVelodyne(d + io::kittiScanFileName(i)));
  };
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  const registration::IcpMatcher chain_icp(icp, conf);
  Isometry3d step = Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0.8, 0.0, 0.0);
  Isometry3d reference = Isometry3d::Identity();  // T_2_12, the chain of ICP steps
  for (std::size_t j = 2; j < 12; ++j) {
    const registration::MatchResult r = chain_icp.match(sweep(j + 1), sweep(j), step);
    ASSERT_GT(r.inlier_ratio, 0.7) << "chain " << j + 1 << " -> " << j;
    reference = reference * r.T_target_source;
  }
  const PointCloud source = sweep(12), target = sweep(2);
  registration::ObmNetMatcherParams plain = netParams(kModels + "obmnet_lidar_small.pt");
  plain.network.ransac_iterations = 5000;
  plain.network.yaw_hypotheses = 4;
  registration::ObmNetMatcherParams prohibitive = plain;
  prohibitive.network.start_heading_margin = 1000.0;
  registration::ObmNetMatcherParams floor = plain;
  floor.network.min_consensus = 0.06;
  const registration::ObmNetMatcher plain_net(plain, icp, conf);
  const registration::ObmNetMatcher margin_net(prohibitive, icp, conf);
  const registration::ObmNetMatcher floor_net(floor, icp, conf);

  Isometry3d turn = Isometry3d::Identity();
  turn.linear() =
      Eigen::AngleAxisd(180.0 / kDegPerRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const PointCloud turned = source.transformed(turn, "source_turned");
  const Isometry3d truth_turned = reference * turn.inverse();
  const Isometry3d a = plain_net.match(turned, target).T_target_source;
  const Isometry3d b = margin_net.match(turned, target).T_target_source;
  std::printf("source turned round: margin 1 RRE %.2f deg RTE %.2f m; margin 1000 RRE %.2f deg\n",
              rreDeg(a, truth_turned), rte(a, truth_turned), rreDeg(b, truth_turned));
  EXPECT_LT(rreDeg(a, truth_turned), 5.0) << "the network finds the turn among its hypotheses";
  EXPECT_GT(rreDeg(b, truth_turned), 90.0) << "a prohibitive margin keeps the start's heading";

  const Isometry3d right = floor_net.match(source, target).T_target_source;
  const Isometry3d right_plain = plain_net.match(source, target).T_target_source;
  const PointCloud elsewhere = realOutdoorPair().source;
  const Isometry3d wrong = floor_net.match(elsewhere, target).T_target_source;
  const Isometry3d wrong_plain = plain_net.match(elsewhere, target).T_target_source;
  std::printf("right sweeps: floor RRE %.2f deg RTE %.2f m (without %.2f deg); another place: "
              "floor moves %.3f m, without %.3f m\n",
              rreDeg(right, reference), rte(right, reference), rreDeg(right_plain, reference),
              wrong.translation().norm(), wrong_plain.translation().norm());
  EXPECT_TRUE(wrong.isApprox(Isometry3d::Identity(), 1e-6)) << "the start kept without consensus";
  EXPECT_FALSE(wrong_plain.isApprox(Isometry3d::Identity(), 1e-3)) << "without the floor it moves";
  EXPECT_TRUE(right.isApprox(right_plain, 1e-9)) << "the floor leaves an agreed pose alone";
  EXPECT_LT(rte(right, reference), 2.0) << "the right sweeps registered [m]";
}

/// A sweep of the benchmark drive as the LiDAR models see it (lidarCloud).
PointCloud driveSweep(const test::SeedFiveDrive& drive, std::size_t k) {
  return lidarCloud(drive.rawSweep(k, 500));
}

TEST(ModelAccuracy, SmallLidarModelHeadingByConsensusOnSimulatedRevisits) {
  // Pairs of the benchmark drive whose four yaw hypotheses, ranked by the fitness of their
  // poses, return the street seen turned round (docs/benchmarks.md, "Ranking the yaw hypotheses
  // by their consensus"): the wrong heading's points still land near points. Ranked by the share
  // of source points in RANSAC's consensus on the network's own matches (select_by_consensus),
  // the network alone must turn fewer of them round and end closer.
  const test::SeedFiveDrive drive;
  const sim::Trajectory& traj = drive.traj();
  auto sweep = [&](std::size_t k) { return driveSweep(drive, k); };
  const registration::IcpParams icp = lidarIcp();
  const registration::ConfidenceParams conf = lidarConfidence();
  const std::string model = kModels + "obmnet_lidar_small.pt";
  registration::ObmNetMatcherParams by_fitness = netParams(model);
  by_fitness.network.ransac_iterations = 5000;
  by_fitness.network.yaw_hypotheses = 4;
  by_fitness.network.select_by_consensus = false;
  registration::ObmNetMatcherParams by_consensus = by_fitness;
  by_consensus.network.select_by_consensus = true;
  const registration::ObmNetMatcher fit_net(by_fitness, icp, conf);
  const registration::ObmNetMatcher cons_net(by_consensus, icp, conf);
  // (source, target): sweeps 20 apart on one street, and two revisits from another heading.
  const std::vector<std::pair<std::size_t, std::size_t>> pairs = {
      {20, 0}, {274, 254}, {472, 452}, {500, 480}, {904, 103}, {913, 107}};
  int turned_fit = 0, turned_cons = 0, n = 0;
  double rre_fit = 0.0, rre_cons = 0.0;
  for (const auto& [s, t] : pairs) {
    const Isometry3d truth = traj.poses.at(t).inverse() * traj.poses.at(s);  // T_t_s
    const PointCloud source = sweep(s), target = sweep(t);
    const Isometry3d a = fit_net.match(source, target).T_target_source;
    const Isometry3d b = cons_net.match(source, target).T_target_source;
    std::printf(
        "sweeps %zu->%zu (%.1f m apart): by fitness RRE %.2f deg RTE %.2f m; by consensus "
        "RRE %.2f deg RTE %.2f m\n",
        s, t, truth.translation().norm(), rreDeg(a, truth), rte(a, truth), rreDeg(b, truth),
        rte(b, truth));
    turned_fit += rreDeg(a, truth) > 45.0;
    turned_cons += rreDeg(b, truth) > 45.0;
    rre_fit += rreDeg(a, truth);
    rre_cons += rreDeg(b, truth);
    ++n;
  }
  std::printf("%d pairs: turned > 45 deg %d (fitness) / %d (consensus); mean RRE %.2f / %.2f deg\n",
              n, turned_fit, turned_cons, rre_fit / n, rre_cons / n);
  EXPECT_LT(turned_cons, turned_fit) << "hypotheses turned the wrong way, of " << n;
  EXPECT_LT(rre_cons / n, 0.5 * rre_fit / n) << "mean RRE of the network alone [deg]";
}

TEST(ModelAccuracy, SmallLidarModelHeadingByFreeSpaceOnSimulatedSweepsTwentyApart) {
  // Sweeps 20 apart on the benchmark drive, where the network's hypotheses ranked by their
  // consensus still return some streets seen from their other end. Ranked by the consensus
  // discounted by the free-space conflicts (hypothesis_free_space_weight, docs/registration.md
  // "Free space"), the network alone must turn fewer round and end closer in rotation than not
  // moving. The whole voxelised sweeps are checked, not 1 024 keypoints.
  const test::SeedFiveDrive drive;
  const sim::Trajectory& traj = drive.traj();
  registration::ObmNetMatcherParams by_consensus = netParams(kModels + "obmnet_lidar_small.pt");
  by_consensus.network.ransac_iterations = 5000;
  by_consensus.network.yaw_hypotheses = 4;
  registration::ObmNetMatcherParams by_free_space = by_consensus;
  by_free_space.hypothesis_free_space_weight = 8.0;
  const registration::ObmNetMatcher cons_net(by_consensus, lidarIcp(), lidarConfidence());
  const registration::ObmNetMatcher free_net(by_free_space, lidarIcp(), lidarConfidence());
  int turned_cons = 0, turned_free = 0, n = 0;
  double rre_cons = 0.0, rre_free = 0.0, rre_identity = 0.0;
  for (std::size_t s = 40; s + 20 < traj.poses.size() && n < 12; s += 110, ++n) {
    const std::size_t t = s + 20;
    const Isometry3d truth = traj.poses.at(t).inverse() * traj.poses.at(s);  // T_t_s
    const PointCloud source = driveSweep(drive, s), target = driveSweep(drive, t);
    const double a = rreDeg(cons_net.match(source, target).T_target_source, truth);
    const double b = rreDeg(free_net.match(source, target).T_target_source, truth);
    std::printf("sweeps %zu->%zu: RRE by consensus %.2f deg, with free space %.2f deg\n", s, t,
                a, b);
    turned_cons += a > 45.0;
    turned_free += b > 45.0;
    rre_cons += a;
    rre_free += b;
    rre_identity += rreDeg(Isometry3d::Identity(), truth);
  }
  std::printf("%d pairs: turned > 45 deg %d (consensus) / %d (free space); mean RRE %.2f / %.2f "
              "deg, identity %.2f deg\n",
              n, turned_cons, turned_free, rre_cons / n, rre_free / n, rre_identity / n);
  EXPECT_LT(turned_free, turned_cons) << "hypotheses turned the wrong way, of " << n;
  EXPECT_LT(rre_free, rre_identity) << "mean RRE of the network alone against not moving";
}

/// The ten pairs of Open3D's five real RGB-D frames (1 cm voxels, depth 0.3–4 m): `fn(s, t,
/// truth)` per pair, source frame j after target frame i.
template <class Fn>
void forEachRealFramePair(const io::RgbdSequence& seq, Fn&& fn) {
  for (std::size_t i = 0; i < seq.size(); ++i)
    for (std::size_t j = i + 1; j < seq.size(); ++j) {
      const PointCloud s = voxelDownsample(seq.cloud(j, 0.3, 4.0, 2), 0.01);
      const PointCloud t = voxelDownsample(seq.cloud(i, 0.3, 4.0, 2), 0.01);
      const Isometry3d truth = seq.frame(i).T_world_camera.inverse() * seq.frame(j).T_world_camera;
      std::printf("frames %zu->%zu: ", j, i);
      fn(s, t, truth);
    }
}

/// Network + ICP at the real frames' scale: a 5 cm gate, Huber 1 cm, inliers within 2 cm; more
/// starts turned by ± `turn_deg` about `axes` when `turn_deg` > 0.
registration::ObmNetIcpMatcher realFramesMatcher(const std::string& model, double turn_deg = 0.0,
                                                 const std::string& axes = "xy",
                                                 int search_candidates = 0,
                                                 double choice_inlier_power = 0.0) {
  registration::IcpParams icp;
  icp.max_correspondence_distance = 0.05;
  icp.initial_max_correspondence_distance = 0.05;
  icp.kernel_scale = 0.01;
  registration::ConfidenceParams conf;
  conf.inlier_threshold = 0.02;
  registration::ObmNetMatcherParams p = netParams(kModels + model);
  p.start_turn_deg = turn_deg;
  p.start_turn_axes = axes;
  p.search_candidates = search_candidates;
  p.choice_inlier_power = choice_inlier_power;
  p.search.axis = "y";  // the camera's vertical, or the floor's normal near it
  p.search.heading_range_deg = 90.0;
  return registration::ObmNetIcpMatcher(p, icp, conf);
}

TEST(ModelAccuracy, IndoorModelOnPairsOfRealRgbdFrames) {
  // obmnet_indoor.pt + ICP on the ten real frame pairs with the source turned 30° about the
  // camera's y axis and moved 0.2 m (the frames themselves are 0.7–3° apart: unmoved, not moving
  // would pass): the pose after ICP within 1° and 2 cm, which not moving misses on every pair.
  // Measured: all ten, the worst 0.28° and 8 mm. (An untrained network in the model's place
  // registers them too: the ICP behind it does the work from this start; the network alone is
  // judged by IndoorModelAloneOnRealFragmentPairs.)
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto seq = io::RgbdSequence::openRedwood(test::sharedDataDir() + "/rgbd_open3d");
  ASSERT_GE(seq.size(), 5u);
  const auto refined = realFramesMatcher("obmnet_indoor.pt");
  const Isometry3d A = makeIsometry(
      Eigen::AngleAxisd(30.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d(0.2, 0.0, 0.0));
  int ok = 0, ok_identity = 0, n = 0;
  forEachRealFramePair(seq, [&](const PointCloud& s, const PointCloud& t, const Isometry3d& truth) {
    const PointCloud moved = s.transformed(A, s.frame_id);
    const Isometry3d truth_moved = truth * A.inverse();
    const registration::MatchResult r = refined.match(moved, t);
    const double e_r = rreDeg(r.T_target_source, truth_moved);
    const double e_t = rte(r.T_target_source, truth_moved);
    std::printf("+ICP RRE %.2f deg RTE %.3f m\n", e_r, e_t);
    ok += (e_r < 1.0 && e_t < 0.02) ? 1 : 0;
    ok_identity += (rreDeg(Isometry3d::Identity(), truth_moved) < 1.0 &&
                    rte(Isometry3d::Identity(), truth_moved) < 0.02)
                       ? 1
                       : 0;
    ++n;
  });
  EXPECT_EQ(ok_identity, 0) << "the moved pairs must not be registered by not moving";
  EXPECT_GE(ok, 9) << ok << " of " << n << " real frame pairs within 1° and 2 cm";
}

TEST(ModelAccuracy, IndoorModelAloneOnRealFragmentPairs) {
  // The fragments preset's model (obmnet_indoor.pt, config/presets/fragments.yaml) alone, before
  // any ICP, on the pairs of its protocol (RIENet's 7Scenes: one fragment cut twice, turned up to
  // 45°, moved up to 0.5 of its radius; the `indoor` preset) made from the five real frames of
  // Open3D's data, its test group (no training run saw them): two pairs per frame. Measured
  // (mean RRE of ten, pairs within 5°): the shipped model 1.10°, 9 of 10; an untrained network of
  // the same shape (tests/untrained_like, seed 7) 19.4°, 1 of 10; not moving 52.9°, 0 of 10.
  // Bounds: 2° (1.8× the measured mean) and 8 of 10.
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  datasets::RgbdFragmentOptions fo;
  fo.layout = "redwood";
  fo.train_sequences = {test::sharedDataDir() + "/rgbd_open3d"};
  fo.frame_step = 1;
  const obmnet::ObjectSet set = datasets::loadRgbdFragments("", fo, 2048, 1);
  ASSERT_EQ(set.train.size(), 5u);
  obmnet::ObmNetRegistrar::Options o;
  o.model_path = kModels + "obmnet_indoor.pt";
  o.threads = 1;
  const obmnet::ObmNetRegistrar net(o);
  const auto proto = obmnet::PairProtocol::preset("indoor");
  std::mt19937_64 rng(1);
  double net_r = 0.0, id_r = 0.0;
  int close = 0, n = 0;
  for (int k = 0; k < 10; ++k) {
    const auto& fragment = set.train[static_cast<std::size_t>(k % 5)];
    const auto pair = obmnet::makePair(fragment, proto, rng);
    const Isometry3d T = net.align(pair.source, pair.target).T_target_source;
    const double e = rreDeg(T, pair.T_target_source);
    const double e0 = rreDeg(Isometry3d::Identity(), pair.T_target_source);
    std::printf("%s: network alone RRE %.2f deg RTE %.3f; identity RRE %.2f deg\n",
                fragment.frame_id.c_str(), e, rte(T, pair.T_target_source), e0);
    net_r += e;
    id_r += e0;
    close += e < 5.0 ? 1 : 0;
    ++n;
  }
  std::printf("mean RRE: network alone %.2f deg, identity %.2f deg; %d of %d within 5 deg\n",
              net_r / n, id_r / n, close, n);
  EXPECT_LT(net_r / n, 2.0) << "mean RRE of the network alone [deg]";
  EXPECT_GE(close, 8) << "pairs the network alone brings within 5°, of " << n;
}

TEST(ModelAccuracy, FramesModelAloneOnMovedRealRgbdFrames) {
  // The frame model (obmnet_indoor_frames.pt, obm-bench's RGB-D frame-pair rows) alone, before any
  // ICP, on the ten real frame pairs with the source turned 20° about the camera's y axis and
  // moved 0.15 m. Measured (means of ten): the shipped model 6.80° and 0.226 m; an untrained
  // network of the same shape (tests/untrained_like, seed 7) 4.95° and 0.376 m; not moving 19.62°
  // and 0.159 m. So on real frames the trained weights are told from fresh ones by the
  // translation only (the weighted SVD of an untrained network already turns these pairs most of
  // the way), and neither network alone beats not moving in translation: the pose it hands to ICP
  // is what counts (StartTurnsRecover…, SearchStartsRecover… below).
  // Bounds: RTE 0.3 m (1.33× the measured), RRE half the identity's (the shipped model's 0.35×).
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto seq = io::RgbdSequence::openRedwood(test::sharedDataDir() + "/rgbd_open3d");
  ASSERT_GE(seq.size(), 5u);
  obmnet::ObmNetRegistrar::Options o;
  o.model_path = kModels + "obmnet_indoor_frames.pt";
  o.threads = 1;
  const obmnet::ObmNetRegistrar net(o);
  const Isometry3d A = makeIsometry(
      Eigen::AngleAxisd(20.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d(0.15, 0.0, 0.0));
  double net_r = 0.0, net_t = 0.0, id_r = 0.0;
  int n = 0;
  forEachRealFramePair(seq, [&](const PointCloud& s, const PointCloud& t, const Isometry3d& truth) {
    const PointCloud moved = s.transformed(A, s.frame_id);
    const Isometry3d truth_moved = truth * A.inverse();  // T_t_s' for s' = A·s
    const Isometry3d T = net.align(moved, t).T_target_source;
    std::printf("network alone %.2f deg %.3f m\n", rreDeg(T, truth_moved), rte(T, truth_moved));
    net_r += rreDeg(T, truth_moved);
    net_t += rte(T, truth_moved);
    id_r += rreDeg(Isometry3d::Identity(), truth_moved);
    ++n;
  });
  std::printf("mean: network alone %.2f deg %.3f m; identity %.2f deg\n", net_r / n, net_t / n,
              id_r / n);
  EXPECT_LT(net_t / n, 0.3) << "mean RTE of the network alone [m]";
  EXPECT_LT(net_r / n, 0.5 * id_r / n) << "mean RRE of the network alone [deg]";
}

TEST(ModelAccuracy, FramesModelAloneOnPairsOfRealRgbdFrames) {
  // The frame model matches each point near its current place (model.match_spatial_sigma), so it
  // corrects the pair as given; obmnet_indoor.pt (one frame cut twice, no prior) matches across
  // the room. Both alone on the ten pairs of Open3D's five real frames (measured with obm-bench's
  // sampling: mean RRE 5.1° against 13.3°), and the frame model with ICP behind it.
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto seq = io::RgbdSequence::openRedwood(test::sharedDataDir() + "/rgbd_open3d");
  ASSERT_GE(seq.size(), 5u);
  auto registrar = [](const std::string& model) {
    obmnet::ObmNetRegistrar::Options o;
    o.model_path = kModels + model;
    o.threads = 1;
    return obmnet::ObmNetRegistrar(o);
  };
  const auto frames = registrar("obmnet_indoor_frames.pt");
  const auto fragments = registrar("obmnet_indoor.pt");
  const auto refined = realFramesMatcher("obmnet_indoor_frames.pt");
  double sum_frames = 0.0, sum_fragments = 0.0, worst_t = 0.0;
  int ok = 0, n = 0;
  forEachRealFramePair(seq, [&](const PointCloud& s, const PointCloud& t, const Isometry3d& truth) {
    const Isometry3d T_f = frames.align(s, t).T_target_source;
    const Isometry3d T_c = fragments.align(s, t).T_target_source;
    const registration::MatchResult r = refined.match(s, t);
    std::printf("frame model %.2f deg %.3f m, fragment model %.2f deg %.3f m, "
                "frame model + ICP %.2f deg %.3f m\n",
                rreDeg(T_f, truth), rte(T_f, truth), rreDeg(T_c, truth), rte(T_c, truth),
                rreDeg(r.T_target_source, truth), rte(r.T_target_source, truth));
    sum_frames += rreDeg(T_f, truth);
    sum_fragments += rreDeg(T_c, truth);
    worst_t = std::max(worst_t, rte(T_f, truth));
    ok += (rreDeg(r.T_target_source, truth) < 5.0 && rte(r.T_target_source, truth) < 0.1) ? 1 : 0;
    ++n;
  });
  EXPECT_LT(sum_frames / n, 0.6 * sum_fragments / n)
      << "mean RRE of the frame model " << sum_frames / n << " deg, of the fragment model "
      << sum_fragments / n << " deg";
  EXPECT_LT(sum_frames / n, 8.0);
  EXPECT_LT(worst_t, 0.5);
  EXPECT_GE(ok, 9) << ok << " of " << n << " real frame pairs within 5° and 0.1 m after ICP";
}

/// Each real frame pair with its source moved by A (s' = A·s, truth T·A⁻¹), registered by a
/// single-start matcher and by one with more starts: how many of each land within 5° and 0.1 m.
/// The single start is among the other's, so the chosen result is at least as confident.
struct MovedFramesCount {
  int ok_one = 0, ok_more = 0, n = 0;
};
MovedFramesCount compareOnMovedRealFrames(const registration::ObmNetIcpMatcher& one,
                                          const registration::ObmNetIcpMatcher& more,
                                          const Isometry3d& A, const char* more_label) {
  const auto seq = io::RgbdSequence::openRedwood(test::sharedDataDir() + "/rgbd_open3d");
  EXPECT_GE(seq.size(), 5u);
  MovedFramesCount c;
  forEachRealFramePair(seq, [&](const PointCloud& s, const PointCloud& t, const Isometry3d& truth) {
    const PointCloud moved = s.transformed(A, s.frame_id);
    const Isometry3d truth_moved = truth * A.inverse();  // T_t_s' for s' = A·s
    const registration::MatchResult a = one.match(moved, t);
    const registration::MatchResult b = more.match(moved, t);
    std::printf("one start %.2f deg %.3f m (confidence %.3f), %s %.2f deg %.3f m "
                "(confidence %.3f)\n",
                rreDeg(a.T_target_source, truth_moved), rte(a.T_target_source, truth_moved),
                a.network_confidence, more_label, rreDeg(b.T_target_source, truth_moved),
                rte(b.T_target_source, truth_moved), b.network_confidence);
    auto ok = [&](const registration::MatchResult& r) {
      return rreDeg(r.T_target_source, truth_moved) < 5.0 &&
             rte(r.T_target_source, truth_moved) < 0.1;
    };
    c.ok_one += ok(a);
    c.ok_more += ok(b);
    EXPECT_GE(b.network_confidence, a.network_confidence - 1e-9);
    ++c.n;
  });
  std::printf("within 5 deg and 0.1 m: one start %d, %s %d of %d\n", c.ok_one, more_label,
              c.ok_more, c.n);
  return c;
}

TEST(ModelAccuracy, StartTurnsRecoverRealFramesSeenTurned) {
  // Each source frame turned 70° about the camera's y axis (as if the camera had panned): from
  // there the frame model and ICP land 5–47° short on every pair (they arrive from 50°, measured
  // with this test's pairs); with starts turned by ±65° about y
  // (ObmNetMatcherParams::start_turn_deg) the start 5° from the truth arrives, and the
  // bias-weighted confidence has to pick it out of the three.
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const Isometry3d R = makeIsometry(
      Eigen::AngleAxisd(70.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d::Zero());
  const auto c = compareOnMovedRealFrames(realFramesMatcher("obmnet_indoor_frames.pt"),
                                          realFramesMatcher("obmnet_indoor_frames.pt", 65.0, "y"),
                                          R, "three starts");
  EXPECT_GE(c.ok_more, 9) << "of " << c.n;
  EXPECT_GT(c.ok_more, c.ok_one) << "of " << c.n;
}

TEST(ModelAccuracy, SearchStartsRecoverRealFramesSeenTurnedAndMoved) {
  // Each source frame turned 75° about the camera's y axis and moved 0.4 m (a pan while
  // stepping aside): one start from there lands far off; with the correlative search's poses as
  // more starts (ObmNetMatcherParams::search_candidates) ICP from the search's pose nearest the
  // truth arrives, and the bias-weighted confidence times the share of inliers (obm-bench's
  // choice for frame pairs, choice_inlier_power 1) has to pick it out of nine.
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const Isometry3d A = makeIsometry(
      Eigen::AngleAxisd(75.0 * kDegToRad, Eigen::Vector3d::UnitY()).toRotationMatrix(),
      Eigen::Vector3d(0.3, 0.0, 0.25));
  const auto c = compareOnMovedRealFrames(
      realFramesMatcher("obmnet_indoor_frames.pt"),
      realFramesMatcher("obmnet_indoor_frames.pt", 0.0, "xy", 8, 1.0), A, "with the search");
  EXPECT_GE(c.ok_more, 9) << "of " << c.n;
  EXPECT_GT(c.ok_more, c.ok_one) << "of " << c.n;
}

}  // namespace obm
