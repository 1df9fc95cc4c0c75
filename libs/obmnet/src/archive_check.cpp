#include "archive_check.hpp"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <new>
#include <string>
#include <utility>

#include "obm/core/errors.hpp"

namespace obm::obmnet::detail {

namespace {

// Zip record signatures (APPNOTE.TXT 4.3).
constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kEndOfDirectory = 0x06054b50;
constexpr std::uint32_t kZip64EndOfDirectory = 0x06064b50;
constexpr std::uint32_t kZip64Locator = 0x07064b50;

std::uint32_t crc32(const unsigned char* data, std::size_t n) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) c = table[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

/// Whether the raw deflate stream `data[0, n)` inflates to exactly `size` bytes whose CRC-32 is
/// `crc` (streamed in 64 kB pieces: a damaged size field does not become an allocation).
bool inflatesTo(const unsigned char* data, std::size_t n, std::uint64_t size, std::uint32_t crc) {
  z_stream zs{};
  if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) throw std::bad_alloc();
  std::array<unsigned char, 65536> out{};
  zs.next_in = const_cast<unsigned char*>(data);
  std::uint64_t total = 0;
  uLong c = ::crc32(0L, Z_NULL, 0);
  int rc = Z_OK;
  std::size_t left = n;
  while (rc == Z_OK) {
    if (zs.avail_in == 0 && left > 0) {
      zs.avail_in = static_cast<uInt>(std::min<std::size_t>(left, 1u << 30));
      left -= zs.avail_in;
    }
    zs.next_out = out.data();
    zs.avail_out = static_cast<uInt>(out.size());
    rc = inflate(&zs, Z_NO_FLUSH);
    const std::size_t produced = out.size() - zs.avail_out;
    total += produced;
    if (total > size) break;
    c = ::crc32(c, out.data(), static_cast<uInt>(produced));
    if (rc == Z_BUF_ERROR && zs.avail_in == 0 && left == 0) break;  // the stream is cut short
  }
  inflateEnd(&zs);
  return rc == Z_STREAM_END && total == size && static_cast<std::uint32_t>(c) == crc;
}

/// Little-endian reads with bounds checks against the whole file.
class Bytes {
 public:
  Bytes(const std::string& path, std::string data) : path_(path), d_(std::move(data)) {}
  std::size_t size() const { return d_.size(); }
  const unsigned char* at(std::size_t off) const {
    return reinterpret_cast<const unsigned char*>(d_.data()) + off;
  }
  std::uint64_t le(std::size_t off, int bytes, const char* what) const {
    need(off, static_cast<std::size_t>(bytes), what);
    std::uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | *at(off + static_cast<std::size_t>(i));
    return v;
  }
  void need(std::uint64_t off, std::uint64_t n, const std::string& what) const {
    if (off > d_.size() || n > d_.size() - off)
      fail(what + " lies beyond the end of the file (truncated or damaged)");
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw FormatError(path_, 0, "damaged model archive: " + what);
  }

 private:
  std::string path_;
  std::string d_;
};

}  // namespace

