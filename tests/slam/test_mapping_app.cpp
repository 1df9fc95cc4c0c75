// The mapping app (what obm-map runs) end to end on short sequences simulated here with libs/sim:
// a KITTI-layout LiDAR folder, the same sequence as an MRPT rawlog, and a TUM-layout RGB-D folder.
// Every output exists and parses (map.bt loads with OctoMap, graph.g2o with the back-end), the
// metrics are finite and small, and bad input is an error or a counted skip.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "obm/backend/graph_io.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "obm/sim/simulator.hpp"
#include "obm/slam/mapping_app.hpp"
#include "test_data.hpp"

namespace obm::slam {
namespace {

namespace fs = std::filesystem;

// A small city and a fast straight drive (20 m/s at 10 Hz: 2 m between sweeps, ~120 m in 60
// sweeps, so the KITTI metric has 100 m segments), a 64-ring LiDAR with 0.8° columns.
const char* kLidarYaml = R"(
name: slam_test_drive
seed: 5
frames: 60
scene:
  type: urban_grid
  blocks_x: 2
  blocks_y: 1
  block_length_x: 75.0
  block_length_y: 60.0
  margin: 10.0
  terrain_resolution: 1.5
sensor:
  type: lidar
  layout: hdl64
  azimuth_step_deg: 0.8
  max_range: 100.0
trajectory:
  type: drive
  route: [[0, 0], [2, 0]]
  speed: 20.0
  turn_speed: 8.0
output:
  format: kitti
)";

// A hand-held camera walking through a small office floor (320×240 depth at 30 Hz).
const char* kRgbdYaml = R"(
name: slam_test_walk
seed: 4
frames: 45
scene:
  type: indoor_floor
  rooms_per_side: 1
  mesh_dir: ""
sensor:
  type: rgbd
  width: 320
  height: 240
  fx: 262.5
  fy: 262.5
  cx: 159.5
  cy: 119.5
trajectory:
  type: walk
output:
  format: tum
)";

std::string simulate(const char* yaml, const std::string& name) {
  // ctest runs every test in its own process, possibly in parallel: each one simulates into a
  // folder of its own, or one process would delete the sequence another is reading.
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string dir =
      test::scratchDir("slam_" + name + "_" + (info ? info->name() : "shared")) + "/seq";
  sim::SequenceSimulator s(sim::SimConfig::load(ConfigNode::fromString(yaml, name)));
  sim::SimOptions o;
  o.out_dir = dir;
  o.progress = false;
  s.run(o);
  return dir;
}

const std::string& lidarSequence() {
  static const std::string dir = simulate(kLidarYaml, "lidar");
  return dir;
}

SlamConfig kittiConfig() {
  return SlamConfig::loadFile(obm::test::sourceDir() + "/config/map_kitti.yaml");
}

nlohmann::json readJson(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  return nlohmann::json::parse(in);
}

std::size_t countLines(const std::string& path) {
  std::ifstream in(path);
  std::size_t n = 0;
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') ++n;
  return n;
}

double num(const nlohmann::json& j, const char* key) {
  EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_TRUE(j.at(key).is_number()) << key << " = " << j.at(key).dump();
  return j.at(key).is_number() ? j.at(key).get<double>() : NAN;
}

