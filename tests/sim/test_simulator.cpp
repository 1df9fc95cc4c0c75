// End-to-end runs of the sequence simulator on small scenes: dataset layouts, ground-truth
// consistency, rawlog round trips, determinism, and every kind of bad input failing clearly
// without leaving anything behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unordered_map>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "obm/sim/simulator.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::sim;
namespace fs = std::filesystem;

namespace {

// A small city, a dense custom LiDAR, three sweeps.
const char* kUrbanYaml = R"(
name: test_urban
seed: 3
frames: 3
scene:
  type: urban_grid
  blocks_x: 1
  blocks_y: 1
  block_length_x: 60.0
  block_length_y: 60.0
  building_depth_max: 12.0
  margin: 5.0
  terrain_resolution: 1.5
  car_probability: 0.8
sensor:
  type: lidar
  layout: uniform
  rings: 96
  max_elevation_deg: 12.0
  min_elevation_deg: -25.0
  azimuth_step_deg: 0.3
  noise: false
output:
  format: kitti
trajectory:
  type: drive
)";

const char* kIndoorYaml = R"(
name: test_indoor
seed: 4
frames: 3
scene:
  type: indoor_floor
  rooms_per_side: 1
  mesh_dir: ""
sensor:
  type: rgbd
  width: 160
  height: 120
  fx: 131.25
  fy: 131.25
  cx: 79.5
  cy: 59.5
trajectory:
  type: walk
)";

std::string writeConfig(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p) << text;
  return p;
}

SimOptions quiet(const std::string& out) {
  SimOptions o;
  o.out_dir = out;
  o.progress = false;
  return o;
}

std::size_t countEntries(const std::string& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) (void)e, ++n;
  return n;
}

// Entries of `dir` whose name starts with `prefix` (the output or a temporary beside it).
std::size_t countStartingWith(const std::string& dir, const std::string& prefix) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(prefix, 0) == 0) ++n;
  return n;
}

std::vector<std::string> readLines(const std::string& path) {
  std::ifstream is(path);
  std::vector<std::string> lines;
  std::string l;
  while (std::getline(is, l))
    if (!l.empty() && l[0] != '#') lines.push_back(l);
  return lines;
}

// Nearest-neighbour distances to a fixed reference cloud (voxel hash of 0.2 m cells, exact up to
// 0.2 m; farther neighbours are reported as 0.2 m).
class NnGrid {
 public:
  explicit NnGrid(const std::vector<Eigen::Vector3d>& ref) : ref_(ref) {
    for (std::size_t i = 0; i < ref.size(); ++i) grid_[key(cellOf(ref[i]))].push_back(i);
  }
  std::vector<double> distances(const std::vector<Eigen::Vector3d>& query) const {
    std::vector<double> out;
    out.reserve(query.size());
    for (const auto& q : query) {
      const Eigen::Vector3i c = cellOf(q);
      double best = kCell;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const auto it = grid_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
            if (it == grid_.end()) continue;
            for (std::size_t i : it->second) best = std::min(best, (ref_[i] - q).norm());
          }
      out.push_back(best);
    }
    return out;
  }

 private:
  static constexpr double kCell = 0.2;
  static Eigen::Vector3i cellOf(const Eigen::Vector3d& p) {
    return (p / kCell).array().floor().cast<int>();
  }
  static long long key(const Eigen::Vector3i& c) {
    return (static_cast<long long>(c.x()) * 73856093) ^ (static_cast<long long>(c.y()) * 19349663) ^
           (static_cast<long long>(c.z()) * 83492791);
  }
  std::vector<Eigen::Vector3d> ref_;
  std::unordered_map<long long, std::vector<std::size_t>> grid_;
};

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1))];
}

std::vector<Eigen::Vector3d> near(const PointCloud& c, double r) {
  std::vector<Eigen::Vector3d> out;
  for (const auto& p : c.points)
    if (p.norm() < r) out.push_back(p.cast<double>());
  return out;
}

}  // namespace

