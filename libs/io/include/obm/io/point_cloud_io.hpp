#pragma once
/// \file point_cloud_io.hpp
/// Point-cloud files: PLY (ascii, binary little / big endian), PCD (ascii, binary) and OFF point
/// sets, read into obm::PointCloud with intensity and RGB colour when the file has them; PLY and
/// PCD written back, atomically.
///
/// Points with a NaN or infinite coordinate (PCL's "invalid" points of organised clouds, for
/// instance) are dropped on reading and on writing, and counted. The acquisition time and the frame
/// name of a cloud are kept in comment lines (`obm_timestamp`, `obm_frame_id`) that other readers
/// ignore, so a round trip through obmslam preserves them.
///
/// Readers throw obm::IoError when the file cannot be read and obm::FormatError naming the file,
/// the line (for headers and ascii bodies) and the fault otherwise.
#include <cstddef>
#include <string>
#include <string_view>

#include "obm/core/point_cloud.hpp"

namespace obm::io {

/// What a reader returns: the cloud and what was left out of it.
struct PointCloudReadResult {
  PointCloud cloud;
  std::size_t num_in_file = 0;            ///< points stored in the file
  std::size_t num_nonfinite_dropped = 0;  ///< of those, points with a NaN / inf coordinate
};

/// What a writer did.
struct PointCloudWriteResult {
  std::size_t num_written = 0;
  std::size_t num_nonfinite_dropped = 0;  ///< points with a NaN / inf coordinate, not written
};

/// PLY body encodings.
enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// Reads .ply, .pcd or .off (extension, case-insensitive) and returns the cloud; non-finite points
/// are dropped (a warning on stderr says how many). Throws FormatError for other extensions.
PointCloud readPointCloud(const std::string& path);

/// Same as readPointCloud, with the counts.
PointCloudReadResult readPointCloudDetailed(const std::string& path);

/// PLY: the `vertex` element's x, y, z (any numeric type); `intensity` (or `scalar_intensity`)
/// when present; `red`, `green`, `blue` (or `r`, `g`, `b`; uchar as is, ushort scaled by 1/257,
/// floating-point 0-1 scaled by 255) when present. Other elements and properties are skipped.
PointCloudReadResult readPlyPointCloud(const std::string& path);

/// PCD v0.5-0.7 (PCL): FIELDS with x y z and optionally `intensity` and packed `rgb` / `rgba`
/// (0x00RRGGBB in the bits of a 4-byte field, written as a float or as an unsigned integer; in
/// ascii either its integer or its float text), other fields skipped; COUNT, SIZE 1/2/4/8 and TYPE
/// I/U/F honoured; DATA ascii or binary (little endian, as PCL writes it). `binary_compressed`
/// is rejected with FormatError ("not supported"). VIEWPOINT is ignored (PCL does not apply it to
/// the points either).
PointCloudReadResult readPcd(const std::string& path);

/// OFF point set: the vertices of an OFF file (faces, if any, are ignored); COFF colours kept.
PointCloudReadResult readOffPointCloud(const std::string& path);

/// The parsers behind the readers, on file content already in memory; `file` names it in messages.
PointCloudReadResult parsePlyPointCloud(std::string_view data, const std::string& file);
PointCloudReadResult parsePcd(std::string_view data, const std::string& file);
PointCloudReadResult parseOffPointCloud(std::string_view data, const std::string& file);

/// Writes .ply or .pcd by extension: binary (PLY little endian, PCD binary) or ascii. Fields x y z
/// as float32, plus intensity (float32) and colour (PLY: uchar red green blue; PCD: packed `rgb`)
/// when the cloud has them. Atomic: a temporary file renamed over `path`. Throws FormatError for
/// other extensions, ContractError for an inconsistent cloud, IoError when it cannot be written.
PointCloudWriteResult writePointCloud(const std::string& path, const PointCloud& cloud,
                                      bool binary = true);

/// PLY writer with an explicit encoding.
PointCloudWriteResult writePly(const std::string& path, const PointCloud& cloud, PlyFormat format);

/// PCD writer (v0.7, WIDTH = points, HEIGHT = 1, `DATA binary` or `DATA ascii`).
PointCloudWriteResult writePcd(const std::string& path, const PointCloud& cloud, bool binary);

}  // namespace obm::io
