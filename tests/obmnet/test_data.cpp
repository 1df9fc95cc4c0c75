// Pair protocols, normalisation, object split, model files and the inference API.
#include "test_data.hpp"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/mesh.hpp"
#include "obm/obmnet/data.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/obmnet/object_set.hpp"
#include "obm/obmnet/registrar.hpp"
#include "obm/obmnet/trainer.hpp"
#include "test_clouds.hpp"
#include "untrained_model.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

PointCloud sphereCloud(std::size_t n, std::uint64_t seed) {
  return test::unitSphereSamples(n, seed);
}

/// `f` must throw ConfigError whose message names `needle`.
template <class F>
void expectConfigErrorNaming(F&& f, const std::string& needle, const std::string& why) {
  try {
    f();
    ADD_FAILURE() << why;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TriangleMesh boxMesh(const std::string& name, float sx, float sy, float sz) {
  TriangleMesh m;
  m.name = name;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back((i & 1 ? sx : -sx), (i & 2 ? sy : -sy), (i & 4 ? sz : -sz));
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (auto& t : f) m.faces.emplace_back(t[0], t[1], t[2]);
  return m;
}

/// A small network (16 features, 4 samples, 1 iteration) saved to `path` with 64 points.
obmnet::ObmNet saveSmallModel(const std::string& path, std::uint64_t seed, int n_keypoints = 256) {
  obmnet::ObmNetConfig c;
  c.emb_dims = 16;
  c.n_samples = 4;
  c.n_iters = 1;
  c.n_keypoints = n_keypoints;
  torch::manual_seed(seed);
  obmnet::ObmNet net(c);
  ModelMeta meta;
  meta.num_points = 64;
  meta.description = "unit test";
  saveModel(path, net, meta);
  return net;
}

/// A trainer of `model` on 64-point pairs of one 128-point sphere, with `val_pairs` validation
/// pairs, writing into `out`.
std::unique_ptr<Trainer> sphereTrainer(const obmnet::ObmNetConfig& model, int val_pairs,
                                       const std::string& out) {
  TrainConfig tc;
  tc.model = model;
  tc.protocol.num_points = 64;
  tc.val_protocol.num_points = 64;
  tc.val_pairs = val_pairs;
  std::vector<PointCloud> clouds{sphereCloud(128, 21)};
  return std::make_unique<Trainer>(tc, clouds, clouds, out);
}

/// An untrained model for the registrar tests, written to DIR/m.pt: `c` at width 16 with 8 overlap
/// draws, 96 points per cloud, weights drawn from `seed`.
std::string saveRegistrarModel(const std::string& dir, obmnet::ObmNetConfig c, std::uint64_t seed) {
  c.emb_dims = 16;
  c.n_samples = 8;
  return test::saveUntrainedModel(dir + "/m.pt", c, seed, 96);
}

}  // namespace

TEST(PairProtocol, CleanPairIsExactlyTheTransformedSource) {
  const auto obj = sphereCloud(1500, 1);
  std::mt19937_64 rng(2);
  const auto p = makePair(obj, PairProtocol::preset("clean"), rng);
  ASSERT_EQ(p.source.size(), 1024u);
  ASSERT_EQ(p.target.size(), 1024u);
  EXPECT_DOUBLE_EQ(p.overlap, 1.0);
  // Every target point is T·(some source point) — same points, shuffled.
  double worst = 0.0;
  for (const auto& q : p.target.points) {
    double best = 1e9;
    for (const auto& s : p.source.points)
      best = std::min(best, (p.T_target_source * s.cast<double>() - q.cast<double>()).norm());
    worst = std::max(worst, best);
  }
  EXPECT_LT(worst, 1e-5);
  // Rotation within the protocol's bounds: each Euler angle in [0, 45°] gives an angle ≤ ~78°.
  EXPECT_LE(rotationAngle(p.T_target_source.linear()) * kRadToDeg, 80.0);
  EXPECT_LE(p.T_target_source.translation().cwiseAbs().maxCoeff(), 0.5);
}

TEST(PairProtocol, PartialCropRecordsOverlapAndSizes) {
  const auto obj = sphereCloud(1024, 3);
  std::mt19937_64 rng(4);
  double mean = 0.0;
  for (int i = 0; i < 20; ++i) {
    const auto p = makePair(obj, PairProtocol::preset("partial"), rng);
    EXPECT_EQ(p.source.size(), 768u);
    EXPECT_EQ(p.target.size(), 768u);
    EXPECT_GT(p.overlap, 0.3);
    EXPECT_LT(p.overlap, 1.0);
    mean += p.overlap / 20.0;
  }
  // Two random 75 % caps of a sphere share well over half of the source.
  EXPECT_GT(mean, 0.5);
  const auto pn = makePair(obj, PairProtocol::preset("partial_noise"), rng);
  EXPECT_EQ(pn.source.size(), 640u);
}

TEST(PairProtocol, JitterAndOutliers) {
  const auto obj = sphereCloud(1024, 5);
  std::mt19937_64 rng(6);
  auto proto = PairProtocol::preset("jitter");
  const auto p = makePair(obj, proto, rng);
  // Jitter moves points off the unit sphere by at most the clip per axis.
  double max_dev = 0.0;
  for (const auto& s : p.source.points) max_dev = std::max(max_dev, std::abs(s.norm() - 1.0));
  EXPECT_GT(max_dev, 1e-3);
  EXPECT_LE(max_dev, std::sqrt(3.0) * proto.jitter_clip + 1e-6);
  const auto o = makePair(obj, PairProtocol::preset("outliers"), rng);
  EXPECT_EQ(o.source.size(), 1024u + 200u);
  for (const auto& s : o.source.points) EXPECT_LE(s.cwiseAbs().maxCoeff(), 1.0f + 1e-6f);
  EXPECT_THROW(PairProtocol::preset("nope"), ConfigError);
}

TEST(PairProtocol, DeterministicForASeed) {
  const auto obj = sphereCloud(1200, 7);
  std::mt19937_64 a(8), b(8);
  const auto p = makePair(obj, PairProtocol::preset("partial_noise"), a);
  const auto q = makePair(obj, PairProtocol::preset("partial_noise"), b);
  EXPECT_TRUE(p.T_target_source.isApprox(q.T_target_source, 0.0));
  EXPECT_EQ(p.source.points[10], q.source.points[10]);
}

TEST(PairProtocol, UniformJitterMixesNoiseLevels) {
  const auto obj = sphereCloud(1024, 15);
  std::mt19937_64 rng(16);
  auto proto = PairProtocol::preset("jitter");
  proto.jitter_uniform = true;
  // The RMS distance of the source points from the sphere estimates each pair's σ: drawn from
  // [0, σ], the levels must spread over most of the range instead of sitting at σ.
  double lo = 1e9, hi = 0.0;
  for (int i = 0; i < 30; ++i) {
    const auto p = makePair(obj, proto, rng);
    double ss = 0.0;
    for (const auto& s : p.source.points) ss += std::pow(s.norm() - 1.0, 2);
    const double rms = std::sqrt(ss / static_cast<double>(p.source.size()));
    lo = std::min(lo, rms);
    hi = std::max(hi, rms);
  }
  EXPECT_LT(lo, 0.3 * proto.jitter_sigma);
  EXPECT_GT(hi, 0.7 * proto.jitter_sigma);
  EXPECT_LT(hi, 1.2 * proto.jitter_sigma);
}

TEST(Curriculum, RampsCropAndJitterFromItsStartLevel) {
  const auto target = PairProtocol::preset("partial_noise");  // 640 of 1024, σ 0.01
  // From clean pairs: epoch 1 is clean, half-way is half the crop and jitter.
  const auto c1 = curriculumProtocol(target, 1, 10);
  EXPECT_EQ(c1.partial_keep, 1024);
  EXPECT_DOUBLE_EQ(c1.jitter_sigma, 0.0);
  const auto c6 = curriculumProtocol(target, 6, 10);
  EXPECT_EQ(c6.partial_keep, 1024 - 192);
  EXPECT_NEAR(c6.jitter_sigma, 0.005, 1e-12);
  // A start level of 0.3: epoch 1 already has 30 % of the crop and the jitter.
  const auto s1 = curriculumProtocol(target, 1, 10, 0.3);
  EXPECT_EQ(s1.partial_keep, 1024 - 115);
  EXPECT_NEAR(s1.jitter_sigma, 0.003, 1e-12);
  const auto s6 = curriculumProtocol(target, 6, 10, 0.3);
  EXPECT_NEAR(s6.jitter_sigma, 0.0065, 1e-12);
  // After the curriculum: the target itself.
  EXPECT_EQ(curriculumProtocol(target, 10, 10, 0.3).partial_keep, 640);
  EXPECT_DOUBLE_EQ(curriculumProtocol(target, 12, 10, 0.3).jitter_sigma, 0.01);
}

TEST(NeighbourMean, ReducesJitterAndCommutesWithRigidMotion) {
  const auto obj = sphereCloud(1024, 17);
  std::mt19937_64 rng(18);
  std::normal_distribution<float> G(0.f, 0.01f);
  PointCloud noisy = obj;
  for (auto& p : noisy.points) p += Vector3f(G(rng), G(rng), G(rng));
  // Spread of the radius around its mean: the noise. (The mean itself moves inwards: averaging
  // over a cap of the sphere is a blur of about the sampling spacing, the same for any cloud.)
  auto radialSpread = [](const PointCloud& c) {
    double s = 0.0, ss = 0.0;
    for (const auto& p : c.points) {
      s += p.norm();
      ss += double(p.norm()) * p.norm();
    }
    const double n = static_cast<double>(c.size());
    return std::sqrt(std::max(0.0, ss / n - (s / n) * (s / n)));
  };
  const PointCloud smooth = neighbourMean(noisy, 8);
  ASSERT_EQ(smooth.size(), noisy.size());
  // Radial noise σ = 0.01 drops by about √9 = 3.
  EXPECT_LT(radialSpread(smooth), 0.5 * radialSpread(noisy));
  // Moving the cloud and then averaging = averaging and then moving.
  const Isometry3d T = makeIsometry(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())
                                        .toRotationMatrix(),
                                    Eigen::Vector3d(0.3, -0.2, 0.5));
  const PointCloud a = neighbourMean(noisy.transformed(T, "x"), 8);
  const PointCloud b = smooth.transformed(T, "x");
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, double((a.points[i] - b.points[i]).norm()));
  EXPECT_LT(worst, 1e-5);
  // k = 0 is the identity.
  EXPECT_EQ(neighbourMean(noisy, 0).points[5], noisy.points[5]);
}

