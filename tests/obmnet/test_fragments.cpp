// Indoor fragments for obm-train / obm-bench (libs/datasets, fragment_source): RIENet's 7Scenes
// normalisation on real RGB-D frames (Open3D's test frames in the shared data).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <utility>

#include "obm/datasets/fragment_source.hpp"
#include "obm/datasets/object_source.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/redwood_log.hpp"
#include "test_data.hpp"

using namespace obm;

namespace {

datasets::RgbdFragmentOptions open3dOptions() {
  datasets::RgbdFragmentOptions o;
  o.layout = "redwood";
  o.train_sequences = {test::sharedDataDir() + "/rgbd_open3d"};
  o.frame_step = 1;
  o.test_frame_step = 1;
  return o;
}


/// A sequence folder whose images are the shared frames (linked, not copied), with a labels file
/// `labels.log` next to them: the shared trajectory with pose k moved by k · `step` in its own
/// frame, so a label differs from the ground-truth relative pose.
struct LabelledFrames {
  std::string dir;
  std::vector<Isometry3d> gt, labels;
};

LabelledFrames labelledFrames(const std::string& scratch, const Eigen::Vector3d& step) {
  namespace fs = std::filesystem;
  const std::string src = test::sharedDataDir() + "/rgbd_open3d";
  LabelledFrames f;
  f.dir = test::scratchDir(scratch) + "/seq";
  fs::remove_all(f.dir);
  fs::create_directories(f.dir);
  for (const char* name : {"depth", "color", "camera_primesense.json", "trajectory.log"})
    fs::create_symlink(fs::absolute(src + "/" + name), f.dir + "/" + name);
  f.gt = io::readRedwoodTrajectory(src + "/trajectory.log");
  for (std::size_t k = 0; k < f.gt.size(); ++k) {
    Isometry3d D = Isometry3d::Identity();
    D.translation() = static_cast<double>(k) * step;
    f.labels.push_back(f.gt[k] * D);
  }
  io::writeRedwoodTrajectory(f.dir + "/labels.log", f.labels);
  return f;
}

/// The frames (j, i) of a frame pair named "SEQUENCE:j->i".
std::pair<int, int> pairFrames(const std::string& name) {
  const auto arrow = name.find("->"), colon = name.find(':');
  return {std::stoi(name.substr(colon + 1, arrow - colon - 1)), std::stoi(name.substr(arrow + 2))};
}
}  // namespace

TEST(RgbdFragments, RealFramesAreCentredScaledAndSampled) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto set = datasets::loadRgbdFragments("", open3dOptions(), 2048, 0);
  ASSERT_EQ(set.train.size(), 5u);  // the 5 frames, one fragment each
  EXPECT_TRUE(set.val.empty());
  EXPECT_TRUE(set.test.empty());
  for (const auto& f : set.train) {
    ASSERT_EQ(f.size(), 2048u) << f.frame_id;
    EXPECT_LT(f.centroid().norm(), 1e-5f) << f.frame_id;
    float r = 0.0f;
    for (const auto& p : f.points) r = std::max(r, p.norm());
    EXPECT_NEAR(r, 0.5f, 1e-5f) << f.frame_id;
  }
  EXPECT_EQ(set.train.front().frame_id, "rgbd_open3d:0");
  // The sample depends on the seed, not on the call.
  const auto again = datasets::loadRgbdFragments("", open3dOptions(), 2048, 0);
  EXPECT_EQ(again.train[2].points, set.train[2].points);
  const auto other = datasets::loadRgbdFragments("", open3dOptions(), 2048, 1);
  EXPECT_NE(other.train[2].points, set.train[2].points);
}

TEST(RgbdFragments, FusedFramesUseTheGroundTruthAndTooSmallFragmentsAreSkipped) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  auto o = open3dOptions();
  o.fragment_frames = 3;  // frames 0-2, 1-3, 2-4 fused with trajectory.log
  o.voxel = 0.02;
  const auto fused = datasets::loadRgbdFragments("", o, 2048, 0);
  EXPECT_EQ(fused.train.size(), 3u);
  // A coarse grid leaves fewer points than asked for: every fragment is skipped, and an empty
  // training split is an error naming the folder.
  o.voxel = 0.5;
  EXPECT_THROW(datasets::loadRgbdFragments("", o, 2048, 0), IoError);
}

