#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "obm/core/errors.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "test_data.hpp"

using namespace obm;
namespace fs = std::filesystem;

namespace {

/// MRPT's sample rawlogs (Debian mrpt-common). Fails in CI, skips elsewhere, when missing.
#define REQUIRE_MRPT_DATASET(path)                                                  \
  do {                                                                              \
    if (!fs::exists(path)) {                                                        \
      if (test::inCI()) FAIL() << "missing " << (path) << " (package mrpt-common)"; \
      GTEST_SKIP() << "missing " << (path) << " (package mrpt-common)";             \
    }                                                                               \
  } while (0)

const std::string kDatasets = "/usr/share/mrpt/datasets/";

double maxDistanceFrom(const PointCloud& c, const Eigen::Vector3d& origin) {
  double m = 0;
  for (const auto& p : c.points) m = std::max(m, (p.cast<double>() - origin).norm());
  return m;
}

Isometry3d somePose(double yaw, double pitch, const Eigen::Vector3d& t) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

}  // namespace

TEST(Rawlog, OpticalToMrptCameraRotation) {
  // MRPT's default depth → intensity-camera pose is the pure rotation between its 3D-camera frame
  // and the optical frame: CPose3D(0, 0, 0, yaw −90°, pitch 0, roll −90°).
  const mrpt::obs::CObservation3DRangeScan scan;
  const auto H =
      scan.relativePoseIntensityWRTDepth.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  EXPECT_TRUE(io::T_mrptCamera_optical().matrix().isApprox(H.asEigen(), 1e-12));
  // Optical z (forward) is MRPT's x, optical x (right) is MRPT's −y, optical y (down) MRPT's −z.
  const Eigen::Vector3d fwd = io::T_mrptCamera_optical() * Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(fwd.isApprox(Eigen::Vector3d::UnitX()));
}

TEST(Rawlog, VelodyneVlp16PointsGeneratedByMrpt) {
  const std::string path = kDatasets + "test_velodyne_VLP16.rawlog";
  REQUIRE_MRPT_DATASET(path);
  io::RawlogCounts counts;
  const auto obs = io::readRawlog(path, {}, &counts);
  ASSERT_EQ(obs.size(), 1u);
  const auto& o = obs[0];
  EXPECT_EQ(o.class_name, "CObservationVelodyneScan");
  EXPECT_EQ(o.sensor_label, "Velodyne1_SCAN");
  EXPECT_GT(o.timestamp, 1.5e9);  // recorded in 2018
  EXPECT_LT(o.timestamp, 1.6e9);
  // A VLP-16 revolution has at most 16 lasers × ~1800 firings; ranges beyond 1 m are kept.
  EXPECT_GT(o.cloud.size(), 5000u);
  EXPECT_LT(o.cloud.size(), 16u * 2000u);
  EXPECT_TRUE(o.cloud.hasIntensity());
  EXPECT_EQ(o.cloud.frame_id, "vehicle");
  const Eigen::Vector3d origin = o.T_vehicle_sensor.translation();
  EXPECT_LE(maxDistanceFrom(o.cloud, origin), 131.0);  // VLP-16 range 100 m (+ margin)
  double min_d = 1e9;
  for (const auto& p : o.cloud.points) min_d = std::min(min_d, (p.cast<double>() - origin).norm());
  EXPECT_GE(min_d, 0.99);  // the 1 m minimum range
  EXPECT_EQ(counts.returned, 1u);
  EXPECT_EQ(counts.skipped, 0u);

  // A larger minimum range keeps fewer points; metadata-only mode decodes no points.
  io::RawlogReadOptions far;
  far.velodyne_min_range = 10.0;
  EXPECT_LT(io::readRawlog(path, far)[0].cloud.size(), o.cloud.size());
  io::RawlogReadOptions meta;
  meta.generate_clouds = false;
  const auto m = io::readRawlog(path, meta);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_TRUE(m[0].cloud.empty());
  EXPECT_EQ(m[0].timestamp, o.timestamp);
}

