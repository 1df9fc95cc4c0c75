#include "obm/io/rawlog.hpp"

#include <mrpt/core/Clock.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/maps/CColouredPointsMap.h>
#include <mrpt/maps/CPointsMapXYZI.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationPointCloud.h>
#include <mrpt/obs/CObservationVelodyneScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/obs/CSinCosLookUpTableFor2DScans.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <vector>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"

namespace obm::io {
namespace {
namespace fs = std::filesystem;
using mrpt::obs::CObservation;

Isometry3d toIsometry(const mrpt::poses::CPose3D& p) {
  const auto H = p.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  Isometry3d T = Isometry3d::Identity();
  T.matrix() = H.asEigen();
  return T;
}

mrpt::poses::CPose3D toCPose3D(const Isometry3d& T) {
  mrpt::math::CMatrixDouble44 H;
  H.asEigen() = T.matrix();
  return mrpt::poses::CPose3D(H);
}

/// MRPT exceptions are nested reports with call stacks; this keeps the innermost "Message:" line
/// and the objects being parsed around it, e.g. "(EOF?) Cannot read requested number of bytes
/// from stream (in CObservationPointCloud > CSimplePointsMap)".
std::string mrptMessage(const std::exception& e) {
  const std::string all = e.what();
  std::vector<std::string> messages;
  std::size_t pos = 0;
  while ((pos = all.find("Message:", pos)) != std::string::npos) {
    pos += 8;
    const std::size_t end = all.find('\n', pos);
    std::string m = all.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    m.erase(0, m.find_first_not_of(' '));
    messages.push_back(m);
  }
  if (messages.empty()) return all.substr(0, all.find('\n'));
  std::string inner = messages.back(), context;
  const std::string key = "parsing typed object '";
  for (std::size_t i = 0; i + 1 < messages.size(); ++i) {
    const auto k = messages[i].find(key);
    if (k == std::string::npos) continue;
    const auto b = k + key.size();
    std::string cls = messages[i].substr(b, messages[i].find('\'', b) - b);
    if (cls.find(' ') != std::string::npos) continue;  // "Generic mrpt::io::CStream"
    if (const auto c = cls.rfind("::"); c != std::string::npos) cls.erase(0, c + 2);
    context += (context.empty() ? "" : " > ") + cls;
  }
  return context.empty() ? inner : inner + " (in " + context + ")";
}

/// "mrpt::obs::CObservationGPS" → "CObservationGPS".
std::string shortClassName(const mrpt::rtti::CObject& o) {
  const std::string n = o.GetRuntimeClass()->className;
  const auto k = n.rfind("::");
  return k == std::string::npos ? n : n.substr(k + 2);
}

double toSeconds(const mrpt::Clock::time_point& t) {
  return t == INVALID_TIMESTAMP ? 0.0 : mrpt::Clock::toDouble(t);
}

/// Counts the uncompressed bytes an archive pulls from the file, so that an end of file met in
/// the middle of an object (a truncated rawlog) can be told from the clean end between objects.
class CountingStream : public mrpt::io::CStream {
 public:
  explicit CountingStream(mrpt::io::CFileGZInputStream& in) : in_(in) {}
  size_t Read(void* buf, size_t n) override {
    const size_t r = in_.Read(buf, n);
    bytes_ += r;
    return r;
  }
  size_t Write(const void*, size_t) override { return 0; }
  uint64_t Seek(int64_t, CStream::TSeekOrigin) override { return 0; }
  uint64_t getTotalBytesCount() const override { return in_.getTotalBytesCount(); }
  uint64_t getPosition() const override { return in_.getPosition(); }
  std::uint64_t bytes() const noexcept { return bytes_; }

