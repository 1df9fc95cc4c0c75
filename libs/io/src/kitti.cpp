#include "obm/io/kitti.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "text_lines.hpp"

namespace obm::io {
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kRecordBytes = 16;  // 4 × float32: x y z reflectance

// The .bin files are little-endian IEEE floats (written on x86); swap on a big-endian host.
inline float fromLittleEndian(float v) {
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  u = __builtin_bswap32(u);
  std::memcpy(&v, &u, 4);
#endif
  return v;
}

std::array<double, 12> parseTwelve(const std::vector<std::string_view>& tok, std::size_t first,
                                   const std::string& path, std::size_t line, const char* key) {
  if (tok.size() - first != 12)
    throw FormatError(path, line,
                      std::string("expected 12 numbers after '") + key + ":', got " +
                          std::to_string(tok.size() - first));
  std::array<double, 12> v{};
  for (std::size_t k = 0; k < 12; ++k) {
    v[k] = txt::parseDouble(tok[first + k], path, line, key);
    if (!std::isfinite(v[k]))
      throw FormatError(path, line, std::string("non-finite value in ") + key);
  }
  return v;
}

}  // namespace

PointCloud readKittiVelodyne(const std::string& path, KittiScanStats* stats) {
  std::error_code ec;
  const auto bytes = fs::file_size(path, ec);
  if (ec) throw IoError("cannot read '" + path + "': " + ec.message());
  if (bytes % kRecordBytes != 0)
    throw FormatError(path, 0,
                      "size " + std::to_string(bytes) +
                          " bytes is not a multiple of 16 (float32 x y z reflectance records)");
  const std::size_t n = static_cast<std::size_t>(bytes / kRecordBytes);
  std::vector<float> raw(n * 4);
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError("cannot open '" + path + "' for reading");
  is.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(bytes));
  if (static_cast<std::uintmax_t>(is.gcount()) != bytes)
    throw IoError("cannot read '" + path + "': short read");

  PointCloud cloud;
  cloud.frame_id = "velodyne";
  cloud.points.reserve(n);
  cloud.intensity.reserve(n);
  std::size_t bad = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float x = fromLittleEndian(raw[4 * i + 0]);
    const float y = fromLittleEndian(raw[4 * i + 1]);
    const float z = fromLittleEndian(raw[4 * i + 2]);
    const float r = fromLittleEndian(raw[4 * i + 3]);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(r)) {
      ++bad;
      continue;
    }
    cloud.points.emplace_back(x, y, z);
    cloud.intensity.push_back(r);
  }
  if (stats) {
    stats->num_records = n;
    stats->num_non_finite = bad;
  }
  return cloud;
}

void writeKittiVelodyne(const std::string& path, const PointCloud& cloud) {
  cloud.validate();
  std::vector<float> raw(cloud.size() * 4);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    raw[4 * i + 0] = fromLittleEndian(cloud.points[i].x());  // the swap is its own inverse
    raw[4 * i + 1] = fromLittleEndian(cloud.points[i].y());
    raw[4 * i + 2] = fromLittleEndian(cloud.points[i].z());
    raw[4 * i + 3] = fromLittleEndian(cloud.hasIntensity() ? cloud.intensity[i] : 0.f);
  }
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        os.write(reinterpret_cast<const char*>(raw.data()),
                 static_cast<std::streamsize>(raw.size() * sizeof(float)));
      },
      /*binary=*/true);
}

std::string kittiScanFileName(std::size_t index) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06zu.bin", index);
  return buf;
}

std::vector<double> readKittiTimes(const std::string& path) {
  txt::LineReader reader(path);
  std::vector<double> out;
  std::string line;
  while (reader.next(line)) {
    if (txt::isBlank(line)) continue;
    const auto tok = txt::tokenize(line);
    if (tok.size() != 1)
      throw FormatError(
          path, reader.lineNumber(),
          "expected one time stamp per line, got " + std::to_string(tok.size()) + " fields");
    const double t = txt::parseDouble(tok[0], path, reader.lineNumber(), "the time stamp");
    if (!std::isfinite(t)) throw FormatError(path, reader.lineNumber(), "non-finite time stamp");
    out.push_back(t);
  }
  return out;
}

void writeKittiTimes(const std::string& path, const std::vector<double>& times) {
  writeFileAtomically(path, [&](std::ostream& os) {
    for (double t : times) os << txt::formatExact(t) << '\n';
  });
}

KittiCalib readKittiCalib(const std::string& path) {
  txt::LineReader reader(path);
  KittiCalib calib;
  bool has_tr = false;
  std::string line;
  while (reader.next(line)) {
    if (txt::isBlank(line)) continue;
    const auto tok = txt::tokenize(line);
    std::string_view key = tok[0];
    if (key.empty() || key.back() != ':')
      throw FormatError(path, reader.lineNumber(),
                        "expected 'KEY: v1 ... v12', got '" + std::string(tok[0]) + "'");
    key.remove_suffix(1);
    if (key == "P0") {
      const auto v = parseTwelve(tok, 1, path, reader.lineNumber(), "P0");
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) calib.P0(r, c) = v[static_cast<std::size_t>(r * 4 + c)];
      calib.has_P0 = true;
    } else if (key == "Tr" || key == "Tr_velo_to_cam") {
      calib.T_cam0_velo = fromRowMajor3x4(parseTwelve(tok, 1, path, reader.lineNumber(), "Tr"));
      has_tr = true;
    }
    // Other keys (P1..P3, Tr_imu_to_velo, R0_rect, ...) are not used here.
  }
  if (!has_tr) throw FormatError(path, 0, "no 'Tr:' line (velodyne to camera-0 extrinsic)");
  return calib;
}

