// PCD (ASCII, binary; the reader's documented subset).
#include "fuzz_common.hpp"
#include "obm/io/point_cloud_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  obm::fuzz::expectCleanError([&] { obm::io::parsePcd(obm::fuzz::asText(data, size), "fuzz.pcd"); });
  return 0;
}