TEST(Simulator, KittiLayoutIsCompleteAndItsGroundTruthAlignsConsecutiveSweeps) {
  const std::string dir = test::scratchDir("sim_kitti");
  const SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "urban.yaml", kUrbanYaml));
  SequenceSimulator sim(cfg);
  const SimSummary sum = sim.run(quiet(dir + "/out"));
  const std::string out = dir + "/out";
  ASSERT_EQ(sum.frames, 3u);
  for (const char* f : {"poses.txt", "times.txt", "calib.txt", "groundtruth.txt", "sequence.rawlog",
                        "preview_topview.png", "preview_frame.png", "sim_info.yaml",
                        "velodyne/000000.bin", "velodyne/000002.bin"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  EXPECT_FALSE(fs::exists(out + "/velodyne/000003.bin"));
  EXPECT_EQ(readLines(out + "/poses.txt").size(), 3u);
  EXPECT_EQ(readLines(out + "/times.txt").size(), 3u);
  // Nothing but the output folder in the parent: no temporary left behind.
  EXPECT_EQ(countEntries(dir), 2u);

  // Read it back as a KITTI sequence: camera-frame poses + Tr → LiDAR poses.
  const io::KittiSequence seq(out);
  ASSERT_EQ(seq.size(), 3u);
  ASSERT_TRUE(seq.hasGroundTruth());
  EXPECT_TRUE(seq.groundTruthCamera().front().isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  EXPECT_NEAR(seq.timestamp(1) - seq.timestamp(0), 0.1, 1e-9);
  // The LiDAR ground truth equals the simulator's relative poses.
  const auto& traj = sim.trajectory();
  for (std::size_t k = 0; k < 3; ++k) {
    const Eigen::Isometry3d expect = traj.poses[0].inverse() * traj.poses[k];
    EXPECT_TRUE(seq.groundTruthLidar()[k].isApprox(expect, 1e-6)) << "frame " << k;
  }
  // Noise-free sweeps mapped with the true relative pose coincide: the nearest-neighbour
  // residual is at the sampling density, and every small perturbation of the pose (10 cm along
  // an axis, 0.5° about one) makes it worse — the ground truth is the best alignment.
  const PointCloud a = seq.scan(0), b = seq.scan(1);
  const Eigen::Isometry3d T_ab = seq.groundTruthLidar()[0].inverse() * seq.groundTruthLidar()[1];
  ASSERT_GT(T_ab.translation().norm(), 0.5);  // the car moved
  const auto A = near(a, 15.0), Bs = near(b, 15.0);
  ASSERT_GT(A.size(), 10000u);
  const NnGrid grid(A);
  auto residual = [&](const Eigen::Isometry3d& T, double* median) {
    std::vector<Eigen::Vector3d> B;
    const std::size_t step = std::max<std::size_t>(1, Bs.size() / 4000);  // ~4000 queries
    for (std::size_t i = 0; i < Bs.size(); i += step) B.push_back(T * Bs[i]);
    const auto d = grid.distances(B);
    if (median) *median = quantile(d, 0.5);
    double m = 0;
    for (double x : d) m += x;
    return m / static_cast<double>(d.size());
  };
  double med = 0;
  const double best = residual(T_ab, &med);
  EXPECT_LT(med, 0.05) << "median NN residual with the true pose (ring spacing ~0.1 m at 15 m)";
  for (int axis = 0; axis < 3; ++axis)
    for (double sgn : {-1.0, 1.0}) {
      const Eigen::Isometry3d dt(Eigen::Translation3d(0.1 * sgn * Eigen::Vector3d::Unit(axis)));
      const Eigen::Isometry3d dr(
          Eigen::AngleAxisd(0.5 * kDegToRad * sgn, Eigen::Vector3d::Unit(axis)));
      EXPECT_LT(best, residual(T_ab * dt, nullptr)) << "translation axis " << axis << " " << sgn;
      EXPECT_LT(best, residual(T_ab * dr, nullptr)) << "rotation axis " << axis << " " << sgn;
    }
}

TEST(Simulator, RawlogRoundTripGivesTheSamePointsAsTheBinFiles) {
  const std::string dir = test::scratchDir("sim_rawlog");
  SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "urban.yaml", kUrbanYaml));
  cfg.frames = 2;
  cfg.sensor.lidar.noise = true;  // with intensities and noise
  cfg.output.pictures = false;
  SequenceSimulator(cfg).run(quiet(dir + "/out"));
  const auto obs = io::readRawlog(dir + "/out/sequence.rawlog");
  ASSERT_EQ(obs.size(), 2u);
  const auto times = io::readKittiTimes(dir + "/out/times.txt");
  for (std::size_t k = 0; k < 2; ++k) {
    const PointCloud bin = io::readKittiVelodyne(dir + "/out/velodyne/" + io::kittiScanFileName(k));
    const auto& o = obs[k];
    EXPECT_EQ(o.class_name, "CObservationPointCloud");
    EXPECT_EQ(o.sensor_label, "VELODYNE");
    EXPECT_TRUE(o.T_vehicle_sensor.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_NEAR(o.timestamp - obs[0].timestamp, times[k] - times[0], 1e-4);
    ASSERT_EQ(o.cloud.size(), bin.size());
    ASSERT_TRUE(o.cloud.hasIntensity());
    for (std::size_t i = 0; i < bin.size(); ++i) {
      ASSERT_LT((o.cloud.points[i] - bin.points[i]).norm(), 1e-5f)
          << "frame " << k << " point " << i;
      ASSERT_NEAR(o.cloud.intensity[i], bin.intensity[i], 1e-6f);
    }
  }
}

TEST(Simulator, SameSeedSameOutputDifferentSeedDifferentOutput) {
  const std::string dir = test::scratchDir("sim_determinism");
  SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "urban.yaml", kUrbanYaml));
  cfg.frames = 1;
  cfg.sensor.lidar.noise = true;
  cfg.output.rawlog = false;
  cfg.output.pictures = false;
  auto bytes = [](const std::string& p) {
    std::ifstream is(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(is), {});
  };
  SequenceSimulator(cfg).run(quiet(dir + "/a"));
  cfg.threads = 1;
  cfg.applySeed();
  SequenceSimulator(cfg).run(quiet(dir + "/b"));
  cfg.seed = 4;
  cfg.applySeed();
  SequenceSimulator(cfg).run(quiet(dir + "/c"));
  const std::string a = bytes(dir + "/a/velodyne/000000.bin");
  ASSERT_GT(a.size(), 16u * 10000u);
  EXPECT_EQ(a, bytes(dir + "/b/velodyne/000000.bin"));  // also across thread counts
  EXPECT_NE(a, bytes(dir + "/c/velodyne/000000.bin"));
  EXPECT_EQ(bytes(dir + "/a/poses.txt"), bytes(dir + "/b/poses.txt"));
}