TEST(MappingApp, KittiFolderEndToEndWritesEveryOutput) {
  const std::string seq = lidarSequence();
  const std::string out = test::scratchDir("slam_kitti_out");
  MappingAppOptions o;
  o.input = seq;
  o.ground_truth = seq + "/poses.txt";
  o.out_dir = out;
  o.progress = false;
  MappingApp app(kittiConfig(), o);
  const RunSummary s = app.run();
  EXPECT_EQ(s.input_kind, "kitti");
  EXPECT_EQ(s.frames, 60u);
  EXPECT_EQ(s.frames_total, 60u);
  EXPECT_FALSE(s.interrupted);
  EXPECT_EQ(s.stats.bridged, 0u);
  ASSERT_TRUE(s.metrics.has_value());

  for (const char* f : {"trajectory_tum.txt", "trajectory_kitti.txt", "keyframes_tum.txt",
                        "graph.g2o", "map.bt", "map.ot", "metrics.json", "timing.json",
                        "frames.csv", "loops.csv", "trajectory_topview.png", "map_topview.png"})
    EXPECT_TRUE(fs::is_regular_file(out + "/" + f)) << f;

  // metrics.json: the keys the acceptance checks read, finite and small.
  const nlohmann::json m = readJson(out + "/metrics.json");
  EXPECT_LT(num(m, "t_err_percent"), 0.5);
  EXPECT_LT(num(m, "r_err_deg_per_100m"), 0.5);
  EXPECT_LT(num(m, "ate_rmse_m"), 0.1);
  EXPECT_GE(num(m, "rpe_trans_rmse_m"), 0.0);
  EXPECT_GE(num(m, "kitti_segments"), 1.0);
  ASSERT_TRUE(m.contains("loops_accepted"));
  EXPECT_TRUE(m.at("loops_accepted").is_number_integer());
  EXPECT_EQ(m.at("evaluation_frame"), "camera0");
  EXPECT_EQ(m.at("loops_checked"), m.at("loops_accepted"));
  EXPECT_EQ(m.at("loops_wrong"), 0);

  // timing.json.
  const nlohmann::json t = readJson(out + "/timing.json");
  EXPECT_EQ(num(t, "frames"), 60.0);
  EXPECT_GT(num(t, "wall_s"), 0.0);
  EXPECT_NEAR(num(t, "frames_per_second"), 60.0 / num(t, "wall_s"), 1e-6);
  for (const char* stage : {"obmnet", "icp", "graph", "octomap"})
    EXPECT_TRUE(t.at("stages_ms").contains(stage)) << stage;
  EXPECT_GT(t.at("stages_ms").at("icp").get<double>(), 0.0);
  EXPECT_GT(t.at("stages_ms").at("octomap").get<double>(), 0.0);

  // trajectory_kitti.txt: camera-0 poses like poses.txt (first = I), one per frame.
  const auto est = io::readKittiTrajectory(out + "/trajectory_kitti.txt");
  const auto gt = io::readKittiTrajectory(seq + "/poses.txt");
  ASSERT_EQ(est.size(), 60u);
  EXPECT_TRUE(est.front().isApprox(Isometry3d::Identity(), 1e-9));
  for (std::size_t i = 0; i < est.size(); ++i)
    EXPECT_LT((est[i].translation() - gt[i].translation()).norm(), 0.2) << "frame " << i;
  // trajectory_tum.txt: the LiDAR poses with times.txt's stamps.
  const auto tum = io::readTumTrajectory(out + "/trajectory_tum.txt");
  const auto times = io::readKittiTimes(seq + "/times.txt");
  ASSERT_EQ(tum.size(), 60u);
  for (std::size_t i = 0; i < tum.size(); ++i) EXPECT_NEAR(tum[i].t, times[i], 1e-9);
  const io::KittiCalib calib = io::readKittiCalib(seq + "/calib.txt");
  EXPECT_TRUE(io::lidarToCameraPose(tum[30].T, calib.T_cam0_velo).isApprox(est[30], 1e-6));

  // map.bt loads with OctoMap itself.
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(out + "/map.bt"));
  EXPECT_DOUBLE_EQ(tree.getResolution(), kittiConfig().mapping.resolution);
  EXPECT_GT(tree.getNumLeafNodes(), 1000u);
  // graph.g2o loads with the back-end: one node per keyframe, the keyframe chain plus loops.
  const backend::PoseGraph g = backend::readG2o(out + "/graph.g2o");
  EXPECT_EQ(g.numNodes(), s.stats.keyframes);
  EXPECT_EQ(g.numEdges(), s.stats.keyframes - 1 + s.stats.loops_accepted);
  EXPECT_EQ(countLines(out + "/keyframes_tum.txt"), s.stats.keyframes);
  EXPECT_EQ(countLines(out + "/frames.csv"), 60u);
  // The pictures are PNGs.
  EXPECT_GT(io::readColorPng(out + "/trajectory_topview.png").width, 100);
  EXPECT_GT(io::readColorPng(out + "/map_topview.png").width, 100);
}

