// OctomapExporter end to end: a tiny KITTI-layout box room the test writes (KITTI camera-frame
// poses, TUM LiDAR poses, obm-map output folder), bad input, interruption, and the real KITTI
// HDL-64 sample scans at identity.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <atomic>
#include <filesystem>
#include <fstream>

#include "mapping_test_utils.hpp"
#include "obm/core/errors.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "obm/slam/octomap_exporter.hpp"
#include "test_data.hpp"

namespace {

using obm::Isometry3d;
using obm::mapping::CellState;
using obm::slam::ExporterOptions;
using obm::mapping::OccupancyMap;
using obm::slam::OctomapExporter;
using obm::slam::TrajectoryFormat;
namespace fs = std::filesystem;

// The room in the world frame (= LiDAR frame of the first scan): 8 × 6 × 3.2 m, floor 1.5 m below
// the sensor. Bounds are odd multiples of 0.1 so walls lie in the middle of a 0.2 m voxel layer.
const Eigen::Vector3d kRoomLo(-2.9, -2.9, -1.5);
const Eigen::Vector3d kRoomHi(5.1, 3.1, 1.7);

// A KITTI-like extrinsic: camera x right, y down, z forward vs. LiDAR x forward, y left, z up,
// plus a small offset, so that camera and LiDAR poses differ.
Isometry3d cameraFromLidar() {
  Eigen::Matrix3d R;
  R << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  Isometry3d T = Isometry3d::Identity();
  T.linear() = R;
  T.translation() = Eigen::Vector3d(0.03, -0.08, -0.27);
  return T;
}

std::vector<Isometry3d> lidarPoses() {
  std::vector<Isometry3d> poses;
  for (int k = 0; k < 3; ++k) {
    Isometry3d T = Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(0.15 * k, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = Eigen::Vector3d(0.6 * k, 0.2 * k, 0.0);
    poses.push_back(T);
  }
  return poses;
}

/// Writes velodyne/*.bin, calib.txt, times.txt, poses.txt (camera frame) of the box room.
std::string writeBoxRoomSequence(const std::string& name) {
  const std::string dir = obm::test::scratchDir(name);
  fs::create_directories(dir + "/velodyne");
  const auto poses = lidarPoses();
  std::vector<double> times;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    obm::io::writeKittiVelodyne(
        dir + "/velodyne/" + obm::io::kittiScanFileName(k),
        obm::test::boxRoomScan(kRoomLo, kRoomHi, poses[k], 360, -60.0, 60.0, 1.0));
    times.push_back(0.1 * k);
  }
  obm::io::KittiCalib calib;
  calib.T_cam0_velo = cameraFromLidar();
  obm::io::writeKittiCalib(dir + "/calib.txt", calib);
  obm::io::writeKittiTimes(dir + "/times.txt", times);
  obm::io::writeKittiPoses(dir + "/poses.txt",
                           obm::io::lidarToCameraPoses(poses, calib.T_cam0_velo));
  return dir;
}

ExporterOptions baseOptions(const std::string& seq, const std::string& traj,
                            const std::string& out) {
  ExporterOptions o;
  o.input = seq;
  o.trajectory = traj;
  o.output = out;
  o.progress = false;
  o.mapping.resolution = 0.2;
  return o;
}

void expectBoxRoom(const OccupancyMap& map) {
  // Walls occupied (points in the middle of each wall's voxel layer), the room's inside free,
  // outside unknown.
  EXPECT_EQ(map.state({5.1, 0.3, 0.1}), CellState::Occupied);   // +x wall
  EXPECT_EQ(map.state({-2.9, 0.3, 0.1}), CellState::Occupied);  // −x wall
  EXPECT_EQ(map.state({1.1, 3.1, 0.1}), CellState::Occupied);   // +y wall
  EXPECT_EQ(map.state({1.1, 0.3, -1.5}), CellState::Occupied);  // floor
  EXPECT_EQ(map.state({1.1, 0.3, 1.7}), CellState::Occupied);   // ceiling
  EXPECT_EQ(map.state({1.1, 0.3, 0.1}), CellState::Free);
  EXPECT_EQ(map.state({3.5, -1.5, -0.5}), CellState::Free);
  EXPECT_EQ(map.state({7.0, 0.3, 0.1}), CellState::Unknown);
  EXPECT_EQ(map.state({1.1, 0.3, 3.0}), CellState::Unknown);
  const auto s = map.stats();
  EXPECT_TRUE((s.bbox_min.array() >= kRoomLo.array() - 0.21).all()) << s.bbox_min.transpose();
  EXPECT_TRUE((s.bbox_max.array() <= kRoomHi.array() + 0.21).all()) << s.bbox_max.transpose();
}

TEST(OctomapExporter, KittiFolderWithCameraFramePoses) {
  const std::string seq = writeBoxRoomSequence("exporter_kitti_seq");
  const std::string out = obm::test::scratchDir("exporter_kitti_out");
  auto o = baseOptions(seq, seq + "/poses.txt", out + "/map.bt");
  o.png = out + "/top.png";
  const auto sum = OctomapExporter(o).run();
  EXPECT_EQ(sum.input_kind, "kitti");
  EXPECT_EQ(sum.trajectory_format, TrajectoryFormat::Kitti);
  EXPECT_EQ(sum.frames, 3u);
  EXPECT_EQ(sum.frames_integrated, 3u);
  EXPECT_FALSE(sum.interrupted);
  EXPECT_FALSE(sum.stats.empty());

  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(out + "/map.bt"));
  EXPECT_NEAR(tree.getResolution(), 0.2, 1e-12);
  EXPECT_EQ(tree.getNumLeafNodes(), sum.stats.num_leaves);
  expectBoxRoom(OccupancyMap::read(out + "/map.bt"));
  EXPECT_TRUE(fs::is_regular_file(out + "/top.png"));
  EXPECT_GT(sum.top_view.width, 0);
  const std::string text = obm::slam::formatSummary(sum);
  EXPECT_NE(text.find("leaves"), std::string::npos);
  EXPECT_NE(text.find("bounding box"), std::string::npos);
}

