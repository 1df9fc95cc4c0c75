#pragma once
/// \file atomic_file.hpp
/// Outputs are written atomically: to a temporary file in the destination folder, flushed, then
/// renamed over the destination, so a reader never sees a half-written file and a failure (or an
/// interrupt) leaves the previous content, or nothing, behind.
#include <fstream>
#include <functional>
#include <string>

namespace obm {

/// Calls `writer` on a stream to a temporary sibling of `path`, then renames it to `path`.
/// On any exception (from writer or I/O) the temporary is removed and the exception re-thrown
/// (I/O failures as IoError naming `path`). `binary` opens the stream in binary mode.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer,
                         bool binary = false);

/// Writes `content` atomically.
void writeTextAtomically(const std::string& path, const std::string& content);

/// Renames a finished temporary file onto `path` (for writers that need a file name, e.g. a C
/// library); removes `tmp_path` and throws IoError on failure.
void commitTemporaryFile(const std::string& tmp_path, const std::string& path);

/// A unique temporary path next to `path` (same folder, so rename is atomic).
std::string temporaryPathFor(const std::string& path);

/// Creates the folder and its parents; throws IoError naming it when impossible.
void ensureDirectory(const std::string& dir);

}  // namespace obm