// A loop edge is scored against the ground truth's relative pose of its keyframes' frames: exact
// and centimetre-off edges are correct, one 1 m or 3° off is wrong, frames without ground truth
// and rejected candidates are not scored.
TEST(MappingAppLoops, ScoredAgainstTheGroundTruthsRelativePose) {
  auto pose = [](double x, double y, double yaw_deg) {
    Isometry3d T = Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
    T.translation() = Eigen::Vector3d(x, y, 0.0);
    return T;
  };
  std::vector<std::optional<Isometry3d>> gt = {pose(0, 0, 0), pose(10, 0, 5), pose(20, 3, 170),
                                                std::nullopt, pose(1, 2, 180)};
  const std::vector<std::size_t> keyframe_frames = {0, 1, 2, 3, 4};  // keyframe k at frame k
  auto loop = [&](std::size_t from, std::size_t to, const Isometry3d& error, bool accepted) {
    frontend::LoopClosure lc;
    lc.from = from;
    lc.to = to;
    lc.accepted = accepted;
    lc.T_from_to = gt[from]->inverse() * *gt[to] * error;
    return lc;
  };
  TrajectoryMetrics m;
  scoreLoops({loop(0, 4, Isometry3d::Identity(), true), loop(1, 4, pose(0.02, 0, 0.1), true)},
             keyframe_frames, gt, m);
  EXPECT_EQ(m.loops_checked, 2u);
  EXPECT_EQ(m.loops_wrong, 0u);
  EXPECT_NEAR(m.loop_error_max_m, 0.02, 1e-9);
  EXPECT_NEAR(m.loop_error_max_deg, 0.1, 1e-9);

  frontend::LoopClosure no_truth = loop(0, 4, Isometry3d::Identity(), true);
  no_truth.to = 3;  // frame 3 has no ground-truth pose
  scoreLoops({loop(0, 4, pose(1.0, 0, 0), true), loop(2, 4, pose(0, 0, 3.0), true),
              loop(1, 2, pose(5.0, 0, 0), false), no_truth},
             keyframe_frames, gt, m);
  EXPECT_EQ(m.loops_checked, 2u);
  EXPECT_EQ(m.loops_wrong, 2u);
  EXPECT_NEAR(m.loop_error_max_m, 1.0, 1e-9);
  EXPECT_NEAR(m.loop_error_max_deg, 3.0, 1e-9);

  scoreLoops({}, keyframe_frames, gt, m);
  EXPECT_EQ(m.loops_checked, 0u);
  EXPECT_TRUE(std::isnan(m.loop_error_max_m));
}

// The ledger of the matcher's results per call site: which started from the network's pose,
// which were taken, and which of the taken were off the truth (the wrong-loop bounds): for loops
// the loop's relative pose, for recovered frames the motion from the frame before.
TEST(MappingAppLedger, CountsTheNetworksPosesPerCallSiteAndJudgesTheTakenOnes) {
  using registration::MatchStart;
  auto pose = [](double x, double yaw_deg) {
    Isometry3d T = Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).matrix();
    T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
    return T;
  };
  const std::vector<std::optional<Isometry3d>> gt = {pose(0, 0), pose(1, 10), pose(2, 20),
                                                      std::nullopt, pose(4, 40)};
  const std::vector<std::size_t> keyframe_frames = {0, 2, 4};  // keyframe k at frame 2k
  auto loop = [&](std::size_t from, std::size_t to, const Isometry3d& error, bool accepted,
                  MatchStart start) {
    frontend::LoopClosure lc;
    lc.from = from;
    lc.to = to;
    lc.accepted = accepted;
    lc.start = start;
    lc.T_from_to = gt[keyframe_frames[from]]->inverse() * *gt[keyframe_frames[to]] * error;
    return lc;
  };
  const std::vector<frontend::LoopClosure> loops = {
      loop(0, 2, Isometry3d::Identity(), true, MatchStart::Guess),   // right
      loop(0, 1, pose(0.0, 3.0), true, MatchStart::Network),         // 3 deg off: wrong
      loop(1, 2, Isometry3d::Identity(), true, MatchStart::Hypothesis),  // right
      loop(0, 2, pose(2.0, 0.0), false, MatchStart::Network),        // rejected: not judged
  };
  // Frames 1 and 4 recovered: frame 1 from the network with the true motion, frame 4 (its
  // previous frame has no truth) not checked; frame 2 tracked.
  using S = frontend::TrackingStatus;
  const std::vector<S> statuses = {S::Initial, S::Recovered, S::Tracked, S::Tracked, S::Recovered};
  const std::vector<MatchStart> starts = {MatchStart::Guess, MatchStart::Network, MatchStart::Guess,
                                          MatchStart::Guess, MatchStart::Guess};
  std::vector<Isometry3d> traj;
  for (std::size_t i = 0; i < gt.size(); ++i) traj.push_back(gt[i] ? *gt[i] : pose(3, 30));
  const MatcherLedger l = matcherLedger(loops, keyframe_frames, statuses, starts, traj, gt);
  EXPECT_EQ(l.loop_verification.results, 4u);
  EXPECT_EQ(l.loop_verification.network, 3u);
  EXPECT_EQ(l.loop_verification.taken, 3u);
  EXPECT_EQ(l.loop_verification.taken_network, 2u);
  EXPECT_EQ(l.loop_verification.checked, 3u);
  EXPECT_EQ(l.loop_verification.wrong, 1u);
  EXPECT_EQ(l.loop_verification.wrong_network, 1u);
  EXPECT_EQ(l.recovery.taken, 2u);
  EXPECT_EQ(l.recovery.taken_network, 1u);
  EXPECT_EQ(l.recovery.checked, 1u);
  EXPECT_EQ(l.recovery.wrong, 0u);

  // A recovered frame whose motion is 1 m off the truth's is wrong.
  traj[1] = traj[1] * pose(1.0, 0.0);
  EXPECT_EQ(matcherLedger({}, keyframe_frames, statuses, starts, traj, gt).recovery.wrong, 1u);
  // Without ground truth nothing is checked; the counts stay.
  const MatcherLedger none = matcherLedger(loops, keyframe_frames, statuses, starts, traj, {});
  EXPECT_EQ(none.loop_verification.taken_network, 2u);
  EXPECT_EQ(none.loop_verification.checked, 0u);
  EXPECT_EQ(none.recovery.checked, 0u);
}