TEST(RgbdFragments, ConfigErrorsNameTheKeyAndTheVariable) {
  const auto bad_layout = ConfigNode::fromString("layout: kinect\ntrain_sequences: [a]\n", "frag.yaml");
  try {
    datasets::RgbdFragmentOptions::load(bad_layout);
    FAIL() << "unknown layout accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("layout"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frag.yaml"), std::string::npos) << e.what();
  }
  const auto no_train = ConfigNode::fromString("layout: tum\n", "frag.yaml");
  EXPECT_THROW(datasets::RgbdFragmentOptions::load(no_train), ConfigError);

  ::unsetenv("OBM_TEST_UNSET_VARIABLE");
  auto o = open3dOptions();
  o.train_sequences = {"$OBM_TEST_UNSET_VARIABLE/rgbd_open3d"};
  try {
    datasets::loadRgbdFragments("", o, 2048, 0);
    FAIL() << "unset variable accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("OBM_TEST_UNSET_VARIABLE"), std::string::npos)
        << e.what();
  }
  o.train_sequences = {"/nonexistent/seq"};
  EXPECT_THROW(datasets::loadRgbdFragments("", o, 2048, 0), IoError);
}

TEST(RgbdFragments, LayoutPrefixAndEnvironmentVariableInTheObjectSource) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  ::setenv("OBM_TEST_RGBD_ROOT", test::sharedDataDir().c_str(), 1);
  const auto node = ConfigNode::fromString(
      "source: rgbd\n"
      "rgbd:\n"
      "  layout: tum\n"
      "  train_sequences: ['redwood:${OBM_TEST_RGBD_ROOT}/rgbd_open3d']\n"
      "  test_sequences: ['redwood:$OBM_TEST_RGBD_ROOT/rgbd_open3d']\n"
      "  frame_step: 2\n"
      "  test_frame_step: 1\n"
      "objects: {keep_points: 1024}\n",
      "data.yaml");
  const auto set = datasets::loadObjectSet(datasets::ObjectSourceConfig::load(node));
  EXPECT_EQ(set.train.size(), 3u);  // frames 0, 2, 4
  EXPECT_EQ(set.test.size(), 5u);
  EXPECT_EQ(set.test.front().size(), 1024u);
}

TEST(RgbdFramePairs, TrainingSamplerDrawsTwoDifferentFramesOfTheGapsAtTheirPose) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  auto o = open3dOptions();
  o.pair_gaps = {1, 3};
  const auto sampler = datasets::rgbdFramePairSampler("", o, 1500);
  // The ground-truth relative pose of every pair, from the trajectory, to compare with.
  const auto all = datasets::rgbdFramePairs("", o, o.train_sequences, 5, 5, 10, 0);  // every pair
  ASSERT_EQ(all.size(), 10u);
  std::mt19937_64 rng(3);
  for (int k = 0; k < 8; ++k) {
    const obmnet::RegistrationPair p = sampler(rng, 1);
    ASSERT_EQ(p.source.size(), 1500u);
    ASSERT_EQ(p.target.size(), 1500u);
    // name "rgbd_open3d:j->i", j - i in [1, 3]
    const auto [j, i] = pairFrames(p.name);
    EXPECT_GE(j - i, 1) << p.name;
    EXPECT_LE(j - i, 3) << p.name;
    EXPECT_EQ(p.source.frame_id, "camera_" + std::to_string(j));
    // Independent frames: no source point coincides with a target point.
    EXPECT_NE(p.source.points.front(), p.target.points.front());
    bool found = false;
    for (const auto& q : all)
      if (q.name == p.name) {
        found = true;
        EXPECT_TRUE(q.T_target_source.isApprox(p.T_target_source, 1e-9)) << p.name;
      }
    EXPECT_TRUE(found) << p.name;
  }
  // Validation pairs batch like the training ones: exactly N points per cloud, names kept.
  const auto val = datasets::withPointCount(all, 700, 1);
  for (const auto& p : val) {
    EXPECT_EQ(p.source.size(), 700u);
    EXPECT_EQ(p.target.size(), 700u);
  }
  EXPECT_EQ(val[3].name, all[3].name);
  o.pair_gaps = {3, 2};
  const auto node = ConfigNode::fromString("train_sequences: [a]\npair_gaps: [3, 2]\n", "d.yaml");
  EXPECT_THROW(datasets::RgbdFragmentOptions::load(node), ConfigError);
}

