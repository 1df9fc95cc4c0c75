#pragma once
/// \file archive_check.hpp
/// Integrity of a model file's container before LibTorch reads it. A `.pt` file is a zip archive
/// of stored entries (the weights, the project's metadata) and deflated ones (the TorchScript
/// sources). LibTorch's reader does not compare the entries with their CRC-32, so a damaged byte
/// in a weight loads as a wrong number, and one in the TorchScript section reaches its parser
/// (which then reports an error, or in LibTorch 1.13 may crash on some inputs). Checking every
/// entry's CRC-32 first turns any damaged byte into a clear error. Private to libs/obmnet.
#include <string>

namespace obm::obmnet::detail {

/// Reads the zip archive at `path` (zip or zip64 directory) and checks, for every entry, that its
/// local header is where the directory says and that its bytes (inflated, for deflated entries)
/// have the size and CRC-32 the directory gives; any other compression method is refused. Throws
/// obm::FormatError naming `path` and the entry on the first damage; obm::IoError when the file
/// cannot be read.
void verifyZipArchive(const std::string& path);

}  // namespace obm::obmnet::detail
