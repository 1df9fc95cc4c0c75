// ModelNet40 in PointNet's HDF5 layout (`ply_data_*.h5`: `data` N×P×3 float, `label` N×1).
#include "fuzz_common.hpp"
#include "obm/io/modelnet.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string h5 = obm::fuzz::asFile(data, size, ".h5");
  obm::fuzz::expectCleanError([&] { obm::io::readModelNetH5(h5); });
  return 0;
}
