#pragma once
/// \file paths.hpp
/// Finding the project's installed data (trained models, configs) from a tool: $OBM_SHARE_DIR, then
/// <executable>/../share/obmslam (an install), then the source tree the tool was built from.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace obm::apps {

inline std::string executableDir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return ".";
  buf[n] = '\0';
  return std::filesystem::path(buf).parent_path().string();
}

/// Path of `relative` (e.g. "models/obmnet_objects.pt") under the first share folder that has it;
/// the source-tree path when none has it (so the error message names a sensible place).
inline std::string findShareFile(const std::string& relative) {
  namespace fs = std::filesystem;
  std::vector<fs::path> roots;
  if (const char* e = std::getenv("OBM_SHARE_DIR")) roots.emplace_back(e);
  roots.emplace_back(fs::path(executableDir()) / ".." / "share" / "obmslam");
#ifdef OBM_SOURCE_DIR
  roots.emplace_back(fs::path(OBM_SOURCE_DIR) / "share" / "obmslam");
#endif
  for (const auto& r : roots)
    if (fs::exists(r / relative)) return fs::weakly_canonical(r / relative).string();
  return (roots.back() / relative).string();
}

/// Path of a config file (e.g. "obmnet/train_objects.yaml"): $OBM_CONFIG_DIR, then
/// <executable>/../share/obmslam/config (an install), then the source tree's config/.
inline std::string findConfigFile(const std::string& relative) {
  namespace fs = std::filesystem;
  std::vector<fs::path> roots;
  if (const char* e = std::getenv("OBM_CONFIG_DIR")) roots.emplace_back(e);
  roots.emplace_back(fs::path(executableDir()) / ".." / "share" / "obmslam" / "config");
#ifdef OBM_SOURCE_DIR
  roots.emplace_back(fs::path(OBM_SOURCE_DIR) / "config");
#endif
  for (const auto& r : roots)
    if (fs::exists(r / relative)) return fs::weakly_canonical(r / relative).string();
  return (roots.back() / relative).string();
}

}  // namespace obm::apps
