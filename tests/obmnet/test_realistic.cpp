// The pieces for pairs that share no sample: the `resampled` object protocol, voxel keypoints,
// the 4-DoF (yaw) Procrustes, the nearest-neighbour form of L_n, and the registrar's yaw
// hypotheses.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/mesh.hpp"
#include "obm/obmnet/data.hpp"
#include "obm/obmnet/losses.hpp"
#include "obm/obmnet/model.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/obmnet/registrar.hpp"
#include "obm/obmnet/svd.hpp"
#include "obm/obmnet/trainer.hpp"
#include "small_training.hpp"
#include "test_clouds.hpp"
#include "test_data.hpp"
#include "untrained_model.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// n i.i.d. points uniform on the unit sphere: an "object" whose surface samples are independent.
PointCloud sphereSamples(std::size_t n, std::uint64_t seed) {
  PointCloud c = test::unitSphereSamples(n, seed);
  c.frame_id = "sphere";
  return c;
}

/// n i.i.d. points on a street-like scene: a ground plane and two walls, 40 × 20 m.
PointCloud streetSamples(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> U(0.f, 1.f);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const float u = U(rng), a = -20.f + 40.f * U(rng), b = U(rng);
    if (u < 0.4f) c.points.emplace_back(a, -8.f + 16.f * b, 0.f);
    else if (u < 0.7f) c.points.emplace_back(a, -8.f, 6.f * b);
    else c.points.emplace_back(a + 0.3f * std::sin(a), 8.f, 6.f * b);
  }
  return c;
}

/// Mean distance from each point of `a` to its nearest point of `b` (brute force).
double meanNearest(const PointCloud& a, const PointCloud& b) {
  double s = 0;
  for (const auto& p : a.points) {
    float best = 1e30f;
    for (const auto& q : b.points) best = std::min(best, (p - q).squaredNorm());
    s += std::sqrt(best);
  }
  return s / static_cast<double>(a.size());
}

}  // namespace

TEST(ResampledProtocol, DisjointIndependentSamplingsCroppedAndMoved) {
  const PointCloud object = sphereSamples(2048, 1);
  PairProtocol p = PairProtocol::preset("resampled");
  p.jitter_sigma = 0.0;  // exact points, to check that none is shared
  std::mt19937_64 rng(5);
  const RegistrationPair pair = makePair(object, p, rng);
  ASSERT_EQ(pair.source.size(), 768u);
  ASSERT_EQ(pair.target.size(), 768u);
  // Bring the target back: no target point may coincide with a source point (disjoint halves).
  const PointCloud back = pair.target.transformed(pair.T_target_source.inverse(), "source");
  std::size_t shared = 0;
  for (const auto& q : back.points)
    for (const auto& s : pair.source.points) shared += (q - s).norm() < 1e-6f ? 1 : 0;
  EXPECT_EQ(shared, 0u);
  // Each crop is a cap of the sphere around its own far point: the overlap is a fraction, and
  // the source points it counts really lie near target points.
  EXPECT_GT(pair.overlap, 0.0);
  EXPECT_LT(pair.overlap, 1.0);
  // The pose is RIENet's: angles within 45°, translation within 0.5 per axis.
  const double angle = Eigen::AngleAxisd(pair.T_target_source.linear()).angle() * 180.0 / kPi;
  EXPECT_LE(angle, 45.0 * std::sqrt(3.0) + 1e-9);
  EXPECT_LE(pair.T_target_source.translation().cwiseAbs().maxCoeff(), 0.5);
}

