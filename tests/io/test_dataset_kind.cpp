// io::detectDatasetKind: every layout obm-map and obm-octomap read, told apart by its files, and
// clear errors for what is none of them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "obm/core/errors.hpp"
#include "obm/io/dataset_kind.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;
namespace fs = std::filesystem;

namespace {

void touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "# test\n";
}

std::string errorOf(const std::string& input) {
  try {
    detectDatasetKind(input);
  } catch (const IoError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(DatasetKind, EachLayoutIsRecognisedFromItsFiles) {
  const fs::path root = test::scratchDir("dataset_kind_layouts");
  fs::create_directories(root / "kitti" / "velodyne");
  touch(root / "tum" / "depth.txt");
  touch(root / "tum" / "rgb.txt");
  // ICL-NUIM's TUM-compatible release: depth.txt too, told apart by associations.txt or the
  // *.gt.freiburg ground truth.
  touch(root / "icl_assoc" / "associations.txt");
  touch(root / "icl_assoc" / "depth.txt");
  touch(root / "icl_gt" / "depth.txt");
  touch(root / "icl_gt" / "livingRoom0.gt.freiburg");
  touch(root / "seven" / "frame-000007.depth.png");
  fs::create_directories(root / "redwood" / "depth");
  touch(root / "seq.rawlog");
  touch(root / "seq.rawlog.gz");

  EXPECT_EQ(detectDatasetKind((root / "kitti").string()), DatasetKind::Kitti);
  EXPECT_EQ(detectDatasetKind((root / "tum").string()), DatasetKind::TumRgbd);
  EXPECT_EQ(detectDatasetKind((root / "icl_assoc").string()), DatasetKind::IclNuim);
  EXPECT_EQ(detectDatasetKind((root / "icl_gt").string()), DatasetKind::IclNuim);
  EXPECT_EQ(detectDatasetKind((root / "seven").string()), DatasetKind::SevenScenes);
  EXPECT_EQ(detectDatasetKind((root / "redwood").string()), DatasetKind::Redwood);
  EXPECT_EQ(detectDatasetKind((root / "seq.rawlog").string()), DatasetKind::Rawlog);
  EXPECT_EQ(detectDatasetKind((root / "seq.rawlog.gz").string()), DatasetKind::Rawlog);
  EXPECT_EQ(toString(DatasetKind::SevenScenes), "7scenes");
  EXPECT_EQ(toString(DatasetKind::TumRgbd), "tum-rgbd");
}

TEST(DatasetKind, TheRealOpen3dFramesAreARedwoodFolder) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d");
  EXPECT_EQ(detectDatasetKind(test::sharedDataDir() + "/rgbd_open3d"), DatasetKind::Redwood);
}

TEST(DatasetKind, ErrorsNameTheInput) {
  const fs::path root = test::scratchDir("dataset_kind_errors");
  fs::create_directories(root / "empty");
  touch(root / "cloud.ply");
  const std::string missing = (root / "nope").string();
  EXPECT_NE(errorOf(missing).find(missing + "' does not exist"), std::string::npos);
  const std::string empty = (root / "empty").string();
  EXPECT_NE(errorOf(empty).find("no known layout"), std::string::npos) << errorOf(empty);
  EXPECT_NE(errorOf(empty).find(empty), std::string::npos);
  const std::string ply = (root / "cloud.ply").string();
  EXPECT_NE(errorOf(ply).find("not an MRPT .rawlog"), std::string::npos) << errorOf(ply);
}