TEST(MappingApp, RawlogOfTheSameDriveWithItsGroundTruth) {
  const std::string seq = lidarSequence();
  const std::string out = test::scratchDir("slam_rawlog_out");
  SlamConfig cfg = kittiConfig();
  cfg.output.map = false;
  MappingAppOptions o;
  o.input = seq + "/sequence.rawlog";  // groundtruth.txt next to it is found
  o.out_dir = out;
  o.progress = false;
  const RunSummary s = MappingApp(cfg, o).run();
  EXPECT_EQ(s.input_kind, "rawlog");
  EXPECT_EQ(s.frames, 60u);
  ASSERT_TRUE(s.metrics.has_value());
  EXPECT_EQ(s.metrics->frames_evaluated, 60u);
  EXPECT_LT(s.metrics->ate_rmse_m, 0.1);
  EXPECT_FALSE(fs::exists(out + "/map.bt"));
  EXPECT_EQ(countLines(out + "/trajectory_tum.txt"), 60u);
}

TEST(MappingApp, RgbdFolderWithTheIndoorConfiguration) {
  const std::string seq = simulate(kRgbdYaml, "rgbd");
  const std::string out = test::scratchDir("slam_rgbd_out");
  SlamConfig cfg = SlamConfig::loadFile(obm::test::sourceDir() + "/config/map_indoor.yaml");
  MappingAppOptions o;
  o.input = seq;
  o.out_dir = out;
  o.progress = false;
  const RunSummary s = MappingApp(cfg, o).run();
  EXPECT_EQ(s.input_kind, "tum-rgbd");
  EXPECT_EQ(s.frames, 45u);
  ASSERT_TRUE(s.metrics.has_value());
  EXPECT_EQ(s.metrics->frame, "sensor");
  EXPECT_LT(s.metrics->ate_rmse_m, 0.04);  // a 320×240 camera with Kinect-like depth quantisation
  EXPECT_TRUE(fs::is_regular_file(out + "/map.bt"));
}

TEST(MappingApp, CancelWritesWhatWasProcessed) {
  const std::string seq = lidarSequence();
  const std::string out = test::scratchDir("slam_cancel_out");
  std::atomic<bool> cancel{false};
  MappingAppOptions o;
  o.input = seq;
  o.out_dir = out;
  o.progress = false;
  o.cancel = &cancel;
  SlamConfig cfg = kittiConfig();
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    cancel = true;
  });
  const RunSummary s = MappingApp(cfg, o).run();
  stopper.join();
  if (!s.interrupted) GTEST_SKIP() << "the run finished before the cancel flag was set";
  EXPECT_LT(s.frames, 60u);
  EXPECT_EQ(countLines(out + "/trajectory_tum.txt"), s.frames);
  EXPECT_EQ(countLines(out + "/trajectory_kitti.txt"), s.frames);
  const nlohmann::json m = readJson(out + "/metrics.json");
  EXPECT_EQ(m.at("interrupted"), true);
  EXPECT_EQ(m.at("frames").get<std::size_t>(), s.frames);
  const nlohmann::json t = readJson(out + "/timing.json");
  EXPECT_EQ(t.at("frames").get<std::size_t>(), s.frames);
}