TEST(OctomapExporter, TumLidarPosesAndObmMapFolderGiveTheSameMap) {
  const std::string seq = writeBoxRoomSequence("exporter_tum_seq");
  const std::string out = obm::test::scratchDir("exporter_tum_out");
  // The same trajectory as LiDAR poses with time stamps (TUM), and an obm-map-like output folder.
  obm::io::writeTumTrajectory(out + "/lidar_tum.txt",
                              obm::io::stampPoses(lidarPoses(), {0.0, 0.1, 0.2}));
  fs::create_directories(out + "/run");
  fs::copy_file(seq + "/poses.txt", out + "/run/trajectory_kitti.txt");

  const auto a = OctomapExporter(baseOptions(seq, seq + "/poses.txt", out + "/a.bt")).run();
  const auto b = OctomapExporter(baseOptions(seq, out + "/lidar_tum.txt", out + "/b.bt")).run();
  const auto c = OctomapExporter(baseOptions(seq, out + "/run", out + "/c.ot")).run();
  EXPECT_EQ(b.trajectory_format, TrajectoryFormat::Tum);
  EXPECT_EQ(b.frames_integrated, 3u);
  EXPECT_EQ(c.trajectory_path, out + "/run/trajectory_kitti.txt");
  EXPECT_EQ(a.stats.num_leaves, b.stats.num_leaves);
  EXPECT_EQ(a.stats.num_occupied_leaves, b.stats.num_occupied_leaves);
  EXPECT_EQ(a.stats.num_leaves, c.stats.num_leaves);
  expectBoxRoom(OccupancyMap::read(out + "/c.ot"));

  // --every 2 takes scans 0 and 2.
  auto o = baseOptions(seq, seq + "/poses.txt", out + "/every.bt");
  o.every = 2;
  EXPECT_EQ(OctomapExporter(o).run().frames_integrated, 2u);
}

