// JPEG colour images (the colour frames of the Redwood / Open3D RGB-D layout).
#include "fuzz_common.hpp"
#include "obm/io/rgbd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string jpg = obm::fuzz::asFile(data, size, ".jpg");
  obm::fuzz::expectCleanError([&] { obm::io::readColorJpeg(jpg); });
  obm::fuzz::expectCleanError([&] { obm::io::readColorImage(jpg); });
  return 0;
}