TEST(Rawlog, RangeImageMatchesMrptUnprojectionAndDepthToCloud) {
  const std::string path = kDatasets + "tests_rgbd.rawlog";
  REQUIRE_MRPT_DATASET(path);
  const auto obs = io::readRawlog(path);
  ASSERT_EQ(obs.size(), 1u);
  const auto& o = obs[0];
  EXPECT_EQ(o.class_name, "CObservation3DRangeScan");
  ASSERT_TRUE(o.has_depth);
  EXPECT_EQ(o.depth.width, o.intrinsics.width);
  EXPECT_EQ(o.depth.height, o.intrinsics.height);
  EXPECT_GT(o.intrinsics.fx, 100.0);
  EXPECT_GT(o.cloud.size(), 10000u);

  // 1) MRPT's own unprojection with the sensor pose applied by MRPT gives the same points: the
  //    reader's sensor → vehicle transform agrees with MRPT's.
  mrpt::io::CFileGZInputStream f(path);
  auto arch = mrpt::serialization::archiveFrom(f);
  auto scan = arch.ReadObject<mrpt::obs::CObservation3DRangeScan>();
  ASSERT_TRUE(scan);
  mrpt::maps::CSimplePointsMap ref;
  mrpt::obs::T3DPointsProjectionParams pp;
  pp.takeIntoAccountSensorPoseOnRobot = true;
  scan->unprojectInto(ref, pp);
  ASSERT_EQ(ref.size(), o.cloud.size());
  double worst = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    float x, y, z;
    ref.getPoint(i, x, y, z);
    worst = std::max(worst, (Eigen::Vector3f(x, y, z) - o.cloud.points[i]).cast<double>().norm());
  }
  EXPECT_LT(worst, 1e-5) << "[m] largest difference to MRPT's unprojectInto";

  // 2) The exposed depth image, scale, intrinsics and T_vehicle_camera reproduce the cloud through
  //    the optical-frame pinhole back-projection of rgbd.hpp, up to the lens distortion that
  //    MRPT undoes and the pinhole model does not (|k1|, |k2| < 0.01 here: millimetres).
  ASSERT_TRUE(o.range_is_depth);
  ASSERT_LT(std::abs(o.distortion[0]) + std::abs(o.distortion[1]), 0.02);
  PointCloud cam = io::depthToCloud(o.depth, o.intrinsics, o.depth_scale);
  cam.transform(o.T_vehicle_camera);
  ASSERT_EQ(cam.size(), o.cloud.size());
  std::vector<double> diff(cam.size());
  for (std::size_t i = 0; i < cam.size(); ++i)
    diff[i] = (cam.points[i] - o.cloud.points[i]).cast<double>().norm();
  std::sort(diff.begin(), diff.end());
  EXPECT_LT(diff[diff.size() / 2], 1e-3) << "[m] median";
  EXPECT_LT(diff.back(), 1e-2) << "[m] largest";
}

TEST(Rawlog, SensoryFrameLayoutWith2DScans) {
  const std::string path = kDatasets + "localization_demo.rawlog";
  REQUIRE_MRPT_DATASET(path);
  io::RawlogReader reader(path);
  io::RawlogObservation o;
  double last_t = -1;
  std::size_t n = 0;
  while (reader.next(o)) {
    EXPECT_EQ(o.class_name, "CObservation2DRangeScan");
    EXPECT_GT(o.timestamp, last_t) << "observation " << o.index;
    last_t = o.timestamp;
    EXPECT_GT(o.cloud.size(), 100u);
    // A horizontal scanner: every point lies at the sensor's height on the vehicle.
    const double h = o.T_vehicle_sensor.translation().z();
    for (const auto& p : o.cloud.points) ASSERT_NEAR(p.z(), h, 1e-4);
    EXPECT_LE(maxDistanceFrom(o.cloud, o.T_vehicle_sensor.translation()), 81.0);
    ++n;
  }
  EXPECT_DOUBLE_EQ(reader.progress(), 1.0);
  const auto& c = reader.counts();
  EXPECT_EQ(n, 37u);
  EXPECT_EQ(c.sensory_frames, 37u);
  EXPECT_EQ(c.actions, 37u);
  EXPECT_EQ(c.returned, 37u);
  EXPECT_EQ(c.skipped, 0u);
}