TEST(PairNormalization, RoundTripAndDenormalize) {
  const auto obj = sphereCloud(500, 9);
  std::mt19937_64 rng(10);
  auto p = makePair(obj, PairProtocol::preset("partial"), rng);
  for (auto& q : p.source.points) q = 3.f * q + Vector3f(5, -2, 1);  // another scale and place
  p.target = p.source;
  const Isometry3d T = randomRienetTransform(rng);
  p.target.transform(T);
  const auto n = PairNormalization::compute(p.source, p.target, 1.0);
  PointCloud s = p.source, t = p.target;
  n.applySource(s);
  n.applyTarget(t);
  // The normalised pair is related by normalize(T), and denormalize undoes it.
  const Isometry3d That = n.normalize(T);
  for (std::size_t i = 0; i < s.size(); i += 37)
    EXPECT_LT((That * s.points[i].cast<double>() - t.points[i].cast<double>()).norm(), 1e-4);
  EXPECT_TRUE(n.denormalize(That).isApprox(T, 1e-12));
  double r = 0;
  for (const auto& q : s.points) r = std::max(r, static_cast<double>(q.norm()));
  EXPECT_LE(r, 1.0 + 1e-5);
}

TEST(PairNormalization, SharedCentroidKeepsTheIdentityOfSensorFrameScans) {
  // Two "sweeps" of one place from sensors 1 m apart: the target sees more of the scene ahead,
  // so the two centroids differ by far more than the motion.
  PointCloud world;
  for (int i = 0; i < 400; ++i) world.points.emplace_back(0.1f * i, (i % 2) ? 4.f : -4.f, 0.5f);
  PointCloud source, target;
  for (const auto& p : world.points) {
    if (p.x() < 20.f) source.points.push_back(p);
    if (p.x() >= 1.f) target.points.push_back(p - Vector3f(1.f, 0.f, 0.f));
  }
  Isometry3d T = Isometry3d::Identity();  // T_target_source: the source sensor is 1 m behind
  T.translation() = Eigen::Vector3d(-1.0, 0.0, 0.0);
  const auto separate = PairNormalization::compute(source, target, 1.0);
  const auto shared = PairNormalization::compute(source, target, 1.0, true);
  EXPECT_TRUE(shared.centroid_source.isApprox(shared.centroid_target));
  // Shared centre: the normalised motion is the real one, scaled (the identity is 1 m off).
  EXPECT_NEAR(shared.normalize(T).translation().norm() / shared.scale, 1.0, 1e-9);
  // Separate centres: the network would start at the offset of the centroids instead.
  EXPECT_GT(separate.normalize(T).translation().norm() / separate.scale, 5.0);
  // Both undo exactly.
  EXPECT_TRUE(shared.denormalize(shared.normalize(T)).isApprox(T, 1e-12));
}

