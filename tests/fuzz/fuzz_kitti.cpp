// KITTI odometry: velodyne .bin sweeps, poses, times and calib files.
#include "fuzz_common.hpp"
#include "obm/io/kitti.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bin = obm::fuzz::asFile(data, size, ".bin");
  obm::fuzz::expectCleanError([&] { obm::io::readKittiVelodyne(bin); });
  const std::string txt = obm::fuzz::asFile(data, size, ".txt");
  obm::fuzz::expectCleanError([&] { obm::io::readKittiPoses(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readKittiTimes(txt); });
  obm::fuzz::expectCleanError([&] { obm::io::readKittiCalib(txt); });
  return 0;
}
