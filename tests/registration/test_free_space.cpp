// Free space (registration/free_space.hpp): what a sensor looked through, and the poses that put
// the other sweep's points there; the choice among refined poses of LiDAR sweeps on a street of
// repeated facades; the same test in a depth camera's frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/confidence.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/free_space.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"
#include "seed_five_drive.hpp"

namespace obm {
namespace {

using registration::FreeSpaceCheck;
using registration::FreeSpaceParams;
using registration::RangeImage;

/// A wall 10 m ahead of the sensor (x = 10, |y| ≤ 5, |z| ≤ 2), 5 cm samples.
std::vector<Vector3f> wallAhead() {
  std::vector<Vector3f> pts;
  for (float y = -5.f; y <= 5.f; y += 0.05f)
    for (float z = -2.f; z <= 2.f; z += 0.05f) pts.emplace_back(10.f, y, z);
  return pts;
}

TEST(FreeSpace, RangeImageKnowsWhatItLookedThrough) {
  const RangeImage image(wallAhead(), FreeSpaceParams());
  EXPECT_TRUE(image.inFreeSpace(Vector3f(5.f, 0.f, 0.f))) << "between the sensor and the wall";
  EXPECT_TRUE(image.inFreeSpace(Vector3f(8.f, 2.f, 1.f)));
  EXPECT_FALSE(image.inFreeSpace(Vector3f(10.1f, 0.f, 0.f))) << "on the wall";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(9.2f, 0.f, 0.f))) << "within the margin (0.5 + 10 %)";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(15.f, 0.f, 0.f))) << "behind the wall: not seen";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(-5.f, 0.f, 0.f))) << "behind the sensor: no return";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(0.f, 0.f, 5.f))) << "above: no return";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(0.5f, 0.f, 0.f))) << "nearer than min_range";
  // Points of another frame B, moved into the sensor's frame by T_sensor_B.
  const std::vector<Vector3f> b = {{0.f, 0.f, 0.f}, {20.f, 0.f, 0.f}};
  const Isometry3d T_sensor_B =
      makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(5.f, 0.f, 0.f));
  EXPECT_EQ(image.countConflicts(b, T_sensor_B), 1u) << "(5, 0, 0) is free, (25, 0, 0) unseen";
}

TEST(FreeSpace, ConflictsBothWays) {
  // Two sensors 4 m apart facing the same wall: at the right pose nothing conflicts; with the
  // source slid 3 m towards the wall, its wall lies in front of the target's, where the target
  // looked through.
  std::vector<Vector3f> target = wallAhead(), source;
  for (const auto& p : target) source.push_back(p - Vector3f(4.f, 0.f, 0.f));
  const FreeSpaceCheck check(source, target, FreeSpaceParams());
  const Isometry3d truth = makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(4, 0, 0));
  const Isometry3d slid = makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 0, 0));
  const auto right = check.conflicts(truth);
  const auto wrong = check.conflicts(slid);
  EXPECT_EQ(right.source_in_target + right.target_in_source, 0u);
  EXPECT_GT(wrong.source_in_target, source.size() / 2) << "the source's wall in front of the target's";
  EXPECT_EQ(wrong.num_source, source.size());
  EXPECT_GT(wrong.ratio(), 0.25);
  EXPECT_EQ(right.ratio(), 0.0);
}