TEST(ObjectSet, SplitIsByNameAndStable) {
  int counts[3] = {0, 0, 0};
  for (int i = 0; i < 1000; ++i) {
    const auto s = splitForName("object_" + std::to_string(i), 0.15, 0.25);
    EXPECT_EQ(s, splitForName("object_" + std::to_string(i), 0.15, 0.25));
    ++counts[static_cast<int>(s)];
  }
  EXPECT_NEAR(counts[static_cast<int>(Split::Test)], 250, 50);
  EXPECT_NEAR(counts[static_cast<int>(Split::Validation)], 150, 45);
  std::vector<TriangleMesh> meshes;
  for (int i = 0; i < 12; ++i)
    meshes.push_back(boxMesh("box" + std::to_string(i), 1.f + i, 1.f, 0.5f));
  ObjectSetOptions o;
  o.surface_points = 256;
  o.keep_points = 128;
  const auto set = buildObjectSet(meshes, o);
  EXPECT_EQ(set.train.size() + set.val.size() + set.test.size(), 12u);
  // Order independence: reversed input gives the same clouds.
  std::reverse(meshes.begin(), meshes.end());
  const auto set2 = buildObjectSet(meshes, o);
  ASSERT_EQ(set.train.size(), set2.train.size());
  for (const auto& c : set.train) {
    const auto it = std::find_if(set2.train.begin(), set2.train.end(),
                                 [&](const PointCloud& d) { return d.frame_id == c.frame_id; });
    ASSERT_NE(it, set2.train.end());
    EXPECT_EQ(it->points, c.points);
    EXPECT_EQ(c.size(), 128u);
  }
}

