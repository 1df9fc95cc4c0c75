#pragma once
// Shared pieces of the libFuzzer targets (tests/fuzz, scripts/fuzz.sh). A target hands the
// fuzzer's bytes to one reader of the project. A clear error is an obm::Error (it names the file
// and line or key); any other exception, a crash, a hang or a leak is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>

#include "obm/core/errors.hpp"

namespace obm::fuzz {

/// The bytes as a file (for readers that take a path), in a per-process temporary folder; the
/// name keeps `ext` so that readers choosing by extension see the right one.
inline std::string asFile(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  static const std::string dir = [] {
    char tmpl[] = "/tmp/obm_fuzz_XXXXXX";
    const char* d = mkdtemp(tmpl);
    return std::string(d ? d : "/tmp");
  }();
  const std::string path = dir + "/input" + ext;
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

inline std::string_view asText(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

/// Runs `read`; obm::Error is the documented answer to bad input and is swallowed.
template <class F>
void expectCleanError(F&& read) {
  try {
    read();
  } catch (const obm::Error&) {
  }
}

}  // namespace obm::fuzz