 private:
  mrpt::io::CFileGZInputStream& in_;
  std::uint64_t bytes_ = 0;
};

/// Appends the points of an MRPT map (sensor frame) to `cloud`, with intensity / colours when the
/// map type carries them.
void appendMap(const mrpt::maps::CPointsMap& map, PointCloud& cloud) {
  const auto& xs = map.getPointsBufferRef_x();
  const auto& ys = map.getPointsBufferRef_y();
  const auto& zs = map.getPointsBufferRef_z();
  const std::size_t n = map.size();
  const auto* xyzi = dynamic_cast<const mrpt::maps::CPointsMapXYZI*>(&map);
  const auto* rgb = dynamic_cast<const mrpt::maps::CColouredPointsMap*>(&map);
  cloud.points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) cloud.points.emplace_back(xs[i], ys[i], zs[i]);
  if (xyzi) {
    cloud.intensity.resize(n);
    for (std::size_t i = 0; i < n; ++i) cloud.intensity[i] = xyzi->getPointIntensity_fast(i);
  } else if (rgb) {
    cloud.colors.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      float r, g, b;
      rgb->getPointColor(i, r, g, b);
      const auto u8 = [](float v) {
        return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f));
      };
      cloud.colors[i] = Color3u8(u8(r), u8(g), u8(b));
    }
  }
}

/// Depth scale (raw units per metre) from MRPT's float `rangeUnits`: 1 / 0.0002f is 4999.9999,
/// so values within 1e-4 (relative) of an integer are taken as that integer.
double depthScaleFromRangeUnits(float units) {
  const double s = 1.0 / static_cast<double>(units);
  const double r = std::round(s);
  return std::abs(s - r) <= 1e-4 * std::abs(s) ? r : s;
}

}  // namespace

Isometry3d T_mrptCamera_optical() {
  // Columns: the optical x (right), y (down), z (forward) axes in MRPT's camera frame
  // (x forward, y left, z up).
  Eigen::Matrix3d R;
  R << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  Isometry3d T = Isometry3d::Identity();
  T.linear() = R;
  return T;
}

// ------------------------------------------------------------------------------------------ reader

struct RawlogReader::Impl {
  std::string path;
  RawlogReadOptions options;
  mrpt::io::CFileGZInputStream file;
  std::unique_ptr<CountingStream> counted;
  std::unique_ptr<mrpt::serialization::CArchive> archive;
  std::deque<CObservation::Ptr> pending;
  RawlogCounts counts;
  bool at_end = false;
  mrpt::obs::CSinCosLookUpTableFor2DScans sincos;

  /// Reads the next top-level object into `pending`; false at the clean end of the file.
  bool readObject();
  /// Converts one observation; false for classes the reader does not handle.
  bool convert(const CObservation::Ptr& obs, RawlogObservation& out);
  FormatError error(const std::string& what) const {
    return FormatError(path, 0, "object " + std::to_string(counts.objects) + ": " + what);
  }
};

bool RawlogReader::Impl::readObject() {
  const std::uint64_t before = counted->bytes();
  mrpt::serialization::CSerializable::Ptr obj;
  try {
    obj = archive->ReadObject();
  } catch (const mrpt::serialization::CExceptionEOF&) {
    if (counted->bytes() != before)
      throw error("the file ends in the middle of this object (truncated rawlog)");
    return false;
  } catch (const std::exception& e) {
    if (counted->bytes() == before) return false;
    const std::string msg = mrptMessage(e);
    if (msg.find("EOF") != std::string::npos)
      throw error("the file ends in the middle of this object (truncated rawlog): " + msg);
    throw error("cannot deserialize (corrupt data or a class unknown to MRPT): " + msg);
  }
  ++counts.objects;
  if (!obj) return true;
  if (auto sf = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(obj)) {
    ++counts.sensory_frames;
    for (const auto& o : *sf)
      if (o) pending.push_back(o);
  } else if (auto o = std::dynamic_pointer_cast<CObservation>(obj)) {
    pending.push_back(o);
  } else if (std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(obj)) {
    ++counts.actions;
  } else {
    ++counts.skipped;
    ++counts.skipped_by_class[shortClassName(*obj)];
  }
  return true;
}