TEST(Simulator, TumLayoutDepthPngsAndRawlogRangeImagesAgree) {
  const std::string dir = test::scratchDir("sim_tum");
  const SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "indoor.yaml", kIndoorYaml));
  SequenceSimulator sim(cfg);
  sim.run(quiet(dir + "/out"));
  const std::string out = dir + "/out";
  for (const char* f : {"depth.txt", "rgb.txt", "groundtruth.txt", "poses.txt", "times.txt",
                        "camera_intrinsic.json", "sequence.rawlog", "preview_frame.png"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;
  const auto seq = io::RgbdSequence::openTum(out);
  ASSERT_EQ(seq.size(), 3u);
  EXPECT_DOUBLE_EQ(seq.depthScale(), 5000.0);
  const auto gt = io::readTumTrajectory(out + "/groundtruth.txt");
  ASSERT_EQ(gt.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    ASSERT_TRUE(seq.frame(k).has_pose);
    EXPECT_TRUE(seq.frame(k).T_world_camera.isApprox(sim.trajectory().poses[k], 1e-6));
  }
  const auto obs = io::readRawlog(out + "/sequence.rawlog");
  ASSERT_EQ(obs.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const io::DepthImage png = seq.depth(k);
    ASSERT_TRUE(obs[k].has_depth);
    EXPECT_EQ(obs[k].class_name, "CObservation3DRangeScan");
    EXPECT_EQ(obs[k].intrinsics.width, 160);
    EXPECT_DOUBLE_EQ(obs[k].intrinsics.fx, 131.25);
    ASSERT_EQ(obs[k].depth.width, png.width);
    ASSERT_EQ(obs[k].depth.height, png.height);
    std::size_t valid = 0, agree = 0;
    for (int v = 0; v < png.height; ++v)
      for (int u = 0; u < png.width; ++u) {
        const double zp = png.at(u, v) / 5000.0, zr = obs[k].depth.at(u, v) / obs[k].depth_scale;
        if (png.at(u, v) == 0) continue;
        ++valid;
        if (std::fabs(zp - zr) < 1.5e-3) ++agree;
      }
    EXPECT_GT(valid, 160u * 120u / 2);  // indoors most pixels have depth
    EXPECT_EQ(agree, valid) << "frame " << k;
  }
}

TEST(SimulatorBadInput, UnknownPresetNamesItAndTheFoldersSearched) {
  try {
    findPreset("no_such_preset");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no_such_preset"), std::string::npos) << m;
    EXPECT_NE(m.find("searched"), std::string::npos) << m;
    EXPECT_NE(m.find("kitti_like_urban"), std::string::npos) << m;  // lists what exists
  }
}

TEST(SimulatorBadInput, EveryPresetLoadsAndTheSelfContainedOnesNeedNoExternalData) {
  for (const char* name : {"kitti_like_urban", "kitti00_gt", "kitti00_gt_loop", "indoor_tum_fr1_xyz",
                           "indoor_tum_fr2_desk", "indoor_loop", "urban_vlp16", "urban_block_loop"}) {
    const std::string path = findPreset(name);
    std::ifstream is(path);
    const std::string text((std::istreambuf_iterator<char>(is)), {});
    const bool external = text.find("${") != std::string::npos;
    if (std::string(name) == "kitti_like_urban" || std::string(name) == "indoor_loop" ||
        std::string(name) == "urban_vlp16") {
      EXPECT_FALSE(external) << name;
    }
    if (external && !fs::exists(test::sharedDataDir())) continue;
    EXPECT_NO_THROW(SimConfig::loadFile(path)) << name;
  }
  const SimConfig k = SimConfig::loadFile(findPreset("kitti_like_urban"));
  EXPECT_EQ(k.sensor.lidar.layout, "hdl64");
  EXPECT_EQ(k.output.format, "kitti");
  EXPECT_EQ(SimConfig::loadFile(findPreset("indoor_loop")).output.format, "tum");
}

TEST(SimulatorBadInput, UnreadableMeshOrPoseFileIsNamedAndNothingIsWritten) {
  const std::string dir = test::scratchDir("sim_bad_files");
  const std::string out = dir + "/out";
  auto expectFailure = [&](const std::string& yaml, const std::string& needle) {
    try {
      const SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "bad.yaml", yaml));
      SequenceSimulator(cfg).run(quiet(out));
      ADD_FAILURE() << "expected an error mentioning " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
    EXPECT_EQ(countStartingWith(dir, "out"), 0u);  // no output, no temporary folder
  };
  const std::string mesh_scene = R"(
scene: {type: mesh, file: MESH}
sensor: {type: lidar, layout: vlp16, azimuth_step_deg: 2.0}
trajectory: {type: tum, file: POSES}
)";
  auto with = [&](std::string s, const std::string& mesh, const std::string& poses) {
    s.replace(s.find("MESH"), 4, mesh);
    s.replace(s.find("POSES"), 5, poses);
    return s;
  };
  const std::string poses = dir + "/poses.tum";
  std::ofstream(poses) << "0.0 0 0 1 0 0 0 1\n0.1 0.1 0 1 0 0 0 1\n";
  const std::string garbage = dir + "/garbage.off";
  std::ofstream(garbage) << "OFF\n3 1 0\n0 0 0\n1 0 0\n";  // truncated
  const std::string missing = dir + "/does_not_exist.ply";
  expectFailure(with(mesh_scene, missing, poses), "does_not_exist.ply");
  expectFailure(with(mesh_scene, garbage, poses), "garbage.off");
  std::ofstream(dir + "/room.off")
      << "OFF\n4 2 0\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n3 0 1 2\n3 0 2 3\n";
  std::ofstream(dir + "/bad_poses.tum") << "0.0 0 0 1 0 0 0 1\n0.1 0 0 oops 0 0 0 1\n";
  expectFailure(with(mesh_scene, dir + "/room.off", dir + "/bad_poses.tum"), "bad_poses.tum");
  expectFailure(with(mesh_scene, dir + "/room.off", dir + "/nope.tum"), "nope.tum");
}