TEST(ResampledProtocol, NeedsTwiceTheSamplesAndNamesTheObject) {
  PointCloud object = sphereSamples(1024, 2);
  object.frame_id = "elephant";
  std::mt19937_64 rng(1);
  try {
    makePair(object, PairProtocol::preset("resampled"), rng);
    FAIL() << "expected ContractError";
  } catch (const ContractError& e) {
    EXPECT_NE(std::string(e.what()).find("elephant"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("keep_points"), std::string::npos) << e.what();
  }
}

TEST(ResampledProtocol, JitterIsTheProtocolsAndSeedsRepeat) {
  const PointCloud object = sphereSamples(2048, 3);
  std::mt19937_64 a(9), b(9);
  const auto pa = makePair(object, PairProtocol::preset("resampled"), a);
  const auto pb = makePair(object, PairProtocol::preset("resampled"), b);
  ASSERT_EQ(pa.source.size(), pb.source.size());
  for (std::size_t i = 0; i < pa.source.size(); ++i)
    EXPECT_EQ(pa.source.points[i], pb.source.points[i]);
  // σ = 0.005 moves the unit-sphere samples off the sphere by about that much.
  double r = 0;
  for (const auto& q : pa.source.points) r += std::abs(q.norm() - 1.0f);
  r /= static_cast<double>(pa.source.size());
  EXPECT_GT(r, 0.001);
  EXPECT_LT(r, 0.01);
}

TEST(VoxelKeypoints, CountIndicesAndDeterminism) {
  const PointCloud scan = streetSamples(20000, 4);
  std::mt19937_64 r1(3), r2(3);
  std::vector<std::size_t> idx;
  const PointCloud k1 = voxelKeypoints(scan, 512, r1, &idx);
  const PointCloud k2 = voxelKeypoints(scan, 512, r2);
  ASSERT_EQ(k1.size(), 512u);
  ASSERT_EQ(idx.size(), 512u);
  for (std::size_t i = 0; i < k1.size(); ++i) {
    EXPECT_EQ(k1.points[i], k2.points[i]);
    ASSERT_LT(idx[i], scan.size());
    // The representative input point lies in the keypoint's cell: close to the centroid.
    EXPECT_LT((scan.points[idx[i]] - k1.points[i]).norm(), 3.0f);
  }
  // A cloud smaller than n comes back whole.
  std::mt19937_64 r3(1);
  EXPECT_EQ(voxelKeypoints(streetSamples(100, 1), 512, r3).size(), 100u);
}

TEST(VoxelKeypoints, TwoSamplingsOfOnePlaceGiveCloserPointsThanRandomSubsets) {
  // Two independent scans of the same street (no shared sample), 1024 points from each.
  const PointCloud a = streetSamples(30000, 10), b = streetSamples(30000, 11);
  std::mt19937_64 rng(2);
  const double voxel = meanNearest(voxelKeypoints(a, 1024, rng), voxelKeypoints(b, 1024, rng));
  const double random = meanNearest(randomSubset(a, 1024, rng), randomSubset(b, 1024, rng));
  // Cell centroids of the same cells nearly coincide; random subsets are a spacing apart.
  EXPECT_LT(voxel, 0.6 * random) << "voxel " << voxel << " m, random " << random << " m";
}

TEST(WeightedSvd, YawSolveExactOnPlanarMotionAndFlatOtherwise) {
  torch::manual_seed(21);
  const int64_t B = 2, N = 60;
  const auto x = torch::randn({B, 3, N}, torch::kFloat64);
  const double yaw[2] = {0.3, -2.5};
  auto R = torch::zeros({B, 3, 3}, torch::kFloat64);
  for (int b = 0; b < B; ++b) {
    R[b][0][0] = std::cos(yaw[b]);
    R[b][0][1] = -std::sin(yaw[b]);
    R[b][1][0] = std::sin(yaw[b]);
    R[b][1][1] = std::cos(yaw[b]);
    R[b][2][2] = 1.0;
  }
  const auto t = torch::randn({B, 3}, torch::kFloat64);
  const auto y = torch::bmm(R, x) + t.unsqueeze(2);
  const auto w = torch::rand({B, N}, torch::kFloat64) + 0.1;
  const auto T = weightedProcrustesYaw(x, y, w);
  EXPECT_TRUE(torch::allclose(T.R, R, 1e-9, 1e-9));
  EXPECT_TRUE(torch::allclose(T.t, t, 1e-9, 1e-9));
  // The 6-DoF solve agrees on planar motion.
  const auto T6 = weightedProcrustes(x, y, w);
  EXPECT_TRUE(torch::allclose(T6.R, R, 1e-8, 1e-8));
  // With a roll in the data, the yaw solve still returns a rotation about z only.
  auto y_roll = y.clone();
  y_roll.select(1, 2).add_(0.2 * y.select(1, 1));
  const auto Tr = weightedProcrustesYaw(x, y_roll, w);
  EXPECT_NEAR(Tr.R[0][2][2].item<double>(), 1.0, 1e-12);
  EXPECT_NEAR(Tr.R[0][0][2].item<double>(), 0.0, 1e-12);
  // Gradient flows to the weights and the targets.
  auto wg = w.clone().requires_grad_(true);
  auto yg = y.clone().requires_grad_(true);
  const auto Tg = weightedProcrustesYaw(x, yg, wg);
  (Tg.R.sum() + Tg.t.sum()).backward();
  EXPECT_TRUE(wg.grad().defined());
  EXPECT_TRUE(yg.grad().abs().sum().item<double>() > 0.0);
}

TEST(Losses, NearestNeighbourhoodFormHasNoFloorOnIndependentSamplings) {
  // Two independent samplings of the unit sphere (no shared sample), the target moved.
  torch::manual_seed(12);
  const int64_t N = 768, K = 64, k = 16;
  auto toTensor = [](const PointCloud& c) {
    auto t = torch::empty({1, 3, static_cast<int64_t>(c.size())});
    for (std::size_t i = 0; i < c.size(); ++i)
      for (int d = 0; d < 3; ++d) t[0][d][static_cast<int64_t>(i)] = c.points[i][d];
    return t;
  };
  const auto src = toTensor(sphereSamples(N, 30));
  const auto base = toTensor(sphereSamples(N, 31));
  const double yaw = 0.4;
  auto R = torch::eye(3).unsqueeze(0).clone();
  R[0][0][0] = std::cos(yaw);
  R[0][0][1] = -std::sin(yaw);
  R[0][1][0] = std::sin(yaw);
  R[0][1][1] = std::cos(yaw);
  const auto t = torch::tensor({{0.2f, -0.1f, 0.05f}});
  const auto tgt = torch::bmm(R, base) + t.unsqueeze(2);
  // Pseudo-targets: the true image of each source point (what a perfect matching would give).
  const auto pseudo = torch::bmm(R, src) + t.unsqueeze(2);
  const auto kp = torch::arange(K, torch::kInt64).unsqueeze(0);
  const RigidTransforms T_true{R, t};
  // 0.1 off the true translation (a tenth of the radius, about twice the sampling spacing).
  const auto t_off = t + torch::tensor({{0.0577f, 0.0577f, 0.0577f}});
  const RigidTransforms T_wrong{R, t_off};
  const double rank_true = neighborhoodLoss(src, tgt, pseudo, T_true, kp, k, false).item<double>();
  const double near_true = neighborhoodLoss(src, tgt, pseudo, T_true, kp, k, true).item<double>();
  const double near_wrong = neighborhoodLoss(src, tgt, pseudo, T_wrong, kp, k, true).item<double>();
  // Rank pairing leaves a floor of about a sampling spacing at the true pose; the nearest form
  // is well below it, and it still grows away from the truth.
  EXPECT_LT(near_true, 0.6 * rank_true) << near_true << " vs rank " << rank_true;
  EXPECT_GT(near_wrong, near_true * 1.2);
}

TEST(Losses, PointToPlaneAlignmentIsLowestAtTheTruePoseOfIndependentSamplings) {
  // A street (ground and two walls) sampled twice independently: 1024 source points, 4096
  // surface samples of the target with their PCA normals. Along the street (x) the point-to-point
  // L_g is nearly flat, its floor is the sampling spacing; the plane distances vanish at the truth.
  auto toTensor = [](const std::vector<Vector3f>& pts) {
    auto t = torch::empty({1, 3, static_cast<int64_t>(pts.size())});
    auto a = t.accessor<float, 3>();
    for (std::size_t i = 0; i < pts.size(); ++i)
      for (int d = 0; d < 3; ++d) a[0][d][static_cast<int64_t>(i)] = pts[i][d];
    return t;
  };
  const PointCloud src_cloud = streetSamples(1024, 40), surf = streetSamples(4096, 41);
  const auto normals = pcaNormals(surf, 10);
  ASSERT_EQ(normals.size(), surf.size());
  // Ground samples away from the walls get a vertical normal.
  std::size_t ground = 0, vertical = 0;
  for (std::size_t i = 0; i < surf.size(); ++i)
    if (surf.points[i].z() == 0.f && std::abs(surf.points[i].y()) < 6.f) {
      ++ground;
      vertical += std::abs(normals[i].z()) > 0.99f ? 1 : 0;
    }
  EXPECT_GT(vertical, 0.95 * static_cast<double>(ground));
  const auto surface = toTensor(surf.points), normal_t = toTensor(normals);
  const double scale = 0.05;  // the normalisation of a 20 m radius
  auto moved = [&](float dx, float dy) {
    std::vector<Vector3f> pts;
    for (const auto& p : src_cloud.points) pts.push_back(p + Vector3f(dx, dy, 0.f));
    return toTensor(pts);
  };
  const double c = 0.0009 / (scale * scale);  // the LiDAR Huber threshold in metres²
  const auto dense = toTensor(surf.points);
  std::vector<double> p2l, p2p;
  const std::vector<float> shifts{-0.5f, -0.25f, 0.f, 0.25f, 0.5f};  // across the street [m]
  for (float dy : shifts) {
    p2l.push_back(pointToPlaneAlignmentLoss(moved(0, dy), surface, normal_t, c).item<double>());
    p2p.push_back(globalAlignmentLoss(moved(0, dy), dense, c).item<double>());
    std::printf("shift %+.2f m: point-to-plane %.5g, point-to-point %.5g\n", dy, p2l.back(), p2p.back());
  }
  // The plane form is lowest at the true pose, and nearly zero there relative to 0.5 m off;
  // the point form keeps a floor of the sampling spacing.
  EXPECT_EQ(std::min_element(p2l.begin(), p2l.end()) - p2l.begin(), 2);
  EXPECT_LT(p2l[2], 0.1 * std::min(p2l[0], p2l[4]));
  EXPECT_GT(p2p[2] / std::min(p2p[0], p2p[4]), 2.0 * p2l[2] / std::min(p2l[0], p2l[4]));
  // Gradient flows to the points.
  auto x = moved(0, 0.2f).requires_grad_(true);
  pointToPlaneAlignmentLoss(x, surface, normal_t, c).backward();
  EXPECT_GT(x.grad().abs().sum().item<double>(), 0.0);
}

TEST(ScanPairs, SurfaceSamplesComeWithUnitNormals) {
  std::mt19937_64 rng(3);
  const PointCloud scan = streetSamples(20000, 5);
  const auto pair = makeScanPair(scan, scan, Isometry3d::Identity(), 0.3, 256, rng, true, 2048);
  ASSERT_EQ(pair.target_surface.size(), 2048u);
  ASSERT_EQ(pair.target_normals.size(), 2048u);
  for (const auto& n : pair.target_normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-4f);
  const auto none = makeScanPair(scan, scan, Isometry3d::Identity(), 0.3, 256, rng, true);
  EXPECT_TRUE(none.target_surface.empty());
}

namespace {

/// An untrained planar network of the registrar tests (what they check is the search, not
/// the weights), saved in `dir`.
std::string savePlanarModel(const std::string& dir, bool shared_centroid) {
  obmnet::ObmNetConfig c;
  c.shared_centroid = shared_centroid;
  c.emb_dims = 16;
  c.n_samples = 4;
  c.n_iters = 1;
  c.planar = true;
  c.voxel_keypoints = true;
  return test::saveUntrainedModel(dir + "/planar.pt", c, 1, 256);
}

/// An L-shaped corner of two walls on a road, as a car's sensor sees it.
PointCloud cornerScene() {
  PointCloud scene;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> U(0.f, 1.f);
  for (int i = 0; i < 4000; ++i) {
    const float a = U(rng), b = U(rng);
    if (i % 3 == 0) scene.points.emplace_back(30.f * a, 0.f, 5.f * b);
    else if (i % 3 == 1) scene.points.emplace_back(0.f, 12.f * a, 5.f * b);
    else scene.points.emplace_back(30.f * a, 12.f * b, 0.f);
  }
  return scene;
}

/// `scene` as a sensor sees it from the pose T_scene_sensor = (yaw about z, t): p_sensor = T⁻¹·p.
PointCloud seenFrom(const PointCloud& scene, double yaw, const Eigen::Vector3d& t) {
  Isometry3d T_scene_sensor = Isometry3d::Identity();
  T_scene_sensor.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_scene_sensor.translation() = t;
  return scene.transformed(T_scene_sensor.inverse(), "source");
}

}  // namespace

TEST(Registrar, YawHypothesesAreSearchedInOneBatchAndTheBestFitIsKept) {
  // An untrained planar network: what is checked is the search. Four hypotheses are tried (the
  // default for a planar model), the returned one is one of them, its fitness is at least that of
  // the single pass (which is hypothesis 0 of the four), and the pose has no roll or pitch.
  // Both pivots of the hypotheses: the source's centroid, and its sensor (shared_centroid models).
  for (const bool shared : {false, true}) {
    SCOPED_TRACE(shared ? "shared centroid" : "separate centroids");
    const std::string path = savePlanarModel(test::scratchDir("registrar_yaw"), shared);
    const PointCloud scene = cornerScene();
    const PointCloud source = seenFrom(scene, kPi, Eigen::Vector3d(3.0, -2.0, 0.0));
    obmnet::ObmNetRegistrar::Options o;
    o.model_path = path;
    o.threads = 1;
    const auto r4 = obmnet::ObmNetRegistrar(o).align(source, scene);
    o.yaw_hypotheses = 1;
    const auto r1 = obmnet::ObmNetRegistrar(o).align(source, scene);
    const double h = r4.hypothesis_yaw_deg;
    EXPECT_TRUE(h == 0.0 || h == 90.0 || h == 180.0 || h == 270.0) << h;
    EXPECT_DOUBLE_EQ(r1.hypothesis_yaw_deg, 0.0);
    EXPECT_GE(r4.fitness, r1.fitness);
    EXPECT_GT(r4.fitness, 0.0);
    EXPECT_LE(r4.fitness, 1.0);
    EXPECT_NEAR(r4.T_target_source.linear()(2, 2), 1.0, 1e-6);
    EXPECT_NEAR(r1.T_target_source.linear()(2, 2), 1.0, 1e-6);
  }
}

TEST(Registrar, WithRansacEveryHypothesisCarriesItsConsensusRankedAsAsked) {
  // ransac_iterations > 0: each yaw hypothesis reports the share of source points in RANSAC's
  // consensus on its pass's matches, and the hypotheses are listed best first by the consensus
  // (select_by_consensus) or by the fitness of their poses; the first is the returned pose. The
  // RANSAC is seeded: the same call gives the same pose. Without RANSAC no consensus is reported.
  const std::string path = savePlanarModel(test::scratchDir("registrar_ransac"), false);
  const PointCloud scene = cornerScene();
  const PointCloud source = seenFrom(scene, 0.6 * kPi, Eigen::Vector3d(2.0, 1.0, 0.0));
  obmnet::ObmNetRegistrar::Options o;
  o.model_path = path;
  o.threads = 1;
  o.yaw_hypotheses = 4;
  const auto plain = obmnet::ObmNetRegistrar(o).align(source, scene);
  for (const auto& y : plain.hypotheses) EXPECT_EQ(y.consensus, -1.0) << "yaw " << y.yaw_deg;
  o.ransac_iterations = 300;
  for (const bool by_consensus : {true, false}) {
    SCOPED_TRACE(by_consensus ? "ranked by consensus" : "ranked by fitness");
    o.select_by_consensus = by_consensus;
    const auto r = obmnet::ObmNetRegistrar(o).align(source, scene);
    ASSERT_EQ(r.hypotheses.size(), 4u);
    for (std::size_t h = 0; h < r.hypotheses.size(); ++h) {
      const auto& y = r.hypotheses[h];
      std::printf("yaw %5.1f deg: consensus %.3f, fitness %.3f\n", y.yaw_deg, y.consensus,
                  y.fitness);
      EXPECT_GE(y.consensus, 0.0) << "hypothesis " << h;
      EXPECT_LE(y.consensus, 1.0) << "hypothesis " << h;
      EXPECT_NEAR(y.T_target_source.linear()(2, 2), 1.0, 1e-6) << "a planar pose, hypothesis " << h;
      if (h == 0) continue;
      if (by_consensus) {
        EXPECT_LE(y.consensus, r.hypotheses[h - 1].consensus) << "hypothesis " << h;
      } else {
        EXPECT_LE(y.fitness, r.hypotheses[h - 1].fitness) << "hypothesis " << h;
      }
    }
    EXPECT_GT(r.hypotheses.front().consensus, 0.0) << "no consensus on any hypothesis";
    EXPECT_TRUE(r.hypotheses.front().T_target_source.isApprox(r.T_target_source, 0.0));
    EXPECT_EQ(r.hypotheses.front().fitness, r.fitness);
    const auto again = obmnet::ObmNetRegistrar(o).align(source, scene);
    EXPECT_TRUE(again.T_target_source.isApprox(r.T_target_source, 0.0)) << "seeded RANSAC";
  }
}

TEST(Trainer, OverfitOneBatchLowersTheRotationError) {
  // The learning signal: a fresh small network fitted to one fixed batch of clean pairs (the
  // clouds share their samples) must bring its rotation error well down. A broken gradient path
  // (a detached weight, a sign error in a loss) leaves it where it started.
  const std::string dir = test::scratchDir("obmnet_overfit");
  const TrainConfig tc = test::smallTrainConfig();
  // Anisotropic blobs: a rotation of them is well defined.
  const std::vector<PointCloud> clouds = test::blobClouds(4, 200, 40);
  Trainer trainer(tc, clouds, clouds, dir);
  const auto rows = trainer.overfitOneBatch(30, 10, 1);
  ASSERT_GE(rows.size(), 5u);
  const double first = rows.front().rotation_error_deg;
  double last_train = first;
  for (const auto& r : rows)
    if (r.mode == "train") last_train = r.rotation_error_deg;
  for (const auto& r : rows)
    std::printf("overfit step %d loss %.4f error %.3f deg (%s)\n", r.step, r.loss,
                r.rotation_error_deg, r.mode.c_str());
  EXPECT_GT(first, 3.0) << "the untrained network should be off";
  EXPECT_LT(last_train, 0.5 * first) << "start " << first << "°, after 30 steps " << last_train << "°";
}

TEST(TrainConfig, LossWeightsAreReadAndChecked) {
  const auto load = [](const std::string& train) {
    return TrainConfig::load(ConfigNode::fromString("model: {}\ntrain: " + train + "\n", "w.yaml"));
  };
  EXPECT_TRUE(load("{}").paperLossWeights());
  const TrainConfig c = load("{loss_weights: [1, 0, 0.5]}");
  EXPECT_FALSE(c.paperLossWeights());
  EXPECT_DOUBLE_EQ(c.loss_weights[0], 1.0);
  EXPECT_DOUBLE_EQ(c.loss_weights[1], 0.0);
  EXPECT_DOUBLE_EQ(c.loss_weights[2], 0.5);
  for (const std::string bad : {"{loss_weights: [1, 1]}", "{loss_weights: [1, -1, 1]}",
                                "{loss_weights: [0, 0, 0]}"}) {
    try {
      load(bad);
      ADD_FAILURE() << "no error for " << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("loss_weights"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("w.yaml"), std::string::npos) << e.what();
    }
  }
}
