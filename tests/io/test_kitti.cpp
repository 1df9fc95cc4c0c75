// KITTI odometry files: real HDL-64 scans, the real sequence-00 poses / times / calibration, round
// trips, malformed input and the camera↔LiDAR pose conversion.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/kitti.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;
namespace fs = std::filesystem;

namespace {

std::string kittiDir() {
  return test::sharedDataDir() + "/kitti";
}
std::string scanFile(int i) {
  return kittiDir() + "/hdl64_sample/" + kittiScanFileName(i);
}

std::string readBytes(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>());
}

void writeText(const std::string& path, const std::string& s) {
  std::ofstream os(path, std::ios::binary);
  os << s;
}

double orthonormalityError(const Eigen::Matrix3d& R) {
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
}

}  // namespace

TEST(KittiVelodyne, RealHdl64ScansArePlausible) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample");
  for (int i = 0; i < 6; ++i) {
    SCOPED_TRACE(scanFile(i));
    KittiScanStats st;
    const PointCloud pc = readKittiVelodyne(scanFile(i), &st);
    EXPECT_EQ(st.num_records, fs::file_size(scanFile(i)) / 16);
    EXPECT_EQ(pc.size() + st.num_non_finite, st.num_records);
    // An HDL-64E revolution holds ~120-130k returns.
    EXPECT_GT(pc.size(), 100000u);
    EXPECT_LT(pc.size(), 150000u);
    ASSERT_EQ(pc.intensity.size(), pc.size());
    EXPECT_EQ(pc.frame_id, "velodyne");
    double max_range = 0.0;
    std::size_t near_sensor = 0;
    for (std::size_t k = 0; k < pc.size(); ++k) {
      const double r = pc.points[k].cast<double>().norm();
      max_range = std::max(max_range, r);
      if (r < 1.0) ++near_sensor;
      ASSERT_GE(pc.intensity[k], 0.f);  // KITTI reflectance is in [0, 1]
      ASSERT_LE(pc.intensity[k], 1.f);
    }
    // The HDL-64E's rated range is 120 m; street scenes give returns out to several tens of metres.
    EXPECT_GT(max_range, 30.0);
    EXPECT_LT(max_range, 130.0);
    EXPECT_LT(near_sensor, pc.size() / 100);  // the car roof blocks the closest metre
    Vector3f lo, hi;
    pc.bounds(lo, hi);
    EXPECT_GT(lo.z(), -30.f);  // the sensor sits ~1.7 m above the road
    EXPECT_LT(hi.z(), 30.f);
  }
}

TEST(KittiVelodyne, RoundTripIsByteExact) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample");
  const std::string dir = test::scratchDir("kitti_velo_roundtrip");
  KittiScanStats st;
  const PointCloud a = readKittiVelodyne(scanFile(3), &st);
  const std::string out = dir + "/" + kittiScanFileName(3);
  writeKittiVelodyne(out, a);
  const PointCloud b = readKittiVelodyne(out);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a.points[k], b.points[k]) << k;
    ASSERT_EQ(a.intensity[k], b.intensity[k]) << k;
  }
  if (st.num_non_finite == 0) {
    EXPECT_EQ(readBytes(out), readBytes(scanFile(3)));
  }
  // No temporary file is left behind by the atomic write.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(KittiVelodyne, NonFinitePointsAreDroppedAndCounted) {
  const std::string dir = test::scratchDir("kitti_velo_nan");
  PointCloud pc;
  pc.points = {{1, 2, 3},
               {std::numeric_limits<float>::quiet_NaN(), 0, 0},
               {4, 5, 6},
               {0, std::numeric_limits<float>::infinity(), 0},
               {7, 8, 9}};
  pc.intensity = {0.1f, 0.2f, 0.3f, 0.4f, std::numeric_limits<float>::quiet_NaN()};
  writeKittiVelodyne(dir + "/x.bin", pc);
  EXPECT_EQ(fs::file_size(dir + "/x.bin"), 5u * 16u);
  KittiScanStats st;
  const PointCloud back = readKittiVelodyne(dir + "/x.bin", &st);
  EXPECT_EQ(st.num_records, 5u);
  EXPECT_EQ(st.num_non_finite, 3u);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.points[1], Vector3f(4, 5, 6));
  EXPECT_FLOAT_EQ(back.intensity[1], 0.3f);

  PointCloud no_intensity;
  no_intensity.points = {{1, 1, 1}};
  writeKittiVelodyne(dir + "/y.bin", no_intensity);
  EXPECT_EQ(readKittiVelodyne(dir + "/y.bin").intensity.at(0), 0.f);
}