bool RawlogReader::Impl::convert(const CObservation::Ptr& obs, RawlogObservation& out) {
  using namespace mrpt::obs;
  const std::string cls = shortClassName(*obs);
  const bool pc = IS_CLASS(*obs, CObservationPointCloud);
  const bool velo = IS_CLASS(*obs, CObservationVelodyneScan);
  const bool d3 = IS_CLASS(*obs, CObservation3DRangeScan);
  const bool d2 = IS_CLASS(*obs, CObservation2DRangeScan);
  if (!pc && !velo && !d3 && !d2) {
    ++counts.skipped;
    ++counts.skipped_by_class[cls];
    return false;
  }
  out = RawlogObservation();
  out.class_name = cls;
  out.timestamp = toSeconds(obs->timestamp);
  out.sensor_label = obs->sensorLabel;
  mrpt::poses::CPose3D sensor_pose;
  obs->getSensorPose(sensor_pose);
  out.T_vehicle_sensor = toIsometry(sensor_pose);
  out.cloud.frame_id = "vehicle";
  out.cloud.timestamp = out.timestamp;
  PointCloud& cloud = out.cloud;  // filled in the sensor frame, moved to the vehicle frame below

  if (d3) {
    auto& o = dynamic_cast<CObservation3DRangeScan&>(*obs);
    out.T_vehicle_camera = out.T_vehicle_sensor * T_mrptCamera_optical();
    o.load();  // externally stored images, if any
    if (o.hasRangeImage) {
      out.has_depth = true;
      out.range_is_depth = o.range_is_depth;
      out.depth_scale = depthScaleFromRangeUnits(o.rangeUnits);
      const auto& cam = o.cameraParams;
      out.intrinsics.width = static_cast<int>(cam.ncols);
      out.intrinsics.height = static_cast<int>(cam.nrows);
      out.intrinsics.fx = cam.fx();
      out.intrinsics.fy = cam.fy();
      out.intrinsics.cx = cam.cx();
      out.intrinsics.cy = cam.cy();
      for (std::size_t k = 0; k < out.distortion.size(); ++k) out.distortion[k] = cam.dist[k];
    }
  }
  if (!options.generate_clouds) return true;

  if (pc) {
    auto& o = dynamic_cast<CObservationPointCloud&>(*obs);
    o.load();
    if (o.pointcloud) appendMap(*o.pointcloud, cloud);
  } else if (velo) {
    auto& o = dynamic_cast<CObservationVelodyneScan&>(*obs);
    if (!o.scan_packets.empty()) {
      CObservationVelodyneScan::TGeneratePointCloudParameters p;
      p.minDistance = static_cast<float>(options.velodyne_min_range);
      p.maxDistance = static_cast<float>(options.velodyne_max_range);
      o.generatePointCloud(p);  // sensor frame, MRPT's calibration of the scanner model
    }
    const auto& v = o.point_cloud;
    const std::size_t n = v.x.size();
    cloud.points.reserve(n);
    for (std::size_t i = 0; i < n; ++i) cloud.points.emplace_back(v.x[i], v.y[i], v.z[i]);
    if (v.intensity.size() == n) cloud.intensity.assign(v.intensity.begin(), v.intensity.end());
  } else if (d3) {
    auto& o = dynamic_cast<CObservation3DRangeScan&>(*obs);
    if (out.has_depth) {
      // MRPT's unprojection (CObservation3DRangeScan::unprojectInto) in the sensor frame
      // (x forward): it handles depth vs. range images and undoes the lens distortion of
      // `cameraParams`; pixels with 0 are skipped. The window applies to x, the depth.
      const auto& img = o.rangeImage;
      const int rows = static_cast<int>(img.rows()), cols = static_cast<int>(img.cols());
      out.depth.width = cols;
      out.depth.height = rows;
      out.depth.data.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) out.depth.at(c, r) = img(r, c);
      mrpt::maps::CSimplePointsMap local;
      o.unprojectInto(local, mrpt::obs::T3DPointsProjectionParams());
      const auto& xs = local.getPointsBufferRef_x();
      const auto& ys = local.getPointsBufferRef_y();
      const auto& zs = local.getPointsBufferRef_z();
      cloud.points.reserve(local.size());
      for (std::size_t i = 0; i < local.size(); ++i) {
        const double x = xs[i];
        if (x < options.depth_min || x > options.depth_max) continue;
        cloud.points.emplace_back(xs[i], ys[i], zs[i]);
      }
    } else if (o.hasPoints3D) {
      const std::size_t n = o.points3D_x.size();
      for (std::size_t i = 0; i < n; ++i)
        if (o.points3D_x[i] != 0.f || o.points3D_y[i] != 0.f || o.points3D_z[i] != 0.f)
          cloud.points.emplace_back(o.points3D_x[i], o.points3D_y[i], o.points3D_z[i]);
    }
  } else {  // d2
    auto& o = dynamic_cast<CObservation2DRangeScan&>(*obs);
    // MRPT's own ray angles (aperture, rightToLeft) for this scan.
    const auto& sc = sincos.getSinCosForScan(o);
    const std::size_t n = o.getScanSize();
    cloud.points.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (!o.getScanRangeValidity(i)) continue;
      const float r = o.getScanRange(i);
      cloud.points.emplace_back(r * sc.ccos[static_cast<Eigen::Index>(i)],
                                r * sc.csin[static_cast<Eigen::Index>(i)], 0.f);
    }
  }
  cloud.removeNonFinite();
  cloud.transform(out.T_vehicle_sensor);
  return true;
}