TEST(MappingAppBadInput, MissingInputUnwritableOutputAndBadConfigAreClearErrors) {
  const std::string dir = test::scratchDir("slam_bad");
  MappingAppOptions o;
  o.input = dir + "/no_such_sequence";
  o.out_dir = dir + "/out";
  o.progress = false;
  try {
    MappingApp(kittiConfig(), o).run();
    ADD_FAILURE() << "missing input";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_sequence"), std::string::npos) << e.what();
  }
  // An output "folder" that is a file.
  std::ofstream(dir + "/a_file") << "x";
  o.input = lidarSequence();
  o.out_dir = dir + "/a_file";
  EXPECT_THROW(MappingApp(kittiConfig(), o).run(), IoError);
  // A misspelt key names file and key.
  std::ofstream(dir + "/bad.yaml") << "tracking:\n  max_corection: 2.0\n";
  try {
    SlamConfig::loadFile(dir + "/bad.yaml");
    ADD_FAILURE() << "unknown key";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("tracking.max_corection"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/bad2.yaml") << "mapping:\n  resolution: -1\n";
  EXPECT_THROW(SlamConfig::loadFile(dir + "/bad2.yaml"), ConfigError);
  std::ofstream(dir + "/bad3.yaml") << "outputs:\n  map: false\n";
  EXPECT_THROW(SlamConfig::loadFile(dir + "/bad3.yaml"), ConfigError);
  // A ground-truth file that does not exist.
  o.out_dir = dir + "/out";
  o.ground_truth = dir + "/none.txt";
  EXPECT_THROW(MappingApp(kittiConfig(), o).run(), IoError);
}

TEST(MappingAppBadInput, CorruptAndNanScansAreCountedSkipsNotErrors) {
  // A copy of the first 20 sweeps with scan 7 truncated (not a multiple of 16 bytes) and scan 8
  // all NaN.
  const std::string src = lidarSequence();
  const std::string seq = test::scratchDir("slam_corrupt") + "/seq";
  fs::create_directories(seq + "/velodyne");
  const auto times = io::readKittiTimes(src + "/times.txt");
  const auto poses = io::readKittiTrajectory(src + "/poses.txt");
  const std::size_t n = 20;
  for (std::size_t i = 0; i < n; ++i)
    fs::copy_file(src + "/velodyne/" + io::kittiScanFileName(i),
                  seq + "/velodyne/" + io::kittiScanFileName(i));
  fs::copy_file(src + "/calib.txt", seq + "/calib.txt");
  io::writeKittiTimes(seq + "/times.txt", std::vector<double>(times.begin(), times.begin() + n));
  io::writeKittiTrajectory(seq + "/poses.txt",
                           std::vector<Isometry3d>(poses.begin(), poses.begin() + n));
  fs::resize_file(seq + "/velodyne/" + io::kittiScanFileName(7), 7);
  PointCloud nan = io::readKittiVelodyne(seq + "/velodyne/" + io::kittiScanFileName(8));
  for (auto& p : nan.points) p = Vector3f::Constant(NAN);
  {
    std::ofstream f(seq + "/velodyne/" + io::kittiScanFileName(8), std::ios::binary);
    for (const auto& p : nan.points) {
      const float rec[4] = {p.x(), p.y(), p.z(), 0.f};
      f.write(reinterpret_cast<const char*>(rec), sizeof(rec));
    }
  }
  const std::string out = test::scratchDir("slam_corrupt_out");
  MappingAppOptions o;
  o.input = seq;
  o.out_dir = out;
  o.progress = false;
  const RunSummary s = MappingApp(kittiConfig(), o).run();
  EXPECT_EQ(s.frames, n);
  EXPECT_EQ(s.stats.bridged, 2u);
  EXPECT_EQ(s.stats.empty_sweeps, 2u);
  const nlohmann::json m = readJson(out + "/metrics.json");
  EXPECT_EQ(m.at("read_errors").get<int>(), 1);
  EXPECT_EQ(m.at("frames_bridged").get<int>(), 2);
  EXPECT_LT(num(m, "ate_rmse_m"), 0.2);  // poses.txt next to velodyne/ is found
  EXPECT_EQ(countLines(out + "/trajectory_kitti.txt"), n);
}

}  // namespace
}  // namespace obm::slam