TEST(ObjectSet, ReferenceSamplesLieOnTheSameNormalisedSurfaceAndChangeNothingElse) {
  std::vector<TriangleMesh> meshes;
  for (int i = 0; i < 6; ++i)
    meshes.push_back(boxMesh("slab" + std::to_string(i), 1.f + i, 0.7f, 0.3f));
  ObjectSetOptions o;
  o.surface_points = 256;
  o.keep_points = 256;
  const auto plain = buildObjectSet(meshes, o);
  EXPECT_TRUE(plain.train_reference.empty() && plain.val_reference.empty() &&
              plain.test_reference.empty());
  o.reference_points = 1000;
  const auto set = buildObjectSet(meshes, o);
  const std::vector<const std::vector<PointCloud>*> groups{&set.train, &set.val, &set.test},
      refs{&set.train_reference, &set.val_reference, &set.test_reference},
      plain_groups{&plain.train, &plain.val, &plain.test};
  for (std::size_t g = 0; g < 3; ++g) {
    ASSERT_EQ(groups[g]->size(), refs[g]->size());
    for (std::size_t i = 0; i < groups[g]->size(); ++i) {
      const auto& c = (*groups[g])[i];
      const auto& r = (*refs[g])[i];
      EXPECT_EQ(c.points, (*plain_groups[g])[i].points) << c.frame_id;  // unchanged
      EXPECT_EQ(r.frame_id, c.frame_id);
      ASSERT_EQ(r.size(), 1000u);
      // Both are samples of one box in one frame: the reference's bounding box is the points'
      // (within a sample spacing), and every reference point lies on a face of that box.
      Vector3f lo = c.points[0], hi = c.points[0];
      for (const auto& p : c.points) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      for (const auto& p : r.points) {
        const float to_face =
            std::min((p - lo).cwiseAbs().minCoeff(), (p - hi).cwiseAbs().minCoeff());
        EXPECT_LT(to_face, 0.01f) << c.frame_id;
        EXPECT_TRUE(((p - lo).array() > -0.05f).all() && ((hi - p).array() > -0.05f).all());
      }
    }
  }
}

