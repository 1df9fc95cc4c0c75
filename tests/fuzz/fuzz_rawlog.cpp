// MRPT rawlogs (CObservation* streams, sensory frames, gzip or plain).
#include "fuzz_common.hpp"
#include "obm/io/rawlog.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = obm::fuzz::asFile(data, size, ".rawlog");
  obm::fuzz::expectCleanError([&] { obm::io::readRawlog(path); });
  return 0;
}
