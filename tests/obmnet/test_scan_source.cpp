// LiDAR scan pairs of obm-train / obm-bench (libs/datasets, scan_source): RIENet's KITTI (i, i+gap)
// protocol on the 6 real HDL-64 sweeps of the shared data, laid out as a KITTI odometry folder
// (velodyne/ linked in place, calib and the first poses / times of sequence 00 beside them).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "obm/datasets/scan_source.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/io/kitti.hpp"
#include "test_data.hpp"

using namespace obm;
namespace fs = std::filesystem;

namespace {

void copyFirstLines(const std::string& from, const std::string& to, int n) {
  std::ifstream in(from);
  std::ofstream out(to);
  std::string line;
  for (int i = 0; i < n && std::getline(in, line); ++i) out << line << "\n";
}

/// DIR/seq/{velodyne/*.bin → the shared sweeps, calib.txt, times.txt, poses.txt (if `poses`)}.
std::string makeSequence(const std::string& dir, const std::string& name, bool poses) {
  const std::string data = test::sharedDataDir() + "/kitti";
  const fs::path seq = fs::path(dir) / name;
  fs::create_directories(seq / "velodyne");
  for (int i = 0; i < 6; ++i) {
    const std::string f = "00000" + std::to_string(i) + ".bin";
    fs::create_symlink(fs::absolute(data + "/hdl64_sample/" + f), seq / "velodyne" / f);
  }
  fs::copy_file(data + "/calib/00.txt", seq / "calib.txt");
  copyFirstLines(data + "/times/00.txt", (seq / "times.txt").string(), 6);
  if (poses) copyFirstLines(data + "/poses/00.txt", (seq / "poses.txt").string(), 6);
  return seq.string();
}

datasets::ScanSourceConfig config(const std::string& dir) {
  return datasets::ScanSourceConfig::load(ConfigNode::fromString(
      "source: kitti\ndir: " + dir +
          "\nsequences: [train]\nval_sequences: [val]\nframe_gap: 2\nvoxel: 0.3\n"
          "min_range: 2.0\nmax_range: 40.0\n",
      "scan.yaml"));
}

}  // namespace

TEST(ScanSource, ValidationPairsAreEvenlySpacedWithTheLidarGroundTruth) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000005.bin");
  const std::string dir = test::scratchDir("scan_source_val");
  makeSequence(dir, "train", false);
  const std::string val = makeSequence(dir, "val", true);
  const auto cfg = config(dir);
  const auto pairs = datasets::scanValidationPairs(cfg, 512, 4, 7);
  ASSERT_EQ(pairs.size(), 4u);
  const io::KittiSequence seq(val);
  ASSERT_TRUE(seq.hasGroundTruth());
  const auto& gt = seq.groundTruthLidar();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    // 6 sweeps, gap 2: i = 0, 1, 2, 3 spread evenly; source = i + 2, target = i.
    const std::size_t i = k, j = k + 2;
    EXPECT_EQ(pairs[k].name, "val:" + std::to_string(j) + "->" + std::to_string(i));
    const Isometry3d expected = gt[i].inverse() * gt[j];
    EXPECT_LT((pairs[k].T_target_source.matrix() - expected.matrix()).norm(), 1e-9);
    for (const auto* c : {&pairs[k].source, &pairs[k].target}) {
      EXPECT_EQ(c->size(), 512u);
      for (std::size_t p = 0; p < c->size(); ++p) {
        const double r = c->points[p].norm();
        ASSERT_TRUE(r >= 2.0 - 1e-4 && r <= 40.0 + 1e-4) << "range crop: " << r;
      }
    }
  }
  // Fixed seed: the same pairs again.
  const auto again = datasets::scanValidationPairs(cfg, 512, 4, 7);
  for (std::size_t k = 0; k < pairs.size(); ++k)
    EXPECT_EQ(again[k].source.points, pairs[k].source.points);
}