TEST(ModelFile, SaveLoadRoundTripAndClearErrors) {
  const std::string dir = obm::test::scratchDir("obmnet_model_file");
  obmnet::ObmNet net = saveSmallModel(dir + "/m.pt", 3);
  ModelMeta meta2;
  auto loaded = loadModel(dir + "/m.pt", &meta2);
  EXPECT_EQ(meta2.num_points, 64);
  EXPECT_EQ(loaded->config().emb_dims, 16);
  auto pa = net->named_parameters(), pb = loaded->named_parameters();
  for (const auto& p : pa) EXPECT_TRUE(torch::equal(p.value(), pb[p.key()])) << p.key();

  // Missing file, garbage, a LibTorch archive that is not a model.
  try {
    loadModel(dir + "/missing.pt");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.pt"), std::string::npos);
  }
  std::ofstream(dir + "/garbage.pt") << "not a model";
  try {
    loadModel(dir + "/garbage.pt");
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("garbage.pt"), std::string::npos);
  }
  torch::serialize::OutputArchive other;
  other.write("x", torch::ones({2}));
  other.save_to(dir + "/other.pt");
  EXPECT_THROW(loadModel(dir + "/other.pt"), FormatError);
  // Truncated file.
  {
    std::ifstream in(dir + "/m.pt", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/trunc.pt", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_THROW(loadModel(dir + "/trunc.pt"), FormatError);
}

TEST(Trainer, WarmStartNeedsTheSameLayerShapesOnly) {
  const std::string dir = obm::test::scratchDir("obmnet_warm_start");
  const obmnet::ObmNetConfig c = saveSmallModel(dir + "/m.pt", 5, 16)->config();
  auto trainerWith = [&](const obmnet::ObmNetConfig& mc) {
    return sphereTrainer(mc, 1, dir + "/run");
  };
  // Wider neighbourhoods change no layer shape: the weights carry over.
  obmnet::ObmNetConfig wider = c;
  wider.k1 = 12;
  wider.k2 = 8;
  EXPECT_NO_THROW(trainerWith(wider)->initializeFrom(dir + "/m.pt"));
  // Another feature width does: a clear error naming the file.
  obmnet::ObmNetConfig other = c;
  other.emb_dims = 32;
  try {
    trainerWith(other)->initializeFrom(dir + "/m.pt");
    FAIL() << "a shape mismatch must be an error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("m.pt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("shape"), std::string::npos) << e.what();
  }
}

TEST(Trainer, AModelWithoutEdgeNormalsWarmStartsOneWithThemUnchanged) {
  const std::string dir = obm::test::scratchDir("obmnet_warm_start_normals");
  obmnet::ObmNetConfig plain = saveSmallModel(dir + "/m.pt", 7, 16)->config();
  plain.k1 = 12;  // normals from 12 neighbours of the 64 points
  auto trainerWith = [&](const obmnet::ObmNetConfig& mc, const std::string& run) {
    return sphereTrainer(mc, 3, dir + "/" + run);
  };
  obmnet::ObmNetConfig with_normals = plain;
  with_normals.edge_normals = true;
  with_normals.normal_neighbours = 12;
  auto a = trainerWith(plain, "plain");
  a->initializeFrom(dir + "/m.pt");
  auto b = trainerWith(with_normals, "normals");
  const ValidationScores fresh = b->validate();  // its own random weights
  b->initializeFrom(dir + "/m.pt");
  const ValidationScores sa = a->validate(), sb = b->validate();
  // The normal channels start with zero weights: the same poses, loss and matches as the model.
  EXPECT_GT(sa.mie_r, 1e-3);
  EXPECT_NEAR(sb.mie_r, sa.mie_r, 1e-3 * sa.mie_r);
  EXPECT_NEAR(sb.loss, sa.loss, 1e-4 * std::abs(sa.loss));
  EXPECT_NEAR(sb.inlier_ratio, sa.inlier_ratio, 1e-6);
  EXPECT_GT(std::abs(fresh.loss - sb.loss), 1e-4 * std::abs(sa.loss))
      << "the warm start must have replaced the fresh weights";
  // The other way round the extra columns have nowhere to go: a shape error naming the file.
  const std::string normals_model = dir + "/n.pt";
  {
    torch::manual_seed(8);
    obmnet::ObmNet net(with_normals);
    ModelMeta meta;
    meta.num_points = 64;
    saveModel(normals_model, net, meta);
  }
  const auto reloaded = loadModel(normals_model)->config();  // the settings travel with the weights
  EXPECT_TRUE(reloaded.edge_normals);
  EXPECT_EQ(reloaded.normal_neighbours, 12);
  expectConfigErrorNaming(
      [] {
        ObmNetConfig::load(
            ConfigNode::fromString("edge_normals: true\nnormal_neighbours: 2\n", "m.yaml"));
      },
      "normal_neighbours", "two neighbours cannot give a normal");
  expectConfigErrorNaming([&] { trainerWith(plain, "back")->initializeFrom(normals_model); },
                          "n.pt", "a model with edge normals cannot warm-start one without");
}

