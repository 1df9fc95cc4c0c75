// Indoor fragments for obm-train / obm-bench (apps/common/fragment_source): RIENet's 7Scenes
// normalisation on real RGB-D frames (Open3D's test frames in the shared data).
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "../../apps/common/fragment_source.hpp"
#include "../../apps/common/object_source.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "test_data.hpp"

using namespace obm;

namespace {

apps::RgbdFragmentOptions open3dOptions() {
  apps::RgbdFragmentOptions o;
  o.layout = "redwood";
  o.train_sequences = {test::sharedDataDir() + "/rgbd_open3d"};
  o.frame_step = 1;
  o.test_frame_step = 1;
  return o;
}

}  // namespace

TEST(RgbdFragments, RealFramesAreCentredScaledAndSampled) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  const auto set = apps::loadRgbdFragments("", open3dOptions(), 2048, 0);
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
  const auto again = apps::loadRgbdFragments("", open3dOptions(), 2048, 0);
  EXPECT_EQ(again.train[2].points, set.train[2].points);
  const auto other = apps::loadRgbdFragments("", open3dOptions(), 2048, 1);
  EXPECT_NE(other.train[2].points, set.train[2].points);
}

TEST(RgbdFragments, FusedFramesUseTheGroundTruthAndTooSmallFragmentsAreSkipped) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  auto o = open3dOptions();
  o.fragment_frames = 3;  // frames 0-2, 1-3, 2-4 fused with trajectory.log
  o.voxel = 0.02;
  const auto fused = apps::loadRgbdFragments("", o, 2048, 0);
  EXPECT_EQ(fused.train.size(), 3u);
  // A coarse grid leaves fewer points than asked for: every fragment is skipped, and an empty
  // training split is an error naming the folder.
  o.voxel = 0.5;
  EXPECT_THROW(apps::loadRgbdFragments("", o, 2048, 0), IoError);
}

TEST(RgbdFragments, ConfigErrorsNameTheKeyAndTheVariable) {
  const auto bad_layout = ConfigNode::fromString("layout: kinect\ntrain_sequences: [a]\n", "frag.yaml");
  try {
    apps::RgbdFragmentOptions::load(bad_layout);
    FAIL() << "unknown layout accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("layout"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frag.yaml"), std::string::npos) << e.what();
  }
  const auto no_train = ConfigNode::fromString("layout: tum\n", "frag.yaml");
  EXPECT_THROW(apps::RgbdFragmentOptions::load(no_train), ConfigError);

  ::unsetenv("OBM_TEST_UNSET_VARIABLE");
  auto o = open3dOptions();
  o.train_sequences = {"$OBM_TEST_UNSET_VARIABLE/rgbd_open3d"};
  try {
    apps::loadRgbdFragments("", o, 2048, 0);
    FAIL() << "unset variable accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("OBM_TEST_UNSET_VARIABLE"), std::string::npos)
        << e.what();
  }
  o.train_sequences = {"/nonexistent/seq"};
  EXPECT_THROW(apps::loadRgbdFragments("", o, 2048, 0), IoError);
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
  const auto set = apps::loadObjectSet(apps::ObjectSourceConfig::load(node));
  EXPECT_EQ(set.train.size(), 3u);  // frames 0, 2, 4
  EXPECT_EQ(set.test.size(), 5u);
  EXPECT_EQ(set.test.front().size(), 1024u);
}