void writeKittiCalib(const std::string& path, const KittiCalib& calib) {
  writeFileAtomically(path, [&](std::ostream& os) {
    if (calib.has_P0) {
      os << "P0:";
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) os << ' ' << txt::formatExact(calib.P0(r, c));
      os << '\n';
    }
    os << "Tr:";
    for (double v : toRowMajor3x4(calib.T_cam0_velo)) os << ' ' << txt::formatExact(v);
    os << '\n';
  });
}

Isometry3d cameraToLidarPose(const Isometry3d& T_world_cam0, const Isometry3d& T_cam0_velo) {
  // T_velo0_veloi = T_velo_cam0 · T_cam0(0)_cam0(i) · T_cam0_velo: the rigid extrinsic is the same
  // at every scan, and the camera ground truth starts at the identity.
  return T_cam0_velo.inverse() * T_world_cam0 * T_cam0_velo;
}

Isometry3d lidarToCameraPose(const Isometry3d& T_world_velo, const Isometry3d& T_cam0_velo) {
  return T_cam0_velo * T_world_velo * T_cam0_velo.inverse();
}

std::vector<Isometry3d> cameraToLidarPoses(const std::vector<Isometry3d>& T_world_cam0,
                                           const Isometry3d& T_cam0_velo) {
  std::vector<Isometry3d> out;
  out.reserve(T_world_cam0.size());
  for (const auto& T : T_world_cam0) out.push_back(cameraToLidarPose(T, T_cam0_velo));
  return out;
}

std::vector<Isometry3d> lidarToCameraPoses(const std::vector<Isometry3d>& T_world_velo,
                                           const Isometry3d& T_cam0_velo) {
  std::vector<Isometry3d> out;
  out.reserve(T_world_velo.size());
  for (const auto& T : T_world_velo) out.push_back(lidarToCameraPose(T, T_cam0_velo));
  return out;
}

// ---------------------------------------------------------------------------------------------

KittiSequence::KittiSequence(const std::string& dir, const std::string& poses_path) : dir_(dir) {
  const fs::path root(dir);
  const fs::path velo = root / "velodyne";
  if (!fs::is_directory(root)) throw IoError("KITTI sequence folder '" + dir + "' does not exist");
  if (!fs::is_directory(velo)) throw IoError("KITTI sequence '" + dir + "': no 'velodyne/' folder");
  std::error_code ec;
  for (fs::directory_iterator it(velo, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() == ".bin") scan_paths_.push_back(it->path().string());
  }
  if (ec) throw IoError("cannot list '" + velo.string() + "': " + ec.message());
  std::sort(scan_paths_.begin(), scan_paths_.end());
  if (scan_paths_.empty())
    throw IoError("KITTI sequence '" + dir + "': no .bin scans in 'velodyne/'");

  const std::string times_path = (root / "times.txt").string();
  if (!fs::exists(times_path)) throw IoError("KITTI sequence '" + dir + "': no 'times.txt'");
  times_ = readKittiTimes(times_path);
  if (times_.size() != scan_paths_.size())
    throw FormatError(times_path, 0,
                      std::to_string(times_.size()) + " time stamps but " +
                          std::to_string(scan_paths_.size()) + " scans in '" + velo.string() + "'");

  const std::string calib_path = (root / "calib.txt").string();
  if (!fs::exists(calib_path)) throw IoError("KITTI sequence '" + dir + "': no 'calib.txt'");
  calib_ = readKittiCalib(calib_path);

  if (!poses_path.empty()) {
    if (!fs::exists(poses_path))
      throw IoError("KITTI ground truth '" + poses_path + "' does not exist");
    gt_path_ = poses_path;
  } else {
    // The devkit keeps ground truth in <root>/poses/NN.txt beside <root>/sequences/NN/.
    const fs::path canonical = fs::weakly_canonical(root);
    const fs::path candidates[] = {
        root / "poses.txt",
        canonical.parent_path().parent_path() / "poses" / (canonical.filename().string() + ".txt")};
    for (const auto& c : candidates)
      if (fs::is_regular_file(c)) {
        gt_path_ = c.string();
        break;
      }
  }
  if (!gt_path_.empty()) {
    gt_cam_ = readKittiPoses(gt_path_);
    if (gt_cam_.size() != scan_paths_.size())
      throw FormatError(gt_path_, 0,
                        std::to_string(gt_cam_.size()) + " poses but " +
                            std::to_string(scan_paths_.size()) + " scans in '" + velo.string() +
                            "'");
    gt_velo_ = cameraToLidarPoses(gt_cam_, calib_.T_cam0_velo);
  }
}

PointCloud KittiSequence::scan(std::size_t i, KittiScanStats* stats) const {
  PointCloud pc = readKittiVelodyne(scanPath(i), stats);
  pc.timestamp = times_[i];
  return pc;
}

const std::string& KittiSequence::scanPath(std::size_t i) const {
  OBM_ASSERT(i < scan_paths_.size(), "scan index " + std::to_string(i) + " out of range (" +
                                         std::to_string(scan_paths_.size()) + " scans in '" + dir_ +
                                         "')");
  return scan_paths_[i];
}

double KittiSequence::timestamp(std::size_t i) const {
  OBM_ASSERT(i < times_.size(), "scan index " + std::to_string(i) + " out of range (" +
                                    std::to_string(times_.size()) + " scans in '" + dir_ + "')");
  return times_[i];
}

Trajectory KittiSequence::groundTruthLidarStamped() const {
  if (gt_velo_.empty()) return {};
  return stampPoses(gt_velo_, times_);
}

std::string KittiSequence::name() const {
  return fs::weakly_canonical(fs::path(dir_)).filename().string();
}

}  // namespace obm::io