TEST(Registrar, AlignsAndReportsDiagnostics) {
  obmnet::ObmNetConfig c;
  c.n_iters = 2;
  const std::string model = saveRegistrarModel(obm::test::scratchDir("obmnet_registrar"), c, 1);
  obmnet::ObmNetRegistrar reg({model, 0, 1, 0});
  EXPECT_EQ(reg.numPoints(), 96);
  const auto src = sphereCloud(300, 11);
  PointCloud tgt = src;
  tgt.transform(makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(10, 0, 0)));
  const auto r = reg.align(src, tgt);
  EXPECT_EQ(r.inlier_weights.size(), 96u);
  EXPECT_EQ(r.source_indices.size(), 96u);
  EXPECT_GT(r.alpha, 0.0);
  EXPECT_TRUE(r.T_target_source.matrix().allFinite());
  EXPECT_NEAR(r.T_target_source.linear().determinant(), 1.0, 1e-6);
  // The centroid shift is undone exactly whatever the network does: a pure translation of a
  // whole cloud comes back in the pose.
  const auto r2 = reg.align(src, tgt);
  EXPECT_TRUE(r.T_target_source.isApprox(r2.T_target_source, 0.0));  // deterministic
  PointCloud tiny;
  tiny.points.resize(3, Vector3f::Zero());
  EXPECT_THROW(reg.align(tiny, tgt), ContractError);
}

TEST(Registrar, KeepsItsStartWhenTheStartIsFitterThanTheNetwork) {
  // An untrained network on a pair whose true pose is the identity (the target is half of the
  // source, both about one centre): its pose is worse than not moving, and with
  // keep_start_if_fitter the registrar must notice it by its own fitness and return the start.
  obmnet::ObmNetConfig c;
  c.n_iters = 2;
  c.shared_centroid = true;  // the start is the identity of the clouds as given
  // Seeded weights: the network's (poor) pose does not depend on the tests that ran before.
  const std::string model =
      saveRegistrarModel(obm::test::scratchDir("obmnet_registrar_start"), c, 2);
  const auto src = sphereCloud(300, 11);
  PointCloud tgt;
  for (const auto& p : src.points)
    if (p.x() > -0.2f) tgt.points.push_back(p);
  obmnet::ObmNetRegistrar::Options o{model, 0, 1, 0};
  const auto plain = obmnet::ObmNetRegistrar(o).align(src, tgt);
  o.keep_start_if_fitter = true;
  const auto verified = obmnet::ObmNetRegistrar(o).align(src, tgt);
  EXPECT_FALSE(plain.kept_start);
  ASSERT_TRUE(verified.kept_start) << "network fitness " << plain.fitness;
  EXPECT_GT(verified.fitness, plain.fitness);
  EXPECT_TRUE(verified.T_target_source.isApprox(Isometry3d::Identity(), 1e-9));
  EXPECT_FALSE(plain.T_target_source.isApprox(Isometry3d::Identity(), 1e-3));
}

TEST(Registrar, TheTeachersRefinementAlignsWhatAnUntrainedNetworkMisses) {
  // An untrained network on an elongated cloud and its copy turned by 10° about z: its own pose
  // is off; refined as the self-training teacher labels a pair (Options::teacher_refine), the
  // pose is the true one.
  obmnet::ObmNetConfig c;
  c.n_iters = 2;
  const std::string model =
      saveRegistrarModel(obm::test::scratchDir("obmnet_registrar_teacher"), c, 3);
  PointCloud src = sphereCloud(300, 11);
  for (auto& p : src.points) p = Vector3f(p.x(), 0.6f * p.y(), 0.35f * p.z());
  const Isometry3d T_true = makeIsometry(
      Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
      Eigen::Vector3d(0.05, -0.02, 0.01));
  PointCloud tgt = src;
  tgt.transform(T_true);
  obmnet::ObmNetRegistrar::Options o{model, 300, 1, 0};
  const auto plain = obmnet::ObmNetRegistrar(o).align(src, tgt);
  auto rotErrDeg = [&](const Isometry3d& T) {
    return Eigen::AngleAxisd(T_true.linear().transpose() * T.linear()).angle() * 180.0 / M_PI;
  };
  ASSERT_GT(rotErrDeg(plain.T_target_source), 1.0) << "precondition: the untrained network is off";
  o.teacher_refine = true;
  o.teacher.point_to_plane = true;
  o.teacher.initial_max_distance = 0.3;
  o.teacher.max_distance = 0.05;
  const auto refined = obmnet::ObmNetRegistrar(o).align(src, tgt);
  EXPECT_LT(rotErrDeg(refined.T_target_source), 0.05);
  EXPECT_LT((refined.T_target_source.translation() - T_true.translation()).norm(), 1e-3);
  EXPECT_GE(refined.fitness, plain.fitness);
}

