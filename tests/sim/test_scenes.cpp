// Procedural scenes and trajectories: the drive closes its loop and stays on the road, the walk
// stays in free space and returns to its start, generation is deterministic, real ground truth
// runs through the scenes built around it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/scenes.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::sim;

namespace {
GeneratedScene flatGround() {
  GeneratedScene g;
  g.ground = HeightMap(-1000, -1000, 100.0, 21, 21, 0.0);
  return g;
}

UrbanSceneParams smallCity() {
  UrbanSceneParams p;
  p.blocks_x = 1;
  p.blocks_y = 1;
  p.block_length_x = 60;
  p.block_length_y = 60;
  p.building_depth_max = 12;
  p.margin = 5;
  p.terrain_resolution = 1.5;
  p.seed = 11;
  return p;
}

double yawOf(const Eigen::Isometry3d& T) {
  return std::atan2(T.linear()(1, 0), T.linear()(0, 0));
}
}  // namespace

TEST(Drive, DefaultRouteIsLongerThanAKilometreAndClosesItsLoop) {
  const UrbanSceneParams city;  // the kitti_like_urban grid
  DriveParams p;
  const Trajectory t = generateDrive(city, flatGround(), p);
  ASSERT_GT(t.size(), 1000u);
  EXPECT_GT(t.length(), 1000.0);
  // Ends where it started, heading the same way.
  EXPECT_LT((t.poses.back().translation() - t.poses.front().translation()).norm(), 0.1);
  EXPECT_LT(rotationAngle(t.poses.back().linear().transpose() * t.poses.front().linear()), 1e-2);
  double max_speed = 0, max_yaw_rate = 0;
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double dt = t.stamps[k] - t.stamps[k - 1];
    EXPECT_NEAR(dt, 0.1, 1e-9);
    max_speed =
        std::max(max_speed, (t.poses[k].translation() - t.poses[k - 1].translation()).norm() / dt);
    max_yaw_rate = std::max(max_yaw_rate,
                            std::fabs(wrapAngle(yawOf(t.poses[k]) - yawOf(t.poses[k - 1]))) / dt);
    EXPECT_NEAR(t.poses[k].translation().z(), p.sensor_height, 0.05);
  }
  EXPECT_LT(max_speed, p.speed * 1.05);
  EXPECT_LT(max_yaw_rate, 60.0 * kDegToRad);
  // Loops: places revisited at least 30 s later (beyond the start/end closure).
  int revisits = 0;
  for (std::size_t i = 0; i < t.size(); i += 10)
    for (std::size_t j = i + 300; j + 50 < t.size(); j += 10)
      if ((t.poses[i].translation() - t.poses[j].translation()).norm() < 3.0) {
        ++revisits;
        break;
      }
  EXPECT_GT(revisits, 20);
}

TEST(Drive, InvalidRoutesAreConfigErrors) {
  const UrbanSceneParams city;
  DriveParams p;
  p.route = {{0, 0}, {9, 0}};
  EXPECT_THROW(generateDrive(city, flatGround(), p), ConfigError);  // leaves the grid
  p.route = {{0, 0}, {1, 1}};
  EXPECT_THROW(generateDrive(city, flatGround(), p), ConfigError);  // not along a street
  p.route = {{0, 0}, {2, 0}, {1, 0}};
  EXPECT_THROW(generateDrive(city, flatGround(), p), ConfigError);  // U-turn
  p.route = {{0, 0}, {2, 0}, {2, 1}};
  EXPECT_GT(generateDrive(city, flatGround(), p).length(), 2 * 110.0);
}

TEST(UrbanScene, DriveRidesOnTheRoadWithNothingAboveAndGenerationIsDeterministic) {
  const UrbanSceneParams P = smallCity();
  const GeneratedScene g = generateUrbanGrid(P);
  const GeneratedScene g2 = generateUrbanGrid(P);
  ASSERT_EQ(g.mesh.numFaces(), g2.mesh.numFaces());
  EXPECT_EQ(g.mesh.mesh.vertices, g2.mesh.mesh.vertices);
  UrbanSceneParams other = P;
  other.seed = 12;
  EXPECT_NE(generateUrbanGrid(other).mesh.mesh.vertices, g.mesh.mesh.vertices);
  // Materials present: the city has everything the description promises.
  std::set<Material> mats(g.mesh.materials.begin(), g.mesh.materials.end());
  for (Material m :
       {Material::Road, Material::Sidewalk, Material::Facade, Material::Glass, Material::Balcony,
        Material::CarPaint, Material::Foliage, Material::Metal, Material::Wall, Material::Roof})
    EXPECT_TRUE(mats.count(m)) << materialProperties(m).name;

  const RaycastScene scene(g.mesh);
  DriveParams d;
  const Trajectory t = generateDrive(P, g, d);
  for (std::size_t k = 0; k < t.size(); k += 7) {
    const Eigen::Vector3f o = t.poses[k].translation().cast<float>();
    EXPECT_TRUE(g.bounds.contains(t.poses[k].translation()));
    const RayHit down = scene.intersect(o, {0, 0, -1});
    ASSERT_TRUE(down.hit()) << "pose " << k;
    EXPECT_EQ(down.material, Material::Road) << "pose " << k;
    EXPECT_NEAR(down.range, d.sensor_height, 0.06) << "pose " << k;
    EXPECT_FALSE(scene.intersect(o, {0, 0, 1}).hit()) << "something above the car at pose " << k;
  }
}