void verifyZipArchive(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open model file '" + path + "'");
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw IoError("cannot read model file '" + path + "'");
  const Bytes b(path, std::move(data));

  // The end-of-directory record: 22 bytes plus a comment of up to 65535, at the end.
  if (b.size() < 22) b.fail("too short for a zip archive");
  std::size_t eocd = b.size() - 22;
  const std::size_t lowest = b.size() > 22 + 65535 ? b.size() - 22 - 65535 : 0;
  while (b.le(eocd, 4, "end of directory") != kEndOfDirectory) {
    if (eocd == lowest) b.fail("no zip end-of-directory record");
    --eocd;
  }
  std::uint64_t entries = b.le(eocd + 10, 2, "end of directory");
  std::uint64_t dir_size = b.le(eocd + 12, 4, "end of directory");
  std::uint64_t dir_offset = b.le(eocd + 16, 4, "end of directory");
  if (entries == 0xFFFF || dir_size == 0xFFFFFFFF || dir_offset == 0xFFFFFFFF) {
    // zip64: a locator right before the record points to the zip64 end-of-directory record.
    if (eocd < 20 || b.le(eocd - 20, 4, "zip64 locator") != kZip64Locator)
      b.fail("zip64 sizes without a zip64 locator");
    const std::uint64_t z = b.le(eocd - 20 + 8, 8, "zip64 locator");
    b.need(z, 56, "the zip64 end-of-directory record");
    if (b.le(static_cast<std::size_t>(z), 4, "zip64 end of directory") != kZip64EndOfDirectory)
      b.fail("no zip64 end-of-directory record where its locator points");
    entries = b.le(static_cast<std::size_t>(z) + 32, 8, "zip64 end of directory");
    dir_size = b.le(static_cast<std::size_t>(z) + 40, 8, "zip64 end of directory");
    dir_offset = b.le(static_cast<std::size_t>(z) + 48, 8, "zip64 end of directory");
  }
  b.need(dir_offset, dir_size, "the zip directory");
  if (entries == 0) b.fail("the zip directory lists no entry");
  // Each directory entry is at least 46 bytes: a count beyond that is damage, not a loop bound.
  if (entries > dir_size / 46) b.fail("the zip directory's entry count does not fit its size");

  std::size_t p = static_cast<std::size_t>(dir_offset);
  for (std::uint64_t i = 0; i < entries; ++i) {
    if (b.le(p, 4, "a directory entry") != kCentralHeader)
      b.fail("directory entry " + std::to_string(i) + " has no signature");
    const auto method = b.le(p + 10, 2, "a directory entry");
    const auto crc = static_cast<std::uint32_t>(b.le(p + 16, 4, "a directory entry"));
    std::uint64_t csize = b.le(p + 20, 4, "a directory entry");
    std::uint64_t usize = b.le(p + 24, 4, "a directory entry");
    const auto name_len = static_cast<std::size_t>(b.le(p + 28, 2, "a directory entry"));
    const auto extra_len = static_cast<std::size_t>(b.le(p + 30, 2, "a directory entry"));
    const auto comment_len = static_cast<std::size_t>(b.le(p + 32, 2, "a directory entry"));
    std::uint64_t local = b.le(p + 42, 4, "a directory entry");
    b.need(p + 46, name_len + extra_len + comment_len, "a directory entry's name");
    const std::string name(reinterpret_cast<const char*>(b.at(p + 46)), name_len);
    // zip64 extra field (id 1): the 8-byte values of the fields stored as 0xFFFFFFFF, in order.
    for (std::size_t e = p + 46 + name_len; e + 4 <= p + 46 + name_len + extra_len;) {
      const auto id = b.le(e, 2, "an extra field");
      const auto len = static_cast<std::size_t>(b.le(e + 2, 2, "an extra field"));
      if (id == 1) {
        std::size_t q = e + 4;
        if (usize == 0xFFFFFFFF) usize = b.le(q, 8, "a zip64 field"), q += 8;
        if (csize == 0xFFFFFFFF) csize = b.le(q, 8, "a zip64 field"), q += 8;
        if (local == 0xFFFFFFFF) local = b.le(q, 8, "a zip64 field");
      }
      e += 4 + len;
    }
    const std::string entry = "entry '" + name + "'";
    b.need(local, 30, entry + "'s local header");
    if (b.le(static_cast<std::size_t>(local), 4, entry.c_str()) != kLocalHeader)
      b.fail(entry + " has no local header where the directory says");
    const std::uint64_t start = local + 30 + b.le(static_cast<std::size_t>(local) + 26, 2, "") +
                                b.le(static_cast<std::size_t>(local) + 28, 2, "");
    b.need(start, csize, entry + "'s data");
    if (method == 0) {
      if (csize != usize) b.fail(entry + " is stored with two different sizes");
      if (crc32(b.at(static_cast<std::size_t>(start)), static_cast<std::size_t>(csize)) != crc)
        b.fail(entry + " does not match its CRC-32 (a damaged byte)");
    } else if (method == 8) {
      // Deflated entries (LibTorch compresses the TorchScript sources): a damaged byte there
      // reaches the TorchScript parser, which LibTorch 1.13 may crash on (a fuzzing finding), so
      // they are inflated and checked like the stored ones.
      if (!inflatesTo(b.at(static_cast<std::size_t>(start)), static_cast<std::size_t>(csize),
                      usize, crc))
        b.fail(entry + " does not inflate to its size and CRC-32 (a damaged byte)");
    } else {
      b.fail(entry + " uses compression method " + std::to_string(method) +
             " (model files store or deflate)");
    }
    p += 46 + name_len + extra_len + comment_len;
  }
}

}  // namespace obm::obmnet::detail
