#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/io/convert.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;
namespace fs = std::filesystem;

namespace {

Isometry3d poseAt(double k) {
  Isometry3d T = Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d(0.1, 1.0, 0.2).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.3 * k, -0.02 * k, 1.1 * k);
  return T;
}

/// A 4-scan KITTI sequence folder with ground truth in <dir>/poses.txt.
std::string makeKittiSequence(const std::string& name, bool with_poses) {
  const std::string dir = test::scratchDir(name);
  fs::create_directories(dir + "/velodyne");
  for (int s = 0; s < 4; ++s) {
    PointCloud c;
    for (int i = 0; i < 50 + s; ++i) {
      c.points.emplace_back(0.5f * i - 3.f, static_cast<float>(s), 0.01f * i * i);
      c.intensity.push_back(0.01f * i);
    }
    writeKittiVelodyne(dir + "/velodyne/" + kittiScanFileName(s), c);
  }
  writeKittiTimes(dir + "/times.txt", {0.0, 0.1036, 0.2073, 0.3110});
  KittiCalib calib;
  calib.T_cam0_velo = poseAt(7.0);
  writeKittiCalib(dir + "/calib.txt", calib);
  if (with_poses) {
    std::vector<Isometry3d> poses;
    for (int s = 0; s < 4; ++s) poses.push_back(s == 0 ? Isometry3d::Identity() : poseAt(s));
    writeKittiPoses(dir + "/poses.txt", poses);
  }
  return dir;
}

}  // namespace

TEST(Convert, KittiToRawlogKeepsScansTimesAndIntensity) {
  const std::string seq_dir = makeKittiSequence("conv_kitti", true);
  const std::string out = test::scratchDir("conv_kitti_out") + "/seq.rawlog";
  KittiToRawlogOptions opt;
  opt.time_offset = 1317384000.0;
  opt.stride = 2;
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  EXPECT_EQ(kittiToRawlog(seq_dir, out, opt,
                          [&](std::size_t d, std::size_t t) { calls.emplace_back(d, t); }),
            2u);
  EXPECT_EQ(calls, (std::vector<std::pair<std::size_t, std::size_t>>{{1, 2}, {2, 2}}));
  const KittiSequence seq(seq_dir);
  const auto obs = readRawlog(out);
  ASSERT_EQ(obs.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const PointCloud scan = seq.scan(2 * k);
    EXPECT_EQ(obs[k].class_name, "CObservationPointCloud");
    EXPECT_EQ(obs[k].sensor_label, "velodyne");
    EXPECT_NEAR(obs[k].timestamp, opt.time_offset + seq.timestamp(2 * k), 1e-6);
    EXPECT_EQ(obs[k].cloud.points, scan.points);  // vehicle frame = LiDAR frame (identity)
    EXPECT_EQ(obs[k].cloud.intensity, scan.intensity);
  }
  opt.stride = 0;
  EXPECT_THROW(kittiToRawlog(seq_dir, out + "2", opt), ContractError);
  EXPECT_FALSE(fs::exists(out + "2"));
}

TEST(Convert, KittiToTumInLidarOrCameraFrame) {
  const std::string seq_dir = makeKittiSequence("conv_kitti_tum", true);
  const std::string out_dir = test::scratchDir("conv_kitti_tum_out");
  const KittiSequence seq(seq_dir);
  EXPECT_EQ(kittiToTum(seq_dir, out_dir + "/velo.txt", KittiPoseFrame::Lidar, "", 5.0), 4u);
  EXPECT_EQ(kittiToTum(seq_dir, out_dir + "/cam.txt", KittiPoseFrame::Camera), 4u);
  const Trajectory velo = readTumTrajectory(out_dir + "/velo.txt");
  const Trajectory cam = readTumTrajectory(out_dir + "/cam.txt");
  ASSERT_EQ(velo.size(), 4u);
  ASSERT_EQ(cam.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(velo[i].t, seq.timestamp(i) + 5.0, 1e-9);
    EXPECT_NEAR(cam[i].t, seq.timestamp(i), 1e-9);
    EXPECT_TRUE(cam[i].T.isApprox(seq.groundTruthCamera()[i], 1e-9));
    const Isometry3d expected =
        cameraToLidarPose(seq.groundTruthCamera()[i], seq.calib().T_cam0_velo);
    EXPECT_TRUE(velo[i].T.isApprox(expected, 1e-9)) << i;
  }
  const std::string no_gt = makeKittiSequence("conv_kitti_nogt", false);
  EXPECT_THROW(kittiToTum(no_gt, out_dir + "/none.txt", KittiPoseFrame::Lidar), IoError);
  EXPECT_FALSE(fs::exists(out_dir + "/none.txt"));
}