TEST(Rawlog, UnsupportedObservationsAreSkippedAndCounted) {
  const std::string gps = kDatasets + "test_rtk_path.rawlog";
  const std::string rot = kDatasets + "rot_scan_velodyne.rawlog";
  REQUIRE_MRPT_DATASET(gps);
  REQUIRE_MRPT_DATASET(rot);
  io::RawlogCounts c;
  EXPECT_TRUE(io::readRawlog(gps, {}, &c).empty());
  EXPECT_EQ(c.observations, 692u);
  EXPECT_EQ(c.skipped, 692u);
  EXPECT_EQ(c.skipped_by_class.at("CObservationGPS"), 691u);
  // MRPT 2.5's CObservationRotatingScan carries no elevation calibration to make points from.
  EXPECT_TRUE(io::readRawlog(rot, {}, &c).empty());
  EXPECT_EQ(c.skipped_by_class.at("CObservationRotatingScan"), 1u);
}

TEST(Rawlog, WriteAndReadBack) {
  const auto dir = test::scratchDir("rawlog_rt");
  const std::string path = dir + "/out.rawlog";
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-20.f, 20.f);
  // Three point clouds: with intensity, with colours, plain (one NaN point to drop).
  std::vector<PointCloud> clouds(3);
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 100; ++i) {
      clouds[k].points.emplace_back(u(rng), u(rng), u(rng));
      if (k == 0) clouds[k].intensity.push_back(std::abs(u(rng)));
      if (k == 1) clouds[k].colors.emplace_back(i, 255 - i, 2 * i);
    }
  clouds[2].points[7].x() = std::numeric_limits<float>::quiet_NaN();
  const Isometry3d T_vs = somePose(0.3, -0.1, {1.2, -0.4, 1.8});
  const double t0 = 1317384512.25;
  // A depth image: a tilted plane with a hole.
  io::PinholeIntrinsics K;
  K.width = 32, K.height = 24, K.fx = K.fy = 30.0, K.cx = 15.5, K.cy = 11.5;
  io::DepthImage depth;
  depth.width = K.width, depth.height = K.height;
  depth.data.resize(32 * 24);
  for (int v = 0; v < 24; ++v)
    for (int c = 0; c < 32; ++c)
      depth.at(c, v) = static_cast<std::uint16_t>(5000 + 100 * c + 7 * v);
  depth.at(3, 4) = 0;
  const Isometry3d T_vc = somePose(-1.0, 0.2, {0.1, 0.0, 1.5});
  {
    io::RawlogWriter w(path);
    EXPECT_EQ(w.writePointCloud(clouds[0], T_vs, t0, "lidar"), 0u);
    EXPECT_EQ(w.writePointCloud(clouds[1], T_vs, t0 + 0.1, "lidar"), 0u);
    EXPECT_EQ(w.writePointCloud(clouds[2], T_vs, t0 + 0.2, "lidar"), 1u);
    w.writeDepth(depth, 5000.0, K, T_vc, t0 + 0.3, "rgbd");
    EXPECT_EQ(w.count(), 4u);
    EXPECT_FALSE(fs::exists(path));  // nothing at the destination before close()
    w.close();
  }
  io::RawlogCounts counts;
  const auto obs = io::readRawlog(path, {}, &counts);
  ASSERT_EQ(obs.size(), 4u);
  EXPECT_EQ(counts.sensory_frames, 0u);
  for (int k = 0; k < 3; ++k) {
    const auto& o = obs[k];
    EXPECT_EQ(o.class_name, "CObservationPointCloud");
    EXPECT_EQ(o.sensor_label, "lidar");
    EXPECT_NEAR(o.timestamp, t0 + 0.1 * k, 1e-6);
    EXPECT_TRUE(o.T_vehicle_sensor.isApprox(T_vs, 1e-12));
    PointCloud expected = clouds[k];
    expected.removeNonFinite();
    ASSERT_EQ(o.cloud.size(), expected.size()) << k;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const Eigen::Vector3d pv = T_vs * expected.points[i].cast<double>();
      ASSERT_LT((o.cloud.points[i].cast<double>() - pv).norm(), 1e-5) << k << " " << i;
    }
    EXPECT_EQ(o.cloud.hasIntensity(), k == 0);
    EXPECT_EQ(o.cloud.hasColors(), k == 1);
    if (k == 0) {
      EXPECT_EQ(o.cloud.intensity, expected.intensity);
    }
    if (k == 1) {
      EXPECT_EQ(o.cloud.colors, expected.colors);
    }
  }
  const auto& d = obs[3];
  EXPECT_EQ(d.class_name, "CObservation3DRangeScan");
  EXPECT_EQ(d.sensor_label, "rgbd");
  EXPECT_NEAR(d.timestamp, t0 + 0.3, 1e-6);
  ASSERT_TRUE(d.has_depth);
  EXPECT_EQ(d.depth.data, depth.data);
  EXPECT_EQ(d.depth_scale, 5000.0);
  EXPECT_EQ(d.intrinsics.width, 32);
  EXPECT_DOUBLE_EQ(d.intrinsics.fx, 30.0);
  EXPECT_DOUBLE_EQ(d.intrinsics.cy, 11.5);
  EXPECT_TRUE(d.T_vehicle_camera.isApprox(T_vc, 1e-12));
  PointCloud cam = io::depthToCloud(depth, K, 5000.0);
  ASSERT_EQ(d.cloud.size(), cam.size());
  EXPECT_EQ(cam.size(), 32u * 24u - 1u);
  for (std::size_t i = 0; i < cam.size(); ++i)
    ASSERT_LT((d.cloud.points[i].cast<double>() - T_vc * cam.points[i].cast<double>()).norm(),
              1e-5);
}