TEST(KittiVelodyne, BadSizeAndMissingFileThrowNamingTheFile) {
  const std::string dir = test::scratchDir("kitti_velo_bad");
  const std::string bad = dir + "/000007.bin";
  writeText(bad, std::string(16 * 3 + 5, '\0'));
  try {
    readKittiVelodyne(bad);
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.file(), bad);
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("16"), std::string::npos) << e.what();
  }
  try {
    readKittiVelodyne(dir + "/missing.bin");
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.bin"), std::string::npos) << e.what();
  }
  writeText(dir + "/empty.bin", "");
  EXPECT_TRUE(readKittiVelodyne(dir + "/empty.bin").empty());
}

TEST(KittiPoses, RealSequence00) {
  OBM_REQUIRE_SHARED_DATA("kitti/poses/00.txt");
  const auto poses = readKittiPoses(kittiDir() + "/poses/00.txt");
  ASSERT_EQ(poses.size(), 4541u);
  // The file stores 7 significant digits, so rotations are orthonormal to ~1e-6.
  double worst = 0.0;
  for (const auto& T : poses) {
    worst = std::max(worst, orthonormalityError(T.linear()));
    ASSERT_NEAR(T.linear().determinant(), 1.0, 1e-5);
  }
  EXPECT_LT(worst, 1e-5);
  EXPECT_LT((poses.front().matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 1e-6);
  // Sequence 00 is a drive of ~3.7 km: consecutive camera poses are less than 2 m apart (10 Hz)
  // and the path length is kilometres.
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const double step = (poses[i].translation() - poses[i - 1].translation()).norm();
    ASSERT_LT(step, 2.0) << i;
    length += step;
  }
  EXPECT_GT(length, 3000.0);
  EXPECT_LT(length, 4500.0);
}

TEST(KittiPoses, RoundTripIsExact) {
  OBM_REQUIRE_SHARED_DATA("kitti/poses/00.txt");
  const auto a = readKittiPoses(kittiDir() + "/poses/00.txt");
  const std::string out = test::scratchDir("kitti_poses_rt") + "/00.txt";
  writeKittiPoses(out, a);
  const auto b = readKittiPoses(out);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_LE((a[i].matrix() - b[i].matrix()).cwiseAbs().maxCoeff(), 1e-12) << i;
  // Values that need all 17 digits survive too.
  std::vector<Isometry3d> hard{
      makeIsometry(expSO3(Eigen::Vector3d(0.1, -0.7, 1.3)),
                   Eigen::Vector3d(1.0 / 3.0, -2e-300, 12345.678901234567))};
  writeKittiPoses(out, hard);
  EXPECT_EQ(readKittiPoses(out).at(0).matrix(), hard[0].matrix());
}