TEST(Convert, RealKittiScansToRawlog) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample");
  const std::string data = test::sharedDataDir() + "/kitti";
  const std::string seq_dir = test::scratchDir("conv_kitti_real");
  fs::create_directories(seq_dir + "/velodyne");
  for (int i = 0; i < 2; ++i)  // links, not copies
    fs::create_symlink(fs::absolute(data + "/hdl64_sample/" + kittiScanFileName(i)),
                       seq_dir + "/velodyne/" + kittiScanFileName(i));
  auto times = readKittiTimes(data + "/times/00.txt");
  times.resize(2);
  writeKittiTimes(seq_dir + "/times.txt", times);
  writeKittiCalib(seq_dir + "/calib.txt", readKittiCalib(data + "/calib/00.txt"));
  const std::string out = seq_dir + "/out.rawlog";
  ASSERT_EQ(kittiToRawlog(seq_dir, out), 2u);
  RawlogReader reader(out);
  RawlogObservation o;
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(reader.next(o));
    const PointCloud scan = readKittiVelodyne(seq_dir + "/velodyne/" + kittiScanFileName(i));
    EXPECT_GT(scan.size(), 100000u);
    ASSERT_EQ(o.cloud.size(), scan.size());
    EXPECT_EQ(o.cloud.points.back(), scan.points.back());
    EXPECT_EQ(o.cloud.intensity.back(), scan.intensity.back());
  }
  EXPECT_FALSE(reader.next(o));
}

TEST(Convert, TumDepthFramesToRawlog) {
  const std::string dir = test::scratchDir("conv_tum");
  fs::create_directories(dir + "/depth");
  std::vector<StampedFile> list;
  std::vector<DepthImage> images;
  for (int f = 0; f < 3; ++f) {
    DepthImage d;
    d.width = 640, d.height = 480;
    d.data.resize(640 * 480);
    for (int v = 0; v < 480; ++v)
      for (int u = 0; u < 640; ++u)
        d.at(u, v) = static_cast<std::uint16_t>((u + v) % 7 == 0 ? 0 : 5000 + 10 * f + u);
    const std::string name = "depth/" + std::to_string(f) + ".png";
    writeDepthPng(dir + "/" + name, d);
    list.push_back({1305031102.16 + 0.033 * f, name});
    images.push_back(std::move(d));
  }
  writeTumFileList(dir + "/depth.txt", list, "depth maps");
  const std::string out = dir + "/tum.rawlog";
  RgbdToRawlogOptions opt;
  opt.layout = parseRgbdLayout("TUM");
  EXPECT_EQ(rgbdToRawlog(dir, out, opt), 3u);
  const auto obs = readRawlog(out);
  ASSERT_EQ(obs.size(), 3u);
  for (std::size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(obs[f].class_name, "CObservation3DRangeScan");
    EXPECT_EQ(obs[f].sensor_label, "rgbd");
    EXPECT_NEAR(obs[f].timestamp, list[f].t, 1e-6);
    ASSERT_TRUE(obs[f].has_depth);
    EXPECT_EQ(obs[f].depth.data, images[f].data);
    EXPECT_EQ(obs[f].depth_scale, 5000.0);
    EXPECT_DOUBLE_EQ(obs[f].intrinsics.fx, 525.0);
    EXPECT_TRUE(obs[f].T_vehicle_camera.isApprox(Isometry3d::Identity(), 1e-12));
    // Vehicle frame = optical frame: every point lies in front of the camera, z ≈ raw / 5000.
    ASSERT_FALSE(obs[f].cloud.empty());
    for (const auto& p : obs[f].cloud.points) ASSERT_GT(p.z(), 0.99f);
  }
  EXPECT_THROW(parseRgbdLayout("kinect"), ConfigError);
  EXPECT_EQ(parseRgbdLayout("7-Scenes"), RgbdLayout::SevenScenes);
}

TEST(Convert, RealRedwoodFramesToRawlog) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d");
  const std::string dir = test::sharedDataDir() + "/rgbd_open3d";
  const std::string out = test::scratchDir("conv_redwood") + "/redwood.rawlog";
  RgbdToRawlogOptions opt;
  opt.layout = RgbdLayout::Redwood;
  opt.count = 2;
  opt.time_offset = 100.0;
  ASSERT_EQ(rgbdToRawlog(dir, out, opt), 2u);
  const auto obs = readRawlog(out);
  ASSERT_EQ(obs.size(), 2u);
  const RgbdSequence seq = RgbdSequence::openRedwood(dir);
  for (std::size_t f = 0; f < 2; ++f) {
    EXPECT_NEAR(obs[f].timestamp, seq.frame(f).timestamp + 100.0, 1e-6);
    EXPECT_EQ(obs[f].depth.data, seq.depth(f).data);
    EXPECT_EQ(obs[f].depth_scale, seq.depthScale());
    // The rawlog's cloud is the sequence's own back-projection (no distortion is written).
    const PointCloud expected = seq.cloud(f);
    ASSERT_EQ(obs[f].cloud.size(), expected.size());
    EXPECT_GT(expected.size(), 50000u);
    for (std::size_t i = 0; i < expected.size(); i += 997)
      ASSERT_LT((obs[f].cloud.points[i] - expected.points[i]).norm(), 1e-4f) << i;
  }
}
