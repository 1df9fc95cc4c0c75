#include "obm/io/dataset_kind.hpp"

#include <filesystem>
#include <system_error>

#include "obm/core/errors.hpp"

namespace obm::io {

namespace fs = std::filesystem;

std::string toString(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::Kitti:
      return "kitti";
    case DatasetKind::TumRgbd:
      return "tum-rgbd";
    case DatasetKind::IclNuim:
      return "icl-nuim";
    case DatasetKind::SevenScenes:
      return "7scenes";
    case DatasetKind::Redwood:
      return "redwood";
    case DatasetKind::Rawlog:
      return "rawlog";
  }
  return "unknown";
}

DatasetKind detectDatasetKind(const std::string& input) {
  const fs::path p(input);
  if (!fs::exists(p)) throw IoError("input '" + input + "' does not exist");
  if (fs::is_regular_file(p)) {
    if (p.extension() == ".rawlog" || p.extension() == ".gz") return DatasetKind::Rawlog;
    throw IoError("input '" + input + "' is a file but not an MRPT .rawlog");
  }
  if (!fs::is_directory(p)) throw IoError("input '" + input + "' is neither a folder nor a file");
  if (fs::is_directory(p / "velodyne")) return DatasetKind::Kitti;
  const auto endsWith = [](const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  bool seven_scenes = false, icl_ground_truth = false;
  std::error_code ec;
  for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("frame-", 0) == 0 && endsWith(name, ".depth.png")) seven_scenes = true;
    if (endsWith(name, ".freiburg")) icl_ground_truth = true;
  }
  // ICL-NUIM's TUM-compatible release also has depth.txt; its *.gt.freiburg file tells it apart
  // (the intrinsics differ from TUM's).
  if (fs::is_regular_file(p / "associations.txt") || icl_ground_truth) return DatasetKind::IclNuim;
  if (fs::is_regular_file(p / "depth.txt")) return DatasetKind::TumRgbd;
  if (seven_scenes) return DatasetKind::SevenScenes;
  if (fs::is_directory(p / "depth")) return DatasetKind::Redwood;
  throw IoError("input '" + input +
                "': no known layout (expected velodyne/ + calib.txt + times.txt for KITTI; "
                "depth.txt, associations.txt, frame-*.depth.png or depth/ for RGB-D; or an MRPT "
                ".rawlog file)");
}

}  // namespace obm::io
