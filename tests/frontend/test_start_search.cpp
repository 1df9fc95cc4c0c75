// The start search of a frame without a motion prior (TrackingParams::start_search_range): a car
// already at 12 m/s in a street of identical, gap-free facades. From the last pose the wide-gate
// ICP locks onto a repeated facade element metres from the truth, and the velocity it gives keeps
// every later frame in the wrong place while each is reported "tracked".
#include <gtest/gtest.h>

#include "obm/frontend/frontend.hpp"
#include "sim_loop.hpp"

namespace obm::frontend {
namespace {

using test::poseError;

/// 20 sweeps at 10 Hz along the first straight of config/sim/suite_corridor.yaml (fewer columns).
const test::SimLoop& corridor() {
  static const test::SimLoop c = test::simulateDrive(R"(
name: start_search_corridor
seed: 5
scene:
  type: urban_grid
  blocks_x: 1
  blocks_y: 1
  block_length_x: 400.0
  block_length_y: 120.0
  block_types: 1
  building_templates: 1
  min_floors: 3
  max_floors: 3
  lot_width_min: 28.0
  lot_width_max: 28.0
  setback_max: 0.0
  gap_probability: 0.0
  car_probability: 0.0
  sign_probability: 0.0
  tree_spacing: 1000.0
  light_spacing: 40.0
  slope_x_pct: 0.0
  slope_y_pct: 0.0
  hill_amplitude: 0.0
sensor:
  type: lidar
  layout: hdl64
  azimuth_step_deg: 0.4
  rate_hz: 10.0
  max_range: 80.0
  range_noise_sigma: 0.02
trajectory:
  type: drive
  route: [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]
  speed: 12.0
output:
  format: kitti
)", "corridor", 20, 300);
  return c;
}

/// config/map_kitti.yaml's tracking, at this test's resolution.
FrontendParams corridorParams(double start_search_range) {
  FrontendParams p;
  p.preprocess.max_range = 80.0;
  p.preprocess.voxel = 0.5;
  p.loop_closure.enabled = false;
  p.matcher.type = registration::MatcherKind::Icp;
  p.tracking.start_search_range = start_search_range;
  p.optimizer.num_threads = 1;
  return p;
}

/// Largest position error over the frames, and how many frames were reported tracked.
std::pair<double, int> drive(const FrontendParams& p) {
  const test::SimLoop& c = corridor();
  Frontend fe(p);
  int tracked = 0;
  for (const PointCloud& s : c.sweeps)
    tracked += fe.process(s).status == TrackingStatus::Tracked ? 1 : 0;
  const auto traj = fe.trajectory();
  double worst = 0.0;
  for (std::size_t i = 0; i < traj.size(); ++i)
    worst = std::max(worst, poseError(c.truth[i], traj[i]).first);
  return {worst, tracked};
}

TEST(StartSearch, FindsTheTrueMotionAmongRepeatedFacades) {
  const auto [worst, tracked] = drive(corridorParams(4.0));
  EXPECT_LT(worst, 0.3) << "the start search should find the 1.2 m per sweep the car moves";
  EXPECT_EQ(tracked, 19);
}

TEST(StartSearch, WithoutItTheCarStaysOnAWrongFacadeElementAndIsReportedTracked) {
  // The case the search exists for: if this starts passing, the scene no longer tests it.
  const auto [worst, tracked] = drive(corridorParams(0.0));
  EXPECT_GT(worst, 2.0);
  EXPECT_GE(tracked, 15);
}

}  // namespace
}  // namespace obm::frontend