RawlogReader::RawlogReader(const std::string& path, const RawlogReadOptions& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->options = options;
  if (!fs::is_regular_file(path)) throw IoError("cannot open rawlog '" + path + "': no such file");
  std::string err;
  if (!impl_->file.open(path, err)) throw IoError("cannot open rawlog '" + path + "': " + err);
  impl_->counted = std::make_unique<CountingStream>(impl_->file);
  impl_->archive = mrpt::serialization::archiveUniquePtrFrom(*impl_->counted);
}

RawlogReader::~RawlogReader() = default;
RawlogReader::RawlogReader(RawlogReader&&) noexcept = default;
RawlogReader& RawlogReader::operator=(RawlogReader&&) noexcept = default;

bool RawlogReader::next(RawlogObservation& out) {
  Impl& m = *impl_;
  while (true) {
    while (!m.pending.empty()) {
      CObservation::Ptr obs = std::move(m.pending.front());
      m.pending.pop_front();
      const std::size_t index = m.counts.observations++;
      bool ok = false;
      try {
        ok = m.convert(obs, out);
      } catch (const Error&) {
        throw;
      } catch (const std::exception& e) {
        const std::string msg = mrptMessage(e);
        throw FormatError(
            m.path, 0,
            "observation " + std::to_string(index) + " (" + shortClassName(*obs) + "): " + msg);
      }
      if (ok) {
        out.index = index;
        ++m.counts.returned;
        return true;
      }
    }
    if (m.at_end) return false;
    if (!m.readObject()) m.at_end = true;
  }
}

const RawlogCounts& RawlogReader::counts() const noexcept {
  return impl_->counts;
}
const std::string& RawlogReader::path() const noexcept {
  return impl_->path;
}

double RawlogReader::progress() const {
  const double total = static_cast<double>(impl_->file.getTotalBytesCount());
  if (impl_->at_end) return 1.0;
  return total > 0 ? std::min(1.0, static_cast<double>(impl_->file.getPosition()) / total) : 0.0;
}

std::vector<RawlogObservation> readRawlog(const std::string& path, const RawlogReadOptions& options,
                                          RawlogCounts* counts) {
  RawlogReader reader(path, options);
  std::vector<RawlogObservation> all;
  RawlogObservation o;
  while (reader.next(o)) all.push_back(std::move(o));
  if (counts) *counts = reader.counts();
  return all;
}

// ------------------------------------------------------------------------------------------ writer

struct RawlogWriter::Impl {
  std::string path, tmp;
  mrpt::io::CFileGZOutputStream file;
  std::unique_ptr<mrpt::serialization::CArchive> archive;
  std::size_t count = 0;
  bool closed = false;

  void write(const mrpt::serialization::CSerializable& obj) {
    if (closed) throw ContractError("RawlogWriter: '" + path + "' is already closed");
    try {
      archive->WriteObject(&obj);
    } catch (const std::exception& e) {
      throw IoError("cannot write rawlog '" + path + "': " + e.what());
    }
    ++count;
  }
};

RawlogWriter::RawlogWriter(const std::string& path, int compression_level)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw IoError("cannot write '" + path + "': folder '" + parent.string() + "' does not exist");
  impl_->tmp = temporaryPathFor(path);
  if (!impl_->file.open(impl_->tmp, std::clamp(compression_level, 1, 9)))
    throw IoError("cannot write '" + path + "': cannot create a temporary file in its folder");
  impl_->archive = mrpt::serialization::archiveUniquePtrFrom(impl_->file);
}

