// untrained_like MODEL OUT [SEED]: writes to OUT a network of MODEL's configuration (the same
// layers and sizes, the same inference metadata) with freshly initialised weights. Used by
// scripts/check_models_matter.sh to show that each shipped model is told from an untrained one by
// at least one test. Not a test itself.
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>

#include <torch/torch.h>

#include "obm/obmnet/model.hpp"
#include "obm/obmnet/model_io.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: untrained_like MODEL OUT [SEED]\n");
    return 2;
  }
  try {
    obm::obmnet::ModelMeta meta;
    const obm::obmnet::ObmNet trained = obm::obmnet::loadModel(argv[1], &meta);
    torch::manual_seed(argc > 3 ? std::stoull(argv[3]) : 1);
    obm::obmnet::ObmNet fresh(trained->config());
    meta.description = "untrained network of the shape of " + std::string(argv[1]);
    obm::obmnet::saveModel(argv[2], fresh, meta);
    std::printf("%s: untrained, shape of %s\n", argv[2], argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "untrained_like: %s\n", e.what());
    return 1;
  }
  return 0;
}