TEST(Rawlog, WriterIsAtomicAndReaderReportsDamage) {
  const auto dir = test::scratchDir("rawlog_bad");
  PointCloud c;
  for (int i = 0; i < 20000; ++i) c.points.emplace_back(0.001f * i, std::sin(0.01f * i), 1.f);
  {
    io::RawlogWriter w(dir + "/abandoned.rawlog");
    w.writePointCloud(c, Isometry3d::Identity(), 1.0, "x");
  }  // destroyed without close(): no output, no temporary left
  EXPECT_TRUE(fs::is_empty(dir));
  const std::string good = dir + "/good.rawlog";
  io::RawlogWriter w(good);
  w.writePointCloud(c, Isometry3d::Identity(), 1.0, "x");
  w.close();
  EXPECT_EQ(io::readRawlog(good).size(), 1u);

  std::ifstream is(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(is)), {});
  const std::string cut = dir + "/cut.rawlog";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  try {
    io::readRawlog(cut);
    ADD_FAILURE() << "a truncated rawlog was read without error";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/text.rawlog") << "this is not a rawlog at all, just some text\n";
  EXPECT_THROW(io::readRawlog(dir + "/text.rawlog"), FormatError);
  EXPECT_THROW(io::RawlogReader(dir + "/missing.rawlog"), IoError);
  EXPECT_THROW(io::RawlogWriter(dir + "/no/such/folder/x.rawlog"), IoError);
  io::DepthImage small;
  small.width = 2, small.height = 2, small.data.assign(4, 1000);
  io::RawlogWriter w2(dir + "/d.rawlog");
  EXPECT_THROW(w2.writeDepth(small, 1000.0, io::PinholeIntrinsics{}, Isometry3d::Identity(), 0, ""),
               ContractError);
}

TEST(Rawlog, FuzzFindingHugeStringLengthIsAFormatError) {
  // Found by tests/fuzz (scripts/fuzz.sh): a corrupt CObservation2DRangeScan inside a sensory
  // frame whose string length field claims ~2.3 GB. MRPT allocates that much before it finds
  // the stream short; the reader must then report the damage as a FormatError naming the file
  // and the object, after the observations it could read.
  const std::string path = obm::test::sourceDir() +
                           "/tests/fuzz/regressions/rawlog/mrpt_string_length_4gb.rawlog";
  obm::io::RawlogReader reader(path);
  obm::io::RawlogObservation obs;
  std::size_t read = 0;
  try {
    while (reader.next(obs)) ++read;
    ADD_FAILURE() << "the corrupt object must be reported";
  } catch (const obm::FormatError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find(path), std::string::npos) << w;
    EXPECT_NE(w.find("object 27"), std::string::npos) << w;
  }
  EXPECT_GT(read, 0u) << "the observations before the damage are played";
}