TEST(FreeSpace, DepthCameraLooksAlongItsOpticalAxis) {
  // A depth camera's frame (x right, y down, z forward): a wall 3 m ahead, 1 cm samples over a
  // 60° × 45° field of view.
  std::vector<Vector3f> wall;
  for (float x = -1.7f; x <= 1.7f; x += 0.01f)
    for (float y = -1.2f; y <= 1.2f; y += 0.01f) wall.emplace_back(x, y, 3.f);
  const FreeSpaceParams camera = FreeSpaceParams::depthCamera();
  const RangeImage image(wall, camera);
  EXPECT_TRUE(image.inFreeSpace(Vector3f(0.f, 0.f, 1.5f))) << "on the optical axis, before it";
  EXPECT_TRUE(image.inFreeSpace(Vector3f(0.8f, -0.5f, 2.f))) << "up and right, before the wall";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(0.f, 0.f, 2.95f))) << "within the margin (5 cm + 5 %)";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(0.f, 0.f, 4.f))) << "behind the wall: not seen";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(0.f, 0.f, -1.f))) << "behind the camera";
  EXPECT_FALSE(image.inFreeSpace(Vector3f(3.f, 0.f, 0.5f))) << "out of the field of view";
  // Slid 1 m towards the wall, the source's wall lies where the target looked through.
  const FreeSpaceCheck check(wall, wall, camera);
  const Isometry3d slid = makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, -1));
  EXPECT_EQ(check.conflicts(Isometry3d::Identity()).ratio(), 0.0);
  const auto wrong = check.conflicts(slid);
  // Of the source's wall, now 2 m ahead, the part within the target's field of view
  // (±29° × ±22° of 3.4 m × 2.4 m at 2 m: about 45 %) conflicts; the target's wall, 4 m ahead
  // of the source, is behind what the source saw.
  EXPECT_GT(wrong.source_in_target, wrong.num_source * 4 / 10);
  EXPECT_EQ(wrong.target_in_source, 0u);
  try {
    FreeSpaceParams::load(ConfigNode::fromString("sensor: sonar\n", "fs.yaml"));
    FAIL() << "an unknown sensor was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sensor"), std::string::npos) << e.what();
  }
  EXPECT_EQ(FreeSpaceParams::load(ConfigNode::fromString("sensor: camera\n", "fs.yaml")).sensor,
            registration::FreeSpaceSensor::Camera);
}

TEST(FreeSpace, RejectsBadSettingsByName) {
  FreeSpaceParams p;
  p.azimuth_step_deg = 0.0;
  EXPECT_THROW(p.validate(), ConfigError);
  p = FreeSpaceParams();
  p.relative_margin = 1.0;
  EXPECT_THROW(p.validate(), ConfigError);
  try {
    FreeSpaceParams::load(ConfigNode::fromString("margin: -1\n", "fs.yaml"));
    FAIL() << "a negative margin was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("margin"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FreeSpaceParams::load(ConfigNode::fromString("margins: 1\n", "fs.yaml")),
               ConfigError)
      << "unknown key";
  const auto q = FreeSpaceParams::load(
      ConfigNode::fromString("azimuth_step_deg: 4\nrelative_margin: 0.2\n", "fs.yaml"));
  EXPECT_EQ(q.azimuth_step_deg, 4.0);
  EXPECT_EQ(q.relative_margin, 0.2);
}

/// The search of obm-bench's kitti protocol (±180°, ±20 m, 1 m cells): before the free space,
/// three translations per heading 0.3 m apart; with it, ten 5 m apart, so that the slides along
/// the street and the right place all reach the refinement.
registration::CorrelativeSearchParams streetSearch(bool free_space) {
  registration::CorrelativeSearchParams p;
  p.axis = "z";
  p.heading_range_deg = 180.0;
  p.heading_step_deg = 3.0;
  p.translation_range = 20.0;
  p.axial_range = 1.0;
  p.cell = 1.0;
  p.candidates = 8;
  p.seed = 1;
  if (free_space) {
    p.min_separation_m = 5.0;
    p.shifts_per_heading = 10;
  }
  return p;
}

