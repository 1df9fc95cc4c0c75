// Pose graphs: g2o (SE2 / SE3 vertices and edges, FIX) and TORO.
#include <sstream>

#include "fuzz_common.hpp"
#include "obm/backend/graph_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(obm::fuzz::asText(data, size));
  obm::fuzz::expectCleanError([&] {
    std::istringstream in(text);
    obm::backend::readG2o(in, "fuzz.g2o");
  });
  obm::fuzz::expectCleanError([&] {
    std::istringstream in(text);
    obm::backend::readToro(in, "fuzz.graph");
  });
  return 0;
}