TEST(SimulatorBadInput, TrajectoryLeavingTheSceneIsRejectedBeforeWriting) {
  const std::string dir = test::scratchDir("sim_leaves");
  std::ofstream(dir + "/room.off")
      << "OFF\n4 2 0\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\n3 0 1 2\n3 0 2 3\n";
  // Starts inside the 10 m square, then walks out of it at pose 2.
  std::ofstream(dir + "/walk.tum") << "0.0 0 0 0 0 0 0 1\n0.1 3 0 0 0 0 0 1\n0.2 7 0 0 0 0 0 1\n";
  const std::string yaml = "scene: {type: mesh, file: " + dir + "/room.off}\n" +
                           "sensor: {type: lidar, layout: vlp16}\n" +
                           "trajectory: {type: tum, file: " + dir + "/walk.tum}\n";
  const SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "c.yaml", yaml));
  try {
    SequenceSimulator(cfg).run(quiet(dir + "/out"));
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("walk.tum"), std::string::npos) << m;
    EXPECT_NE(m.find("leaves the scene at pose"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

TEST(SimulatorBadInput, ZeroRaysUnknownKeysAndMismatchedSectionsNameTheKey) {
  const std::string dir = test::scratchDir("sim_bad_keys");
  auto expectKey = [&](const std::string& yaml, const std::string& key) {
    try {
      SimConfig::loadFile(writeConfig(dir, "k.yaml", yaml));
      ADD_FAILURE() << "expected ConfigError naming " << key;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("k.yaml"), std::string::npos) << e.what();
    }
  };
  const std::string scene = "scene: {type: urban_grid}\ntrajectory: {type: drive}\n";
  expectKey(scene + "sensor: {type: lidar, layout: custom, elevations_deg: []}\n",
            "sensor.elevations_deg");
  expectKey(scene + "sensor: {type: lidar, azimuth_step_deg: 0}\n", "sensor.azimuth_step_deg");
  expectKey(scene + "sensor: {type: lidar, rnage: 3}\n", "sensor.rnage");
  expectKey(scene + "sensor: {type: sonar}\n", "sensor.type");
  expectKey(
      "scene: {type: urban_grid}\ntrajectory: {type: drive}\nsensor: {type: rgbd, width: 0}\n",
      "sensor.width");
  expectKey("scene: {type: indoor_floor}\ntrajectory: {type: drive}\nsensor: {type: lidar}\n",
            "trajectory.type");
  expectKey(scene + "sensor: {type: lidar}\noutput: {format: tum}\n", "output.format");
}

TEST(SimulatorBadInput, ExistingOutputIsKeptAndCancellingLeavesNothing) {
  const std::string dir = test::scratchDir("sim_existing");
  SimConfig cfg = SimConfig::loadFile(writeConfig(dir, "urban.yaml", kUrbanYaml));
  cfg.output.pictures = false;
  cfg.frames = 1;
  fs::create_directories(dir + "/out");
  std::ofstream(dir + "/out/keep.txt") << "mine";
  EXPECT_THROW(SequenceSimulator(cfg).run(quiet(dir + "/out")), IoError);
  EXPECT_TRUE(fs::exists(dir + "/out/keep.txt"));

  std::atomic<bool> cancel{true};
  SimOptions o = quiet(dir + "/new");
  o.cancel = &cancel;
  EXPECT_THROW(SequenceSimulator(cfg).run(o), Cancelled);
  EXPECT_FALSE(fs::exists(dir + "/new"));
  EXPECT_EQ(countEntries(dir), 2u);  // urban.yaml and out/

  // --overwrite replaces the folder as a whole.
  o.cancel = nullptr;
  o.out_dir = dir + "/out";
  o.overwrite = true;
  SequenceSimulator(cfg).run(o);
  EXPECT_FALSE(fs::exists(dir + "/out/keep.txt"));
  EXPECT_TRUE(fs::exists(dir + "/out/poses.txt"));
  EXPECT_EQ(countEntries(dir), 2u);
}
