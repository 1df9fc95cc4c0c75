// OFF (point cloud and mesh) and OBJ meshes.
#include "fuzz_common.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/io/point_cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto text = obm::fuzz::asText(data, size);
  obm::fuzz::expectCleanError([&] { obm::io::parseOffPointCloud(text, "fuzz.off"); });
  obm::fuzz::expectCleanError([&] { obm::io::parseOff(text, "fuzz.off"); });
  obm::fuzz::expectCleanError([&] { obm::io::parseObj(text, "fuzz.obj"); });
  return 0;
}