RawlogWriter::~RawlogWriter() {
  if (impl_ && !impl_->closed) {
    impl_->archive.reset();
    impl_->file.close();
    std::remove(impl_->tmp.c_str());
  }
}

std::size_t RawlogWriter::count() const noexcept {
  return impl_->count;
}

std::size_t RawlogWriter::writePointCloud(const PointCloud& cloud_sensor,
                                          const Isometry3d& T_vehicle_sensor, double timestamp,
                                          const std::string& sensor_label) {
  cloud_sensor.validate();
  mrpt::maps::CPointsMap::Ptr map;
  std::size_t dropped = 0;
  const std::size_t n = cloud_sensor.size();
  if (cloud_sensor.hasIntensity()) {
    auto m = std::make_shared<mrpt::maps::CPointsMapXYZI>();
    m->reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = cloud_sensor.points[i];
      if (!p.allFinite()) {
        ++dropped;
        continue;
      }
      m->insertPointFast(p.x(), p.y(), p.z());
      m->setPointIntensity(m->size() - 1, cloud_sensor.intensity[i]);
    }
    map = m;
  } else if (cloud_sensor.hasColors()) {
    auto m = std::make_shared<mrpt::maps::CColouredPointsMap>();
    m->reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = cloud_sensor.points[i];
      if (!p.allFinite()) {
        ++dropped;
        continue;
      }
      const auto& c = cloud_sensor.colors[i];
      m->insertPointRGB(p.x(), p.y(), p.z(), c[0] / 255.f, c[1] / 255.f, c[2] / 255.f);
    }
    map = m;
  } else {
    auto m = std::make_shared<mrpt::maps::CSimplePointsMap>();
    m->reserve(n);
    for (const auto& p : cloud_sensor.points) {
      if (!p.allFinite()) {
        ++dropped;
        continue;
      }
      m->insertPointFast(p.x(), p.y(), p.z());
    }
    map = m;
  }
  mrpt::obs::CObservationPointCloud obs;
  obs.pointcloud = map;
  obs.sensorPose = toCPose3D(T_vehicle_sensor);
  obs.timestamp = mrpt::Clock::fromDouble(timestamp);
  obs.sensorLabel = sensor_label;
  impl_->write(obs);
  return dropped;
}

void RawlogWriter::writeDepth(const DepthImage& depth, double depth_scale,
                              const PinholeIntrinsics& intrinsics,
                              const Isometry3d& T_vehicle_camera, double timestamp,
                              const std::string& sensor_label) {
  if (depth.width != intrinsics.width || depth.height != intrinsics.height ||
      depth.data.size() != static_cast<std::size_t>(depth.width) * depth.height)
    throw ContractError("RawlogWriter::writeDepth: depth image " + std::to_string(depth.width) +
                        "x" + std::to_string(depth.height) + " does not match intrinsics " +
                        std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  if (!(depth_scale > 0)) throw ContractError("RawlogWriter::writeDepth: depth_scale must be > 0");
  mrpt::obs::CObservation3DRangeScan obs;
  obs.hasRangeImage = true;
  obs.rangeImage_setSize(depth.height, depth.width);
  for (int r = 0; r < depth.height; ++r)
    for (int c = 0; c < depth.width; ++c) obs.rangeImage(r, c) = depth.at(c, r);
  obs.rangeUnits = static_cast<float>(1.0 / depth_scale);
  obs.range_is_depth = true;
  mrpt::img::TCamera cam;
  cam.ncols = static_cast<uint32_t>(intrinsics.width);
  cam.nrows = static_cast<uint32_t>(intrinsics.height);
  cam.setIntrinsicParamsFromValues(intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy);
  obs.cameraParams = cam;
  obs.cameraParamsIntensity = cam;
  obs.sensorPose = toCPose3D(T_vehicle_camera * T_mrptCamera_optical().inverse());
  obs.timestamp = mrpt::Clock::fromDouble(timestamp);
  obs.sensorLabel = sensor_label;
  impl_->write(obs);
}

void RawlogWriter::close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.archive.reset();
  m.file.close();
  m.closed = true;
  commitTemporaryFile(m.tmp, m.path);
}

}  // namespace obm::io