TEST(OctomapExporter, DetectsTrajectoryFormat) {
  const std::string dir = obm::test::scratchDir("exporter_detect");
  {
    std::ofstream(dir + "/k.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n";
    std::ofstream(dir + "/t.txt") << "# timestamp tx ty tz qx qy qz qw\n\n0.5 1 2 3 0 0 0 1\n";
    std::ofstream(dir + "/bad.txt") << "# comment\n1 2 3 4 5\n";
  }
  EXPECT_EQ(obm::slam::detectTrajectoryFormat(dir + "/k.txt"), TrajectoryFormat::Kitti);
  EXPECT_EQ(obm::slam::detectTrajectoryFormat(dir + "/t.txt"), TrajectoryFormat::Tum);
  try {
    obm::slam::detectTrajectoryFormat(dir + "/bad.txt");
    FAIL();
  } catch (const obm::FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_EQ(e.file(), dir + "/bad.txt");
  }
  EXPECT_THROW(obm::slam::detectTrajectoryFormat(dir + "/none.txt"), obm::IoError);
  EXPECT_EQ(obm::slam::parseTrajectoryFormat("TUM"), TrajectoryFormat::Tum);
  EXPECT_THROW(obm::slam::parseTrajectoryFormat("g2o"), obm::ConfigError);
}

// Runs the exporter expecting `E`; checks that the message names `needle` and nothing was written.
template <typename E>
void expectFailsWritingNothing(const ExporterOptions& o, const std::string& needle) {
  try {
    OctomapExporter(o).run();
    ADD_FAILURE() << "expected an exception naming " << needle;
  } catch (const E& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
  const fs::path out_dir = fs::path(o.output).parent_path();
  if (fs::is_directory(out_dir))
    for (const auto& f : fs::directory_iterator(out_dir)) {
      const std::string name = f.path().filename().string();
      EXPECT_TRUE(name.find(".bt") == std::string::npos && name.find(".png") == std::string::npos)
          << "left behind: " << name;
    }
}

TEST(OctomapExporter, BadInputNamesTheFileAndWritesNothing) {
  const std::string seq = writeBoxRoomSequence("exporter_bad_seq");
  const std::string out = obm::test::scratchDir("exporter_bad_out");
  auto o = baseOptions(seq, seq + "/poses.txt", out + "/map.bt");
  o.png = out + "/top.png";

  auto missing = o;
  missing.input = seq + "_nope";
  expectFailsWritingNothing<obm::IoError>(missing, seq + "_nope");

  // Two poses for three scans.
  const auto lines = obm::io::readKittiTrajectory(seq + "/poses.txt");
  obm::io::writeKittiTrajectory(out + "/short.txt", {lines[0], lines[1]});
  auto short_traj = o;
  short_traj.trajectory = out + "/short.txt";
  expectFailsWritingNothing<obm::FormatError>(short_traj, "short.txt");

  // An unreadable second line.
  {
    std::ofstream f(out + "/broken.txt");
    f << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.5 0 1 0 x 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n";
  }
  auto broken = o;
  broken.trajectory = out + "/broken.txt";
  expectFailsWritingNothing<obm::FormatError>(broken, "broken.txt:2");

  auto no_traj = o;
  no_traj.trajectory = out + "/absent.txt";
  expectFailsWritingNothing<obm::IoError>(no_traj, "absent.txt");

  // A TUM trajectory whose stamps match no scan.
  obm::io::writeTumTrajectory(out + "/late.txt",
                              obm::io::stampPoses(lidarPoses(), {100.0, 100.1, 100.2}));
  auto late = o;
  late.trajectory = out + "/late.txt";
  expectFailsWritingNothing<obm::FormatError>(late, "late.txt");

  // ... which a time offset repairs.
  auto shifted = late;
  shifted.time_offset = -100.0;
  shifted.output = out + "/shifted.bt";
  shifted.png.clear();
  EXPECT_EQ(OctomapExporter(shifted).run().frames_integrated, 3u);
  fs::remove(out + "/shifted.bt");

  auto wrong_format = o;
  wrong_format.format = TrajectoryFormat::Tum;
  expectFailsWritingNothing<obm::FormatError>(wrong_format, "poses.txt");

  auto no_folder = o;
  no_folder.png = out + "/missing_dir/top.png";
  expectFailsWritingNothing<obm::IoError>(no_folder, "missing_dir");

  auto bad_ext = o;
  bad_ext.output = out + "/map.ply";
  EXPECT_THROW(OctomapExporter{bad_ext}, obm::ConfigError);
}

TEST(OctomapExporter, CancelWritesWhatWasIntegrated) {
  const std::string seq = writeBoxRoomSequence("exporter_cancel_seq");
  const std::string out = obm::test::scratchDir("exporter_cancel_out");
  std::atomic<bool> cancel{true};
  auto o = baseOptions(seq, seq + "/poses.txt", out + "/map.bt");
  o.cancel = &cancel;
  const auto sum = OctomapExporter(o).run();
  EXPECT_TRUE(sum.interrupted);
  EXPECT_EQ(sum.frames_integrated, 0u);
  octomap::OcTree tree(0.1);
  EXPECT_TRUE(tree.readBinary(out + "/map.bt"));  // a valid (empty) map, written atomically
  EXPECT_EQ(tree.getNumLeafNodes(), 0u);
}

TEST(OctomapExporter, RealKittiSampleAtIdentity) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample");
  const std::string real = obm::test::sharedDataDir() + "/kitti/hdl64_sample";
  // A KITTI layout around the real scans: symlinks (never copies), identity Tr and poses.
  const std::string seq = obm::test::scratchDir("exporter_real_seq");
  fs::create_directories(seq + "/velodyne");
  std::vector<double> times;
  for (int k = 0; k < 6; ++k) {
    const std::string name = obm::io::kittiScanFileName(k);
    fs::create_symlink(fs::absolute(real + "/" + name), seq + "/velodyne/" + name);
    times.push_back(0.1 * k);
  }
  obm::io::writeKittiCalib(seq + "/calib.txt", obm::io::KittiCalib{});
  obm::io::writeKittiTimes(seq + "/times.txt", times);
  obm::io::writeKittiTrajectory(seq + "/identity.txt",
                                std::vector<Isometry3d>(6, Isometry3d::Identity()));

  const std::string out = obm::test::scratchDir("exporter_real_out");
  auto o = baseOptions(seq, seq + "/identity.txt", out + "/map.bt");
  o.png = out + "/top.png";
  o.every = 2;  // scans 0, 2, 4: enough for the checks, and quick under the sanitizers
  const auto sum = OctomapExporter(o).run();
  EXPECT_EQ(sum.frames, 6u);
  EXPECT_EQ(sum.frames_integrated, 3u);
  EXPECT_GT(sum.points, 3u * 100000u);
  const auto& s = sum.stats;
  EXPECT_GT(s.num_occupied_leaves, 1000u);
  EXPECT_GT(s.free_volume_m3, s.occupied_volume_m3);
  // Bounded by the beams' reach: max_range around the sensor.
  const double reach = o.mapping.max_range + 2 * o.mapping.resolution;
  EXPECT_TRUE((s.bbox_min.array() >= -reach).all()) << s.bbox_min.transpose();
  EXPECT_TRUE((s.bbox_max.array() <= reach).all()) << s.bbox_max.transpose();
  // The ground below a car-mounted HDL-64 (about 1.7 m down) is occupied near the car.
  EXPECT_LT(s.occupied_min.z(), -1.2);
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(out + "/map.bt"));
  EXPECT_EQ(tree.getNumLeafNodes(), s.num_leaves);
  EXPECT_TRUE(fs::is_regular_file(out + "/top.png"));
  // The sensor sits in free space (beams start there).
  EXPECT_EQ(OccupancyMap::read(out + "/map.bt").state({2.0, 0.0, 0.0}), CellState::Free);
}

}  // namespace