TEST(FreeSpace, ChoosesTheRightPlaceAmongSlidesAlongARepeatedStreet) {
  // Sweeps 20 apart (about 20 m) of the benchmark drive (obm-sim urban_revisits, seed 5), as the
  // kitti protocol gives them: 1024 points of a 0.3 m voxel grid, 2–50 m. Blocks of the same
  // type repeat along its streets, so a pose slid by a block pairs as many points as the right
  // one (docs/benchmarks.md, "Free space"). ICP from each of the search's poses; the refined
  // poses compete on their inlier ratio, or on it times the free-space discount. The sweeps are
  // simulated here (no file).
  const test::SeedFiveDrive drive;
  const sim::Trajectory& traj = drive.traj();
  auto sweep = [&](std::size_t k) {
    PointCloud c = voxelDownsample(cropRange(drive.rawSweep(k, 700), 2.0, 50.0), 0.3);
    std::mt19937_64 rng(k);
    std::shuffle(c.points.begin(), c.points.end(), rng);
    PointCloud out;
    out.frame_id = c.frame_id;
    out.points.assign(c.points.begin(),
                      c.points.begin() + std::min<std::ptrdiff_t>(c.points.size(), 1024));
    return out;
  };
  // obm-bench's refinement of kitti pairs (--unit 20: a 2 m gate, Huber 0.4 m).
  const registration::IcpParams icp = test::unitObjectIcp(20.0);
  registration::ConfidenceParams conf;
  conf.inlier_threshold = 1.0;
  int ok_inliers = 0, ok_free = 0, n = 0, truth_fewer = 0, compared = 0;  // placed pairs, poses
  for (std::size_t s = 120; s + 20 < traj.poses.size() && n < 8; s += 150, ++n) {
    const std::size_t t = s + 20;
    const Isometry3d truth = traj.poses.at(t).inverse() * traj.poses.at(s);  // T_t_s
    const PointCloud source = sweep(s), target = sweep(t);
    registration::PreparedTargetOptions options;
    options.normal_neighbors = 10;
    options.threads = 1;
    const registration::PreparedTarget prepared(target, options);
    const FreeSpaceCheck check(source.points, target.points, FreeSpaceParams());
    const double truth_ratio = check.conflicts(truth).ratio();
    // The right place: not slid along the street, not turned (ICP's precision on 1 024 random
    // points of the sweep is not what is tested).
    auto registered = [&](const Isometry3d& T) {
      return test::poseError(T, truth).second < 2.0 &&
             (T.translation() - truth.translation()).norm() < 1.0;
    };
    // ICP from each of the search's poses; the largest inlier ratio wins, with `free_space`
    // times the discount (and the search then hands on ten translations per heading).
    auto best_of = [&](bool free_space) {
      Isometry3d best = Isometry3d::Identity();
      double best_score = -1.0;
      for (const auto& hit :
           registration::correlativeSearch(source, target, streetSearch(free_space))) {
        const auto o = registration::runIcp(source.points, prepared, hit.T_target_source, icp);
        if (o.status == registration::MatchStatus::TooFewCorrespondences) continue;
        const double ratio = check.conflicts(o.T_target_source).ratio();
        if (!registered(o.T_target_source)) {
          ++compared;
          truth_fewer += truth_ratio < ratio;
        }
        const double score = registration::evaluateAlignment(source.points, nullptr, prepared,
                                                             o.T_target_source, icp, conf)
                                 .inlier_ratio *
                             (free_space ? std::max(0.0, 1.0 - 8.0 * ratio) : 1.0);
        if (score > best_score) {
          best_score = score;
          best = o.T_target_source;
        }
      }
      return best;
    };
    const Isometry3d a = best_of(false), b = best_of(true);
    std::printf("sweeps %zu->%zu (%.1f m apart, truth conflicts %.3f): by inliers RTE %.2f m, "
                "with free space RTE %.2f m\n",
                s, t, truth.translation().norm(), truth_ratio,
                (a.translation() - truth.translation()).norm(),
                (b.translation() - truth.translation()).norm());
    ok_inliers += registered(a);
    ok_free += registered(b);
  }
  std::printf("%d pairs: placed by inliers %d, with free space %d; the truth has fewer "
              "conflicts than %d of %d wrong refined poses\n",
              n, ok_inliers, ok_free, truth_fewer, compared);
  ASSERT_EQ(n, 8);
  EXPECT_GT(ok_free, ok_inliers);
  EXPECT_EQ(ok_free, n) << "pairs placed within 1 m and 2 deg with free space";
  EXPECT_GE(truth_fewer, compared * 9 / 10) << "wrong poses with fewer conflicts than the truth";
}

}  // namespace
}  // namespace obm