TEST(ScanSource, CurriculumStartsWithSelfPairsAndEndsWithRealPairs) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000005.bin");
  const std::string dir = test::scratchDir("scan_source_sampler");
  makeSequence(dir, "train", false);
  makeSequence(dir, "val", true);
  auto sampler = datasets::scanPairSampler(config(dir), 256, 4);
  std::mt19937_64 rng(3);
  for (int n = 0; n < 3; ++n) {
    // Epoch 1: every pair is one sampled sweep and a made-up motion of it, so the motion maps the
    // source exactly onto the target.
    const auto p = sampler(rng, 1);
    EXPECT_NE(p.name.find("(self)"), std::string::npos) << p.name;
    EXPECT_DOUBLE_EQ(p.overlap, 1.0);
    const PointCloud moved = p.source.transformed(p.T_target_source, p.target.frame_id);
    for (std::size_t k = 0; k < moved.size(); ++k)
      ASSERT_LT((moved.points[k] - p.target.points[k]).norm(), 1e-4f);
  }
  // Past the curriculum: real (i + 2 → i) pairs of the training sequence.
  for (int n = 0; n < 3; ++n) {
    const auto p = sampler(rng, 5);
    EXPECT_EQ(p.name.find("(self)"), std::string::npos) << p.name;
    EXPECT_EQ(p.name.rfind("train:", 0), 0u) << p.name;
  }
}

TEST(ScanSource, ErrorsNameTheFolderOrTheKey) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000005.bin");
  const std::string dir = test::scratchDir("scan_source_errors");
  makeSequence(dir, "train", false);
  makeSequence(dir, "val", false);  // no poses.txt: validation cannot be scored
  try {
    datasets::scanValidationPairs(config(dir), 256, 2, 1);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("without ground truth"), std::string::npos) << e.what();
  }
  auto missing = config(dir);
  missing.val_sequences = {"nowhere"};
  try {
    datasets::scanValidationPairs(missing, 256, 2, 1);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("nowhere"), std::string::npos) << e.what();
  }
  auto long_gap = config(dir);
  long_gap.frame_gap = 6;
  EXPECT_THROW(datasets::scanPairSampler(long_gap, 256), FormatError);
  try {
    datasets::ScanSourceConfig::load(
        ConfigNode::fromString("source: kitti\nsequences: [a]\nframe_gapp: 3\n", "scan.yaml"));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("scan.yaml: frame_gapp"), std::string::npos) << e.what();
  }
}

TEST(ScanSource, PairClassesParseAndNameTheirGap) {
  EXPECT_EQ(datasets::ScanPairClass::parse("k5").gap, 5);
  EXPECT_EQ(datasets::ScanPairClass::parse("20").gap, 20);
  EXPECT_TRUE(datasets::ScanPairClass::parse("loop").loop);
  EXPECT_EQ(datasets::ScanPairClass::parse("loop").label(), "loop");
  EXPECT_EQ(datasets::ScanPairClass::parse("k10").label(), "k10");
  for (const char* bad : {"k", "k0", "x5", "5x", "loopy", ""})
    EXPECT_THROW(datasets::ScanPairClass::parse(bad), ConfigError) << bad;
}

TEST(ScanSource, LoopPairsAreRevisitsWithTheirYaw) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000005.bin");
  const std::string dir = test::scratchDir("scan_source_loops");
  const std::string seq = makeSequence(dir, "loop", false);
  // Camera poses (x right, y down, z forward): 1 m forward per sweep for sweeps 0–4, then sweep 5
  // back at sweep 0's place, turned by 180° about the vertical (camera y).
  {
    std::ofstream poses(seq + "/poses.txt");
    for (int i = 0; i < 5; ++i) poses << "1 0 0 0 0 1 0 0 0 0 1 " << i << "\n";
    poses << "-1 0 0 0 0 1 0 0 0 0 -1 0\n";
  }
  auto cfg = datasets::ScanSourceConfig::load(ConfigNode::fromString(
      "source: kitti\ndir: " + dir +
          "\nsequences: [loop]\nval_sequences: [loop]\nframe_gap: 2\nvoxel: 0.3\nmin_range: 2.0\n"
          "max_range: 40.0\nloop_max_distance: 2.0\nloop_min_separation: 3\nloop_fraction: 1.0\n",
      "scan.yaml"));
  // Revisits ≥ 3 sweeps apart within 2 m: (0, 5), (1, 5), (2, 5); none of (0, 3), (0, 4), (1, 4).
  const auto pairs = datasets::scanPairs(cfg, {"loop"}, datasets::ScanPairClass::parse("loop"), 256, 10, 1);
  ASSERT_EQ(pairs.size(), 3u);
  const io::KittiSequence s(seq);
  const auto& gt = s.groundTruthLidar();
  for (const auto& p : pairs) {
    EXPECT_NE(p.name.find("(loop, yaw 180°)"), std::string::npos) << p.name;
    EXPECT_EQ(p.name.rfind("loop:5->", 0), 0u) << p.name;
    const std::size_t i = std::stoul(p.name.substr(8));
    EXPECT_LE(i, 2u);
    EXPECT_LT((p.T_target_source.matrix() - (gt[i].inverse() * gt[5]).matrix()).norm(), 1e-9);
  }
  // The training sampler draws only loops at loop_fraction 1, either sweep as the source, and
  // turns the source by the yaw augmentation (recorded in the pose it reports).
  cfg.yaw_augment_deg = 30.0;
  auto sampler = datasets::scanPairSampler(cfg, 128);
  std::mt19937_64 rng(4);
  for (int n = 0; n < 6; ++n) {
    const auto p = sampler(rng, 1);
    const bool forward = p.name.rfind("loop:5->", 0) == 0;
    const bool backward = p.name.find("->5") != std::string::npos;
    EXPECT_TRUE(forward || backward) << p.name;
  }
  // A sequence with no revisit cannot train loops.
  auto none = cfg;
  none.loop_min_separation = 5;
  EXPECT_NO_THROW(datasets::scanPairSampler(none, 128));  // (0, 5) is still a revisit
  none.loop_min_separation = 6;
  EXPECT_THROW(datasets::scanPairSampler(none, 128), ConfigError);
}

