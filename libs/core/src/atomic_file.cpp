#include "obm/core/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "obm/core/errors.hpp"

namespace obm {
namespace fs = std::filesystem;

std::string temporaryPathFor(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(path);
  return (p.parent_path() / ("." + p.filename().string() + ".tmp." + std::to_string(::getpid()) +
                             "." + std::to_string(counter++)))
      .string();
}

void commitTemporaryFile(const std::string& tmp_path, const std::string& path) {
  if (std::rename(tmp_path.c_str(), path.c_str()) != 0) {
    const std::string err = std::strerror(errno);
    std::remove(tmp_path.c_str());
    throw IoError("cannot write '" + path + "': rename from temporary failed: " + err);
  }
}

void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer,
                         bool binary) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw IoError("cannot write '" + path + "': folder '" + parent.string() + "' does not exist");
  const std::string tmp = temporaryPathFor(path);
  // Why a write failed, as the system said it (errno of the failing write: "No space left on
  // device", "Disk quota exceeded", …), with the space left on the file system.
  auto failure = [&](int err, const char* what) {
    std::string msg = "cannot write '" + path + "': " + what;
    if (err != 0) msg += std::string(": ") + std::strerror(err);
    std::error_code ec;
    const auto space = fs::space(parent.empty() ? fs::path(".") : parent, ec);
    if (!ec) msg += " (" + std::to_string(space.available / 1024) + " KiB free on its file system)";
    return IoError(msg);
  };
  try {
    errno = 0;
    std::ofstream os(tmp, binary ? std::ios::binary | std::ios::out : std::ios::out);
    if (!os) throw failure(errno, "cannot open a temporary file in its folder");
    writer(os);
    os.flush();
    if (!os) throw failure(errno, "write failed");
    os.close();
    if (os.fail()) throw failure(errno, "closing the file failed");
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  commitTemporaryFile(tmp, path);
}

void writeTextAtomically(const std::string& path, const std::string& content) {
  writeFileAtomically(path, [&](std::ostream& os) { os << content; });
}

void ensureDirectory(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw IoError("cannot create folder '" + dir + "': " + (ec ? ec.message() : "not a folder"));
}

}  // namespace obm