TEST(RgbdFramePairs, WithColoursTheGeometryIsTheSameAndEveryPointHasItsColour) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  auto o = open3dOptions();
  o.stride = 4;
  o.voxel = 0.02;
  const auto plain = datasets::rgbdFramePairs("", o, o.train_sequences, 1, 3, 4, 7);
  const auto coloured = datasets::rgbdFramePairs("", o, o.train_sequences, 1, 3, 4, 7, true);
  ASSERT_EQ(plain.size(), coloured.size());
  for (std::size_t k = 0; k < plain.size(); ++k) {
    const auto& a = plain[k];
    const auto& b = coloured[k];
    EXPECT_EQ(a.name, b.name);
    EXPECT_TRUE(a.T_target_source.isApprox(b.T_target_source, 1e-12)) << a.name;
    EXPECT_FALSE(a.source.hasColors()) << a.name;
    for (const auto* c : {&b.source, &b.target}) {
      ASSERT_EQ(c->colors.size(), c->points.size()) << b.name;
      // Real indoor colours: not one flat value.
      double lo = 255.0, hi = 0.0;
      for (const auto& rgb : c->colors) {
        lo = std::min(lo, static_cast<double>(rgb.x()));
        hi = std::max(hi, static_cast<double>(rgb.x()));
      }
      EXPECT_GT(hi - lo, 50.0) << b.name;
    }
    ASSERT_EQ(a.source.size(), b.source.size()) << a.name;
    for (std::size_t i = 0; i < a.source.size(); i += 97)
      EXPECT_EQ(a.source.points[i], b.source.points[i]) << a.name << " point " << i;
  }
}

TEST(RgbdFramePairs, PoseLabelsReplaceTheGroundTruthAndMarkThePairs) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto f = labelledFrames("rgbd_labels", Eigen::Vector3d(0.01, 0.0, 0.0));
  auto o = open3dOptions();
  o.train_sequences = {f.dir};
  o.pair_gaps = {1, 4};
  o.pose_labels = "labels.log";
  const auto sampler = datasets::rgbdFramePairSampler("", o, 500);
  std::mt19937_64 rng(5);
  for (int k = 0; k < 6; ++k) {
    const obmnet::RegistrationPair p = sampler(rng, 1);
    const auto [fj, fi] = pairFrames(p.name);
    const auto j = static_cast<std::size_t>(fj), i = static_cast<std::size_t>(fi);
    ASSERT_TRUE(p.has_pose_label) << p.name;
    const Isometry3d expected = f.labels[i].inverse() * f.labels[j];
    EXPECT_TRUE(p.T_target_source_label.isApprox(expected, 1e-6)) << p.name;
    EXPECT_FALSE(p.T_target_source_label.isApprox(f.gt[i].inverse() * f.gt[j], 1e-6)) << p.name;
  }
  // Without labels the pairs carry none; a missing labels file is an IoError naming it.
  o.pose_labels.clear();
  EXPECT_FALSE(datasets::rgbdFramePairSampler("", o, 500)(rng, 1).has_pose_label);
  o.pose_labels = "missing.log";
  try {
    datasets::rgbdFramePairSampler("", o, 500);
    FAIL() << "missing labels accepted";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.log"), std::string::npos) << e.what();
  }
  // Labels are a file name in each folder, and train frame pairs only.
  EXPECT_THROW(datasets::RgbdFragmentOptions::load(ConfigNode::fromString(
                   "train_sequences: [a]\npair_gaps: [1, 2]\npose_labels: a/b.txt\n", "d.yaml")),
               ConfigError);
  EXPECT_THROW(datasets::RgbdFragmentOptions::load(
                   ConfigNode::fromString("train_sequences: [a]\npose_labels: b.txt\n", "d.yaml")),
               ConfigError);
}