TEST(KittiPoses, WrongColumnCountNamesTheLine) {
  const std::string dir = test::scratchDir("kitti_poses_bad");
  const std::string ok = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  writeText(dir + "/p.txt", ok + ok + "1 0 0 0 0 1 0 0 0 0 1\n" + ok);
  try {
    readKittiPoses(dir + "/p.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 3u);
    EXPECT_NE(std::string(e.what()).find(dir + "/p.txt:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("got 11"), std::string::npos) << e.what();
  }
  writeText(dir + "/q.txt", ok + "1 0 0 0 0 1 0 0 0 0 x 0\n");
  try {
    readKittiPoses(dir + "/q.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_NE(std::string(e.what()).find("'x'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readKittiPoses(dir + "/nope.txt"), IoError);
}

TEST(KittiTimes, RealSequence00AndRoundTrip) {
  OBM_REQUIRE_SHARED_DATA("kitti/times/00.txt");
  const auto t = readKittiTimes(kittiDir() + "/times/00.txt");
  ASSERT_EQ(t.size(), 4541u);
  EXPECT_EQ(t.front(), 0.0);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double dt = t[i] - t[i - 1];
    ASSERT_GT(dt, 0.05) << i;  // the Velodyne spins at 10 Hz
    ASSERT_LT(dt, 0.2) << i;
  }
  const std::string dir = test::scratchDir("kitti_times");
  writeKittiTimes(dir + "/times.txt", t);
  EXPECT_EQ(readKittiTimes(dir + "/times.txt"), t);
  writeText(dir + "/bad.txt", "0.0\n0.1 0.2\n");
  try {
    readKittiTimes(dir + "/bad.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
  }
}

TEST(KittiCalib, RealCalibration00) {
  OBM_REQUIRE_SHARED_DATA("kitti/calib/00.txt");
  const KittiCalib c = readKittiCalib(kittiDir() + "/calib/00.txt");
  ASSERT_TRUE(c.has_P0);
  EXPECT_GT(c.P0(0, 0), 500.0);  // focal length [px] of the 1241×376 grey cameras
  EXPECT_NEAR(c.P0(0, 0), c.P0(1, 1), 1e-9);
  EXPECT_GT(c.P0(0, 2), 0.0);
  EXPECT_LT(c.P0(0, 2), 1241.0);
  const Eigen::Matrix3d R = c.T_cam0_velo.linear();
  EXPECT_LT(orthonormalityError(R), 1e-6);
  // Velodyne x (forward) is camera z, velodyne y (left) is camera −x, velodyne z (up) is camera −y.
  EXPECT_GT((R * Eigen::Vector3d::UnitX()).dot(Eigen::Vector3d::UnitZ()), 0.99);
  EXPECT_GT((R * Eigen::Vector3d::UnitY()).dot(-Eigen::Vector3d::UnitX()), 0.99);
  EXPECT_GT((R * Eigen::Vector3d::UnitZ()).dot(-Eigen::Vector3d::UnitY()), 0.99);
  EXPECT_LT(c.T_cam0_velo.translation().norm(), 0.5);  // sensors ~30 cm apart on the rig

  const std::string dir = test::scratchDir("kitti_calib");
  writeKittiCalib(dir + "/calib.txt", c);
  const KittiCalib d = readKittiCalib(dir + "/calib.txt");
  EXPECT_EQ(d.P0, c.P0);
  EXPECT_EQ(d.T_cam0_velo.matrix(), c.T_cam0_velo.matrix());

  writeText(dir + "/no_tr.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_THROW(readKittiCalib(dir + "/no_tr.txt"), FormatError);
  writeText(dir + "/short_tr.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: 1 0 0\n");
  try {
    readKittiCalib(dir + "/short_tr.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
  }
}

TEST(KittiFrames, CameraLidarConversionExactMath) {
  // Tr maps velodyne axes to camera axes (x_c = −y_v, y_c = −z_v, z_c = x_v) plus an offset.
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  const Isometry3d Tr = makeIsometry(R, Eigen::Vector3d(0.1, -0.2, 0.3));
  // The camera moves 2 m along its optical axis (z) and turns about its y axis.
  const Isometry3d T_w_cam =
      makeIsometry(expSO3(Eigen::Vector3d(0, 0.3, 0)), Eigen::Vector3d(0, 0, 2));
  const Isometry3d T_w_velo = cameraToLidarPose(T_w_cam, Tr);
  const Isometry3d expected = Tr.inverse() * T_w_cam * Tr;
  EXPECT_LT((T_w_velo.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-15);
  // Camera y (down) is LiDAR −z, so the turn about camera y is a turn about LiDAR −z.
  EXPECT_LT((logSO3(T_w_velo.linear()) - Eigen::Vector3d(0, 0, -0.3)).norm(), 1e-12);
  // Identity camera pose ↔ identity LiDAR pose: "world" is the first sensor frame in both.
  EXPECT_LT((cameraToLidarPose(Isometry3d::Identity(), Tr).matrix() - Eigen::Matrix4d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  const Isometry3d back = lidarToCameraPose(T_w_velo, Tr);
  EXPECT_LT((back.matrix() - T_w_cam.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  const auto many = lidarToCameraPoses(cameraToLidarPoses({T_w_cam, T_w_cam.inverse()}, Tr), Tr);
  ASSERT_EQ(many.size(), 2u);
  EXPECT_LT((many[1].matrix() - T_w_cam.inverse().matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(KittiFrames, RealGroundTruthInLidarFrameDrivesForward) {
  OBM_REQUIRE_SHARED_DATA("kitti/calib/00.txt");
  const auto cam = readKittiPoses(kittiDir() + "/poses/00.txt");
  const auto calib = readKittiCalib(kittiDir() + "/calib/00.txt");
  const auto velo = cameraToLidarPoses(cam, calib.T_cam0_velo);
  ASSERT_EQ(velo.size(), cam.size());
  EXPECT_LT((velo[0].matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff(), 1e-5);
  // Along the first second of sequence 00 the car drives straight ahead: +x of the LiDAR frame,
  // staying on the ground plane (small z).
  const Eigen::Vector3d p = velo[10].translation();
  EXPECT_GT(p.x(), 5.0);
  EXPECT_LT(std::abs(p.y()), 0.1 * p.x());
  EXPECT_LT(std::abs(p.z()), 0.1 * p.x());
  // Relative motions are preserved by the (rigid) change of frame.
  for (std::size_t i : {1u, 500u, 4000u}) {
    const double dc = relative(cam[i - 1], cam[i]).translation().norm();
    const double dv = relative(velo[i - 1], velo[i]).translation().norm();
    EXPECT_NEAR(rotationAngle(relative(cam[i - 1], cam[i]).linear()),
                rotationAngle(relative(velo[i - 1], velo[i]).linear()), 1e-6);
    EXPECT_GT(dv, 0.0);
    EXPECT_LT(std::abs(dv - dc), 0.05 + 0.01 * dc);  // lever arm of Tr × rotation
  }
}

namespace {

/// A devkit-layout copy of the 6 sample scans: <root>/sequences/00/{velodyne,times.txt,calib.txt}
/// and <root>/poses/00.txt. Scans are symbolic links to the shared data (nothing is copied).
std::string makeSequence(const std::string& name, std::size_t n_times, std::size_t n_poses) {
  const std::string root = test::scratchDir(name);
  const std::string seq = root + "/sequences/00";
  fs::create_directories(seq + "/velodyne");
  fs::create_directories(root + "/poses");
  for (int i = 0; i < 6; ++i)
    fs::create_symlink(fs::absolute(scanFile(i)), seq + "/velodyne/" + kittiScanFileName(i));
  auto times = readKittiTimes(kittiDir() + "/times/00.txt");
  times.resize(n_times);
  writeKittiTimes(seq + "/times.txt", times);
  writeKittiCalib(seq + "/calib.txt", readKittiCalib(kittiDir() + "/calib/00.txt"));
  auto poses = readKittiPoses(kittiDir() + "/poses/00.txt");
  poses.resize(n_poses);
  writeKittiPoses(root + "/poses/00.txt", poses);
  return seq;
}

}  // namespace

TEST(KittiSequence, OpensDevkitLayout) {
  OBM_REQUIRE_SHARED_DATA("kitti");
  const std::string seq_dir = makeSequence("kitti_seq", 6, 6);
  const KittiSequence seq(seq_dir);
  ASSERT_EQ(seq.size(), 6u);
  EXPECT_EQ(seq.name(), "00");
  const auto times = readKittiTimes(seq_dir + "/times.txt");
  const PointCloud s2 = seq.scan(2);
  EXPECT_EQ(s2.timestamp, times[2]);
  EXPECT_EQ(s2.size(), readKittiVelodyne(scanFile(2)).size());
  ASSERT_TRUE(seq.hasGroundTruth());
  EXPECT_EQ(fs::path(seq.groundTruthPath()).filename(), "00.txt");
  ASSERT_EQ(seq.groundTruthLidar().size(), 6u);
  const auto expected = cameraToLidarPoses(seq.groundTruthCamera(), seq.calib().T_cam0_velo);
  for (std::size_t i = 0; i < 6; ++i)
    EXPECT_EQ(seq.groundTruthLidar()[i].matrix(), expected[i].matrix());
  const auto stamped = seq.groundTruthLidarStamped();
  ASSERT_EQ(stamped.size(), 6u);
  EXPECT_EQ(stamped[5].t, times[5]);
  EXPECT_THROW(seq.scan(6), ContractError);

  // poses.txt beside velodyne/ takes precedence over the devkit's poses/NN.txt.
  std::vector<Isometry3d> shifted(6, makeIsometry(Eigen::Matrix3d::Identity(), {0, 0, 1}));
  writeKittiPoses(seq_dir + "/poses.txt", shifted);
  const KittiSequence seq2(seq_dir);
  EXPECT_EQ(seq2.groundTruthPath(), seq_dir + "/poses.txt");
  EXPECT_NEAR(seq2.groundTruthCamera()[3].translation().z(), 1.0, 0.0);
}

TEST(KittiSequence, InconsistentOrMissingPartsThrow) {
  OBM_REQUIRE_SHARED_DATA("kitti");
  {
    const std::string seq_dir = makeSequence("kitti_seq_times", 5, 6);
    try {
      KittiSequence seq(seq_dir);
      FAIL() << "expected FormatError";
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("times.txt"), std::string::npos) << e.what();
    }
  }
  {
    const std::string seq_dir = makeSequence("kitti_seq_poses", 6, 7);
    EXPECT_THROW(KittiSequence seq(seq_dir), FormatError);
    fs::remove(seq_dir + "/../../poses/00.txt");
    const KittiSequence no_gt(seq_dir);  // ground truth is optional
    EXPECT_FALSE(no_gt.hasGroundTruth());
    EXPECT_TRUE(no_gt.groundTruthLidarStamped().empty());
    fs::remove(seq_dir + "/calib.txt");
    EXPECT_THROW(KittiSequence seq(seq_dir), IoError);
  }
  EXPECT_THROW(KittiSequence seq(test::scratchDir("kitti_seq_empty")), IoError);
}
