// Trajectory and dataset lists: TUM trajectories and file lists, KITTI-format trajectories,
// Redwood / 7-Scenes .log, .info and fragment pairs, Open3D intrinsics.
#include "fuzz_common.hpp"
#include "obm/io/redwood_log.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string txt = obm::fuzz::asFile(data, size, ".txt");
  obm::fuzz::expectCleanError([&] { obm::io::readTumTrajectory(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readKittiTrajectory(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readTumFileList(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readRedwoodLog(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readRedwoodTrajectory(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readRedwoodInfo(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readFragmentPairs(txt); });
  const std::string json = obm::fuzz::asFile(data, size, ".json");
  obm::fuzz::expectCleanError([&] { obm::io::readOpen3dIntrinsics(json); });
  return 0;
}