TEST(Registrar, ReportsEveryYawHypothesisFittestFirst) {
  // With H yaw hypotheses the result lists all H network poses, fittest first; the first is the
  // returned pose with its α, overlap and weights, and each pose's fitness is the score that
  // would be reported had it been chosen (the hypotheses differ: the source was turned).
  obmnet::ObmNetConfig c;
  c.n_iters = 2;
  const std::string model = saveRegistrarModel(obm::test::scratchDir("obmnet_registrar_yaw"), c, 4);
  const auto src = sphereCloud(300, 11);
  PointCloud tgt;
  for (const auto& p : src.points)
    if (p.x() > -0.2f) tgt.points.push_back(p);
  obmnet::ObmNetRegistrar::Options o{model, 0, 1, 0};
  o.yaw_hypotheses = 4;
  const auto r = obmnet::ObmNetRegistrar(o).align(src, tgt);
  ASSERT_EQ(r.hypotheses.size(), 4u);
  std::vector<double> yaws;
  for (std::size_t h = 0; h < r.hypotheses.size(); ++h) {
    const auto& y = r.hypotheses[h];
    yaws.push_back(y.yaw_deg);
    if (h > 0) {
      EXPECT_LE(y.fitness, r.hypotheses[h - 1].fitness) << "hypothesis " << h;
    }
    EXPECT_EQ(y.inlier_weights.size(), r.inlier_weights.size());
    EXPECT_EQ(y.overlap_membership.size(), r.overlap_membership.size());
    EXPECT_GT(y.alpha, 0.0);
    EXPECT_NEAR(y.T_target_source.linear().determinant(), 1.0, 1e-6);
  }
  std::sort(yaws.begin(), yaws.end());
  EXPECT_EQ(yaws, (std::vector<double>{0.0, 90.0, 180.0, 270.0}));
  EXPECT_TRUE(r.hypotheses.front().T_target_source.isApprox(r.T_target_source, 0.0));
  EXPECT_EQ(r.hypotheses.front().fitness, r.fitness);
  EXPECT_EQ(r.hypotheses.front().yaw_deg, r.hypothesis_yaw_deg);
  EXPECT_EQ(r.hypotheses.front().alpha, r.alpha);
  EXPECT_EQ(r.hypotheses.front().inlier_weights, r.inlier_weights);
  EXPECT_FALSE(r.hypotheses[1].T_target_source.isApprox(r.T_target_source, 1e-3));
  // One hypothesis: one entry, the result itself.
  o.yaw_hypotheses = 1;
  const auto single = obmnet::ObmNetRegistrar(o).align(src, tgt);
  ASSERT_EQ(single.hypotheses.size(), 1u);
  EXPECT_TRUE(single.hypotheses.front().T_target_source.isApprox(single.T_target_source, 0.0));
}

TEST(Registrar, ModelTrainedWithoutTheRoadCutsItAtInference) {
  // model.ground_band: the registrar drops the ground plane's returns before sampling, and the
  // reported source indices still point at the input points the network saw.
  obmnet::ObmNetConfig c;
  c.n_iters = 1;
  c.ground_band = 0.3;
  const std::string model =
      saveRegistrarModel(obm::test::scratchDir("obmnet_registrar_ground"), c, 3);
  PointCloud scan = sphereCloud(300, 3);  // the unit sphere around the sensor...
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<float> u(-10.f, 10.f);
  for (int i = 0; i < 2000; ++i) scan.points.emplace_back(u(rng), u(rng), -1.7f);  // ...and a road
  obmnet::ObmNetRegistrar reg({model, 0, 1, 0});
  const auto r = reg.align(scan, scan);
  ASSERT_EQ(r.source_sampled.size(), 96u);
  ASSERT_EQ(r.source_indices.size(), 96u);
  for (std::size_t i = 0; i < r.source_indices.size(); ++i) {
    EXPECT_LT(r.source_indices[i], 300u) << "a road point was sampled";
    EXPECT_EQ(r.source_sampled.points[i], scan.points[r.source_indices[i]]);
  }
  for (const auto& p : r.target_sampled.points) EXPECT_GT(p.z(), -1.4f);
}

