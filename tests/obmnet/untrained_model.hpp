#pragma once
// An untrained OBMNet written as a model file, for the tests of what surrounds the weights (the
// registrar's search, its RANSAC, the matchers' handling): its seed fixes the weights.
#include <torch/torch.h>

#include <cstdint>
#include <string>

#include "obm/obmnet/model.hpp"
#include "obm/obmnet/model_io.hpp"

namespace obm::test {

/// Writes the network of configuration `c`, initialised from `seed`, to `path` with `num_points`
/// sampled per cloud at inference; returns `path`.
inline std::string saveUntrainedModel(const std::string& path, const obmnet::ObmNetConfig& c,
                                      std::uint64_t seed, int num_points) {
  torch::manual_seed(seed);
  obmnet::ObmNet net(c);
  obmnet::ModelMeta meta;
  meta.num_points = num_points;
  meta.description = "untrained (unit test)";
  obmnet::saveModel(path, net, meta);
  return path;
}

}  // namespace obm::test
