// OBMNet model files (`.pt`: LibTorch's zip archive of the weights, the TorchScript section and
// the project's metadata). Built only in a fuzz build with LibTorch (scripts/fuzz.sh model).
#include "fuzz_common.hpp"
#include "obm/obmnet/model_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string pt = obm::fuzz::asFile(data, size, ".pt");
  obm::fuzz::expectCleanError([&] {
    obm::obmnet::ModelMeta meta;
    obm::obmnet::loadModel(pt, &meta);
  });
  return 0;
}
