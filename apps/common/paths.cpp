// The source tree's path is compiled into this one file (OBM_SOURCE_DIR, apps/CMakeLists.txt), so
// the apps' other objects do not depend on where the clone is and ccache reuses them.
#include "paths.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

namespace obm::apps {
namespace fs = std::filesystem;

std::string executableDir() {
  char buf[4096];
  const ssize_t n = ::readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return ".";
  buf[n] = '\0';
  return fs::path(buf).parent_path().string();
}

std::string sourceDir() { return OBM_SOURCE_DIR; }

namespace {
/// The first of `roots` that holds `relative`, else the last root's path (for the error message).
std::string firstExisting(const std::vector<fs::path>& roots, const std::string& relative) {
  for (const auto& r : roots)
    if (fs::exists(r / relative)) return fs::weakly_canonical(r / relative).string();
  return (roots.back() / relative).string();
}
}  // namespace

std::string findShareFile(const std::string& relative) {
  std::vector<fs::path> roots;
  if (const char* e = std::getenv("OBM_SHARE_DIR")) roots.emplace_back(e);
  roots.emplace_back(fs::path(executableDir()) / ".." / "share" / "obmslam");
  roots.emplace_back(fs::path(sourceDir()) / "share" / "obmslam");
  return firstExisting(roots, relative);
}

std::string findConfigFile(const std::string& relative) {
  std::vector<fs::path> roots;
  if (const char* e = std::getenv("OBM_CONFIG_DIR")) roots.emplace_back(e);
  roots.emplace_back(fs::path(executableDir()) / ".." / "share" / "obmslam" / "config");
  roots.emplace_back(fs::path(sourceDir()) / "config");
  return firstExisting(roots, relative);
}

}  // namespace obm::apps