namespace {

TEST(OctomapExporter, TumRgbdFolderWithColour) {
  // Two frames of a red wall 2 m in front of the camera (optical z), TUM layout and depth scale.
  const std::string seq = obm::test::scratchDir("exporter_rgbd_seq");
  fs::create_directories(seq + "/depth");
  fs::create_directories(seq + "/rgb");
  const obm::io::PinholeIntrinsics K;  // TUM's ROS default, 640 x 480
  obm::io::DepthImage depth;
  depth.width = K.width;
  depth.height = K.height;
  depth.data.assign(static_cast<std::size_t>(K.width) * K.height, 2 * 5000);  // 2 m
  obm::io::ColorImage rgb;
  rgb.width = K.width;
  rgb.height = K.height;
  for (int i = 0; i < K.width * K.height; ++i) rgb.rgb.insert(rgb.rgb.end(), {200, 20, 30});
  std::vector<obm::io::StampedFile> depths, colours;
  obm::io::Trajectory traj;
  for (int k = 0; k < 2; ++k) {
    const double t = 1305031102.0 + 0.1 * k;
    const std::string name = std::to_string(k) + ".png";
    obm::io::writeDepthPng(seq + "/depth/" + name, depth);
    obm::io::writeColorPng(seq + "/rgb/" + name, rgb);
    depths.push_back({t, "depth/" + name});
    colours.push_back({t + 0.005, "rgb/" + name});
    obm::io::StampedPose p;
    p.t = t + 0.001;
    p.T.translation() = Eigen::Vector3d(0.1 * k, 0.0, 0.0);
    traj.push_back(p);
  }
  obm::io::writeTumFileList(seq + "/depth.txt", depths);
  obm::io::writeTumFileList(seq + "/rgb.txt", colours);
  const std::string out = obm::test::scratchDir("exporter_rgbd_out");
  obm::io::writeTumTrajectory(out + "/camera_tum.txt", traj);

  auto o = baseOptions(seq, out + "/camera_tum.txt", out + "/wall.ot");
  o.mapping.resolution = 0.05;
  o.color = true;
  o.png = out + "/wall.png";
  o.top_view.use_voxel_color = true;
  const auto sum = OctomapExporter(o).run();
  EXPECT_EQ(sum.input_kind, "tum-rgbd");
  EXPECT_EQ(sum.frames_integrated, 2u);
  EXPECT_TRUE(sum.color);
  const OccupancyMap map = OccupancyMap::read(out + "/wall.ot");
  EXPECT_EQ(map.kind(), obm::mapping::MapKind::Color);
  const Eigen::Vector3d p_wall(0.02, 0.02, 2.0 + 0.025 / 2);  // optical frame = world here
  EXPECT_EQ(map.state(p_wall), CellState::Occupied);
  EXPECT_EQ(map.state({0.02, 0.02, 1.0}), CellState::Free);
  EXPECT_EQ(map.state({0.02, 0.02, 2.5}), CellState::Unknown);
  obm::Color3u8 c;
  ASSERT_TRUE(map.color(p_wall, c));
  EXPECT_NEAR(c[0], 200, 2);
  EXPECT_NEAR(c[1], 20, 2);
  // The top view (looking down world z = along the optical axis) shows the wall's colour.
  const auto img = obm::io::readColorPng(out + "/wall.png");
  const int col = static_cast<int>((0.02 - sum.top_view.x_min) / sum.top_view.pixel_size);
  const int row = static_cast<int>((sum.top_view.y_max - 0.02) / sum.top_view.pixel_size);
  EXPECT_EQ(img.at(col, row), obm::Color3u8(200, 20, 30));
}

TEST(OctomapExporter, RawlogWithTumVehiclePoses) {
  const std::string dir = obm::test::scratchDir("exporter_rawlog");
  const auto poses = lidarPoses();
  obm::io::Trajectory traj;
  {
    obm::io::RawlogWriter w(dir + "/room.rawlog");
    for (std::size_t k = 0; k < poses.size(); ++k) {
      const double t = 1600000000.0 + 0.1 * static_cast<double>(k);
      w.writePointCloud(obm::test::boxRoomScan(kRoomLo, kRoomHi, poses[k], 360, -60.0, 60.0, 1.0),
                        Isometry3d::Identity(), t, "LIDAR");
      traj.push_back({t, poses[k]});
    }
    w.close();
  }
  obm::io::writeTumTrajectory(dir + "/vehicle_tum.txt", traj);
  const auto sum =
      OctomapExporter(baseOptions(dir + "/room.rawlog", dir + "/vehicle_tum.txt", dir + "/m.bt"))
          .run();
  EXPECT_EQ(sum.input_kind, "rawlog");
  EXPECT_EQ(sum.frames, 3u);
  EXPECT_EQ(sum.frames_integrated, 3u);
  expectBoxRoom(OccupancyMap::read(dir + "/m.bt"));
}

}  // namespace