TEST(ScanSource, PoseLabelsComeFromTheMappingTrajectoryNeverFromGroundTruth) {
  OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000005.bin");
  const std::string dir = test::scratchDir("scan_source_labels");
  const std::string train = makeSequence(dir, "train", true);
  makeSequence(dir, "val", true);
  auto cfg = config(dir);
  cfg.pose_labels = "slam_poses.txt";
  // Missing labels: the error names the file.
  try {
    datasets::scanPairSampler(cfg, 256);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("slam_poses.txt"), std::string::npos) << e.what();
  }
  // Labels that differ from poses.txt: a trajectory standing still (every pose the identity).
  {
    std::ofstream out(fs::path(train) / "slam_poses.txt");
    for (int i = 0; i < 6; ++i) out << "1 0 0 0 0 1 0 0 0 0 1 0\n";
  }
  const auto sampler = datasets::scanPairSampler(cfg, 256);
  std::mt19937_64 rng(3);
  for (int k = 0; k < 5; ++k) {
    const auto p = sampler(rng, 1);
    ASSERT_TRUE(p.has_pose_label) << p.name;
    // (KITTI's Tr is orthonormal to ~1e-7 only: the camera-to-LiDAR conjugation keeps that.)
    EXPECT_LT((p.T_target_source_label.matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-5)
        << p.name << "\n" << p.T_target_source_label.matrix();
  }
  // Headings of every kind (augmented by up to 180°) come out within ±45° of a hypothesis of
  // inference, with the label turned along: the residual heading of the label is within ±45°.
  {
    auto turned = cfg;
    turned.yaw_augment_deg = 180.0;
    turned.label_yaw_hypotheses = 4;
    const auto s4 = datasets::scanPairSampler(turned, 256);
    double largest = 0.0;
    for (int k = 0; k < 40; ++k) {
      const auto p = s4(rng, 1);
      const auto& L = p.T_target_source_label.linear();
      const double yaw = std::abs(std::atan2(L(1, 0), L(0, 0))) * 180.0 / 3.14159265358979323846;
      largest = std::max(largest, yaw);
      // The label still maps the (turned) source onto the target: the clouds moved together.
      EXPECT_TRUE(p.T_target_source_label.isApprox(p.T_target_source, 1e-12));
    }
    EXPECT_LE(largest, 45.0 + 1e-6);
    EXPECT_GT(largest, 5.0) << "the augmentation should still leave residual headings";
  }
  // Validation pairs are scored on ground truth and carry no label.
  for (const auto& p : datasets::scanValidationPairs(cfg, 256, 2, 1)) {
    EXPECT_FALSE(p.has_pose_label) << p.name;
    EXPECT_GT(p.T_target_source.translation().norm(), 0.5) << p.name;  // the car moves
  }
  // Without pose_labels, no pair is labelled (poses.txt only chooses and scores).
  const auto plain = datasets::scanPairSampler(config(dir), 256);
  EXPECT_FALSE(plain(rng, 1).has_pose_label);
  auto bad = ConfigNode::fromString("source: kitti\nsequences: [a]\npose_labels: x/y.txt\n", "s.yaml");
  EXPECT_THROW(datasets::ScanSourceConfig::load(bad), ConfigError);
}
