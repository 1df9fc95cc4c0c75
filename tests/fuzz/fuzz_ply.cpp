// PLY: point clouds (ASCII and binary, any property layout) and meshes.
#include "fuzz_common.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/io/point_cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto text = obm::fuzz::asText(data, size);
  obm::fuzz::expectCleanError([&] { obm::io::parsePlyPointCloud(text, "fuzz.ply"); });
  obm::fuzz::expectCleanError([&] { obm::io::parsePlyMesh(text, "fuzz.ply"); });
  return 0;
}
