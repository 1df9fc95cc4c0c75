// YAML configurations: the document, then every typed getter a config struct uses.
#include "fuzz_common.hpp"
#include "obm/config/config_node.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  obm::fuzz::expectCleanError([&] {
    const auto root = obm::ConfigNode::fromString(std::string(obm::fuzz::asText(data, size)), "fuzz.yaml");
    double d = 0;
    int i = 0;
    bool b = false;
    std::string s;
    std::vector<int> v;
    for (const char* key : {"a", "b", "c"}) {
      obm::fuzz::expectCleanError([&] { root.get(key, d); });
      obm::fuzz::expectCleanError([&] { root.get(key, i); });
      obm::fuzz::expectCleanError([&] { root.get(key, b); });
      obm::fuzz::expectCleanError([&] { root.get(key, s); });
      obm::fuzz::expectCleanError([&] { root.get(key, v); });
      obm::fuzz::expectCleanError([&] { (void)root.child(key); });
    }
    obm::fuzz::expectCleanError([&] { root.checkKeys({"a", "b"}); });
  });
  return 0;
}