/// A fuzzing finding of tests/fuzz/regressions/model/: loading it is a FormatError whose message
/// names the file and holds every one of `parts`.
static void expectModelFindingRejected(const std::string& name, const std::vector<std::string>& parts) {
  const std::string found = obm::test::sourceDir() + "/tests/fuzz/regressions/model/" + name;
  ASSERT_TRUE(std::filesystem::exists(found));
  try {
    loadModel(found);
    FAIL() << name << " loaded";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(found), std::string::npos) << what;
    for (const std::string& part : parts) EXPECT_NE(what.find(part), std::string::npos) << what;
  }
}

TEST(ModelFile, FuzzFindingDamagedTorchScriptIsACrcErrorBeforeLibTorchParsesIt) {
  // Found by tests/fuzz (scripts/fuzz.sh model): a model whose TorchScript section has a name
  // changed ("weight" written over a type). LibTorch 1.13's parser crashed on it under the
  // sanitizers (SEGV in ScriptTypeParser::parseClassConstant). The archive check rejects the
  // entry (named: "code/...") by its CRC-32 before LibTorch sees it.
  expectModelFindingRejected("torchscript_parser_segv.pt", {"code/", "CRC-32"});
}

TEST(ModelFile, FuzzFindingDamagedDeflatedTorchScriptIsAnErrorBeforeLibTorchParsesIt) {
  // Found by a one-hour run of tests/fuzz (scripts/fuzz.sh 3600 model), after the CRC-32 check
  // above: one byte changed inside a TorchScript source that the archive stores *deflated*
  // (code/__torch__/___torch_mangle_15.py), which the check then passed by position only. LibTorch
  // inflated it and its parser crashed (SEGV in ScriptTypeParser::parseClassConstant). Deflated
  // entries are now inflated and checked against their size and CRC-32.
  expectModelFindingRejected("deflated_torchscript_damaged.pt", {"___torch_mangle_15.py", "inflate"});
}

TEST(ModelFile, EveryCorruptionLoadsOrIsAFormatErrorNamingTheFile) {
  // A deterministic sweep over damaged copies of a real model file (the inputs a fuzzer of model
  // files would start from): a byte flipped at 160 offsets spread over the file, and the file cut
  // at 40 lengths. Each must either load the very same weights (a flip in the archive's padding)
  // or throw obm::FormatError naming the file; any other exception, or a crash, fails. Before the
  // archive's CRC-32 check, flips inside weight data loaded as different numbers.
  const std::string dir = obm::test::scratchDir("obmnet_model_corrupt");
  obmnet::ObmNet original = saveSmallModel(dir + "/m.pt", 5);
  const auto weights = original->named_parameters();
  std::string bytes;
  {
    std::ifstream in(dir + "/m.pt", std::ios::binary);
    bytes.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 1000u);
  const std::string path = dir + "/bad.pt";
  int loaded = 0, rejected = 0;
  auto attempt = [&](const std::string& content, const std::string& what) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << content;
    try {
      ModelMeta meta;
      auto net = loadModel(path, &meta);
      ++loaded;
      // A copy that loads is the same network: the damage was outside every entry's bytes (the
      // archive's alignment padding), never a weight that silently changed.
      const auto got = net->named_parameters();
      for (const auto& p : weights)
        EXPECT_TRUE(torch::equal(p.value(), got[p.key()])) << what << ": weight " << p.key();
    } catch (const FormatError& e) {
      ++rejected;
      EXPECT_NE(std::string(e.what()).find("bad.pt"), std::string::npos) << what << ": " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not a FormatError: " << e.what();
    }
  };
  for (int k = 0; k < 160; ++k) {
    const std::size_t at = bytes.size() * static_cast<std::size_t>(k) / 160;
    std::string c = bytes;
    c[at] = static_cast<char>(c[at] ^ 0x5a);
    attempt(c, "byte " + std::to_string(at) + " flipped");
  }
  for (int k = 0; k < 40; ++k)
    attempt(bytes.substr(0, bytes.size() * static_cast<std::size_t>(k) / 40),
            "cut at " + std::to_string(bytes.size() * static_cast<std::size_t>(k) / 40));
  EXPECT_EQ(loaded + rejected, 200);
  EXPECT_GT(rejected, 40);  // every cut, and the flips in headers and the embedded config
  std::printf("corrupted model files: %d loaded, %d rejected\n", loaded, rejected);
}
