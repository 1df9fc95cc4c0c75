// PNG depth (16-bit) and colour images.
#include "fuzz_common.hpp"
#include "obm/io/rgbd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string png = obm::fuzz::asFile(data, size, ".png");
  obm::fuzz::expectCleanError([&] { obm::io::readDepthPng(png); });
  obm::fuzz::expectCleanError([&] { obm::io::readColorPng(png); });
  return 0;
}