TEST(IndoorScene, WalkStaysInFreeSpaceAndReturnsToItsStart) {
  IndoorSceneParams P;
  P.rooms_per_side = 2;
  P.seed = 5;
  const GeneratedScene g = generateIndoorFloor(P);
  const RaycastScene scene(g.mesh);
  WalkParams w;
  const Trajectory t = generateWalk(P, g, w);
  ASSERT_GT(t.size(), 300u);
  EXPECT_LT((t.poses.back().translation() - t.poses.front().translation()).norm(), 0.05);
  for (std::size_t k = 0; k < t.size(); k += 5) {
    const Eigen::Vector3d p = t.poses[k].translation();
    ASSERT_TRUE(g.bounds.contains(p)) << "pose " << k;
    const Eigen::Vector3f o = p.cast<float>();
    // The ceiling is straight above (or a door's lintel): not inside furniture or a wall ...
    const RayHit up = scene.intersect(o, {0, 0, 1});
    ASSERT_TRUE(up.hit());
    if (up.material == Material::Wall) {
      EXPECT_NEAR(up.range, P.door_height - p.z(), 0.01) << "pose " << k;
    } else {
      EXPECT_EQ(up.material, Material::Ceiling) << "pose " << k;
      EXPECT_NEAR(up.range, P.wall_height - p.z(), 0.01);
    }
    // ... and nothing is within 20 cm around the camera.
    for (int a = 0; a < 8; ++a) {
      const Eigen::Vector3f d(std::cos(a * M_PI / 4), std::sin(a * M_PI / 4), 0.f);
      EXPECT_FALSE(scene.intersect(o, d, 0.f, 0.2f).hit()) << "pose " << k << " direction " << a;
    }
    // The optical axis is roughly horizontal (looking slightly down), z of the world is up.
    const Eigen::Vector3d fwd = t.poses[k].linear().col(2), down = t.poses[k].linear().col(1);
    EXPECT_LT(fwd.z(), 0.1);
    EXPECT_LT(down.z(), -0.8);
  }
}

TEST(IndoorScene, TumRoomPutsTheDeskWhereTheCameraLooks) {
  OBM_REQUIRE_SHARED_DATA("tum/rgbd_dataset_freiburg1_xyz-groundtruth.txt");
  const Trajectory cam =
      loadTumTrajectory(test::sharedDataDir() + "/tum/rgbd_dataset_freiburg1_xyz-groundtruth.txt");
  IndoorSceneParams P;
  P.seed = 2;
  const GeneratedScene g = generateRoomAroundTrajectory(P, cam, 0.0);
  const RaycastScene scene(g.mesh);
  std::size_t on_furniture = 0, n = 0;
  for (std::size_t k = 0; k < cam.size(); k += 50, ++n) {
    ASSERT_TRUE(g.bounds.contains(cam.poses[k].translation()));
    const RayHit h = scene.intersect(cam.poses[k].translation().cast<float>(),
                                     cam.poses[k].linear().col(2).cast<float>());
    ASSERT_TRUE(h.hit());
    if (h.material != Material::Wall && h.material != Material::Floor) ++on_furniture;
  }
  EXPECT_GT(on_furniture, 8 * n / 10);  // the optical axis mostly meets the desk and its clutter
}

TEST(UrbanScene, RealKitti00PathRunsOnARoadBuiltAroundIt) {
  OBM_REQUIRE_SHARED_DATA("kitti/poses/00.txt");
  const std::string d = test::sharedDataDir() + "/kitti/";
  const Trajectory path = loadKittiTrajectory(d + "poses/00.txt", d + "times/00.txt",
                                              KittiCalibration::kitti00().T_cam0_velo, 400);
  ASSERT_EQ(path.size(), 400u);
  EXPECT_NEAR(path.stamps[1], 0.1037359, 1e-6);
  UrbanSceneParams P;
  P.seed = 3;
  const GeneratedScene g = generateUrbanAroundPath(P, path, 1.73);
  const RaycastScene scene(g.mesh);
  for (std::size_t k = 0; k < path.size(); k += 9) {
    const Eigen::Vector3f o = path.poses[k].translation().cast<float>();
    const Eigen::Vector3f down = (path.poses[k].linear() * Eigen::Vector3d(0, 0, -1)).cast<float>();
    const RayHit h = scene.intersect(o, down);
    ASSERT_TRUE(h.hit()) << "pose " << k;
    EXPECT_EQ(h.material, Material::Road) << "pose " << k;
    EXPECT_NEAR(h.range, 1.73, 0.1) << "pose " << k;
  }
}

TEST(MeshScene, LoadsScalesAndNamesTheFile) {
  const std::string dir = test::scratchDir("mesh_scene");
  std::ofstream(dir + "/tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n";
  const GeneratedScene g = loadMeshScene(dir + "/tri.obj", 2.0);
  EXPECT_EQ(g.mesh.numFaces(), 2u);
  EXPECT_NEAR(g.bounds.max().x(), 2.0, 1e-6);
  EXPECT_NE(g.description.find("tri.obj"), std::string::npos);
  EXPECT_THROW(loadMeshScene(dir + "/none.obj"), IoError);
  EXPECT_THROW(loadMeshScene(dir + "/tri.obj", 0.0), ConfigError);
}