TEST(RgbdFramePairs, StartNearLabelPutsEachPairWithinItsOffsetOfTheLabel) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  // The shared frames with labels (as above): a pair that starts near its label is placed by the
  // label times an offset of at most the given size.
  const auto f = labelledFrames("rgbd_near_labels", Eigen::Vector3d(0.0, 0.02, 0.0));

  auto o = open3dOptions();
  o.train_sequences = {f.dir};
  o.pair_gaps = {1, 4};
  o.pose_labels = "labels.log";
  o.start_near_label = {10.0, 0.05};
  const auto sampler = datasets::rgbdFramePairSampler("", o, 500);
  std::mt19937_64 rng(7);
  double largest_turn = 0.0;
  for (int k = 0; k < 8; ++k) {
    const obmnet::RegistrationPair p = sampler(rng, 1);
    const auto [fj, fi] = pairFrames(p.name);
    const auto j = static_cast<std::size_t>(fj), i = static_cast<std::size_t>(fi);
    ASSERT_TRUE(p.has_pose_label) << p.name;
    // The label is now the offset Δ⁻¹ alone: within 10° and 5 cm of not moving.
    const double turn = rotationAngle(p.T_target_source_label.linear()) * 180.0 / M_PI;
    EXPECT_LE(turn, 10.0 + 1e-9) << p.name;
    EXPECT_LE(p.T_target_source_label.translation().norm(), 0.05 + 1e-9) << p.name;
    largest_turn = std::max(largest_turn, turn);
    // Opened on its labels, the pair's pose is the label (training never sees the truth), and it
    // moved with the source.
    EXPECT_TRUE(p.T_target_source.isApprox(p.T_target_source_label, 1e-9)) << p.name;
    EXPECT_LT(i, j) << p.name;
    EXPECT_EQ(p.source.frame_id, "camera_" + std::to_string(j) + "@start");
  }
  EXPECT_GT(largest_turn, 1.0) << "no pair was moved off its label";

  // The source points move with the pair: target ≈ T · source before and after.
  obmnet::RegistrationPair q;
  q.target.points = {{1.f, 0.f, 0.f}, {0.f, 2.f, 0.f}, {0.f, 0.f, 3.f}, {1.f, 1.f, 1.f}};
  Isometry3d T = Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.5, -1.0, 2.0);
  q.source = q.target.transformed(T.inverse(), "s");
  q.T_target_source = T;
  datasets::startNearPose(q, T, 20.0, 0.3, rng);
  EXPECT_LE(rotationAngle(q.T_target_source.linear()) * 180.0 / M_PI, 20.0 + 1e-9);
  EXPECT_LE(q.T_target_source.translation().norm(), 0.3 + 1e-9);
  for (std::size_t k = 0; k < q.target.size(); ++k)
    EXPECT_LT((q.T_target_source * q.source.points[k].cast<double>() -
               q.target.points[k].cast<double>())
                  .norm(),
              1e-5);

  // Refused: without labels to start near, a malformed range; each names the key.
  for (const char* yaml : {"train_sequences: [a]\npair_gaps: [1, 2]\nstart_near_label: [5, 0.1]\n",
                           "train_sequences: [a]\npair_gaps: [1, 2]\npose_labels: b.txt\n"
                           "start_near_label: [200, 0.1]\n",
                           "train_sequences: [a]\npair_gaps: [1, 2]\npose_labels: b.txt\n"
                           "start_near_label: [5]\n"}) {
    try {
      datasets::RgbdFragmentOptions::load(ConfigNode::fromString(yaml, "d.yaml"));
      FAIL() << "accepted: " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("start_near_label"), std::string::npos) << e.what();
    }
  }
}
