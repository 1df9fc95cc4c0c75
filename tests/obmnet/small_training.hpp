#pragma once
// A small OBMNet and trainer configuration (a step takes well under a second on a CPU) and
// clouds to train it on, for the tests of the training machinery.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/obmnet/trainer.hpp"

namespace obm::test {

/// emb_dims 32, k1 = 8, k2 = 4, 32 keypoints, 8 overlap samples, 2 iterations; 96-point pairs
/// in batches of 4, lr 10⁻³, one thread.
inline obmnet::TrainConfig smallTrainConfig() {
  obmnet::ObmNetConfig mc;
  mc.emb_dims = 32;
  mc.dim = 4;
  mc.k1 = 8;
  mc.k2 = 4;
  mc.n_keypoints = 32;
  mc.n_samples = 8;
  mc.n_iters = 2;
  obmnet::TrainConfig tc;
  tc.model = mc;
  tc.protocol.num_points = 96;
  tc.protocol.max_angle_deg = 45.0;
  tc.val_protocol = tc.protocol;
  tc.val_pairs = 1;
  tc.batch_size = 4;
  tc.lr = 1e-3;
  tc.threads = 1;
  return tc;
}

/// `count` anisotropic Gaussian blobs of `points` points (seeds seed0, seed0 + 1, …): a rotation
/// of them is well defined.
inline std::vector<PointCloud> blobClouds(int count, int points, std::uint64_t seed0) {
  std::vector<PointCloud> clouds;
  for (int o = 0; o < count; ++o) {
    std::mt19937_64 rng(seed0 + static_cast<std::uint64_t>(o));
    std::normal_distribution<float> G(0.f, 1.f);
    PointCloud c;
    for (int i = 0; i < points; ++i)
      c.points.emplace_back(0.8f * G(rng), 0.45f * G(rng) + 0.2f * std::sin(3.0f * i), 0.2f * G(rng));
    clouds.push_back(c);
  }
  return clouds;
}

/// Two validation pairs whose target is `cloud` itself: one whose true pose is the identity and
/// one whose true pose is 5 units away. Whatever a model estimates for them, a score against the
/// truth that is all-right on the first is all-wrong on the second.
inline std::vector<obmnet::RegistrationPair> sameCloudPairs(const PointCloud& cloud) {
  obmnet::RegistrationPair same;
  same.source = cloud;
  same.target = cloud;
  obmnet::RegistrationPair elsewhere = same;
  elsewhere.T_target_source.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  return {same, elsewhere};
}

/// A sampler of `protocol` pairs of `cloud`.
inline obmnet::PairSampler cloudPairSampler(const PointCloud& cloud,
                                            const obmnet::PairProtocol& protocol) {
  return [cloud, protocol](std::mt19937_64& rng, int) { return obmnet::makePair(cloud, protocol, rng); };
}

}  // namespace obm::test
