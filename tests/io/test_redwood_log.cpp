// Redwood / 3DMatch .log and .info files on the real Open3D trajectory and odometry logs.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/redwood_log.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;

namespace {

std::string o3dDir() {
  return test::sharedDataDir() + "/rgbd_open3d";
}

void writeText(const std::string& path, const std::string& s) {
  std::ofstream os(path, std::ios::binary);
  os << s;
}

std::size_t countLines(const std::string& path) {
  std::ifstream is(path);
  std::string line;
  std::size_t n = 0;
  while (std::getline(is, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) ++n;
  return n;
}

}  // namespace

TEST(RedwoodLog, RealTrajectoryAndOdometryLogs) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/trajectory.log");
  for (const char* name : {"trajectory.log", "odometry.log"}) {
    const std::string path = o3dDir() + "/" + name;
    SCOPED_TRACE(path);
    const auto log = readRedwoodLog(path);
    ASSERT_EQ(log.size() * 5, countLines(path));  // 5 lines per item
    ASSERT_EQ(log.size(), 5u);                    // one per RGB-D frame of the folder
    for (std::size_t k = 0; k < log.size(); ++k) {
      // A camera trajectory: metadata "k k k+1".
      EXPECT_EQ(log[k].i, static_cast<int>(k));
      EXPECT_EQ(log[k].j, static_cast<int>(k));
      EXPECT_EQ(log[k].n, static_cast<int>(k) + 1);
      const Eigen::Matrix3d R = log[k].T.linear();
      // odometry.log stores 6 significant digits.
      EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-4);
      EXPECT_NEAR(R.determinant(), 1.0, 1e-4);
      EXPECT_LT(log[k].T.translation().norm(), 10.0);  // a room-sized scene
    }
    // Consecutive frames of a hand-held sequence are a few centimetres / degrees apart.
    for (std::size_t k = 1; k < log.size(); ++k) {
      const Isometry3d d = relative(log[k - 1].T, log[k].T);
      EXPECT_LT(d.translation().norm(), 0.2);
      EXPECT_LT(rotationAngle(d.linear()), 10.0 * kDegToRad);
    }
  }
  const auto traj = readRedwoodTrajectory(o3dDir() + "/trajectory.log");
  ASSERT_EQ(traj.size(), 5u);
  EXPECT_EQ(traj[2].matrix(), readRedwoodLog(o3dDir() + "/trajectory.log")[2].T.matrix());
}

TEST(RedwoodLog, RoundTripsAreExact) {
  OBM_REQUIRE_SHARED_DATA("rgbd_open3d/odometry.log");
  const std::string dir = test::scratchDir("redwood_rt");
  const auto a = readRedwoodLog(o3dDir() + "/odometry.log");
  writeRedwoodLog(dir + "/o.log", a);
  const auto b = readRedwoodLog(dir + "/o.log");
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].i, b[k].i);
    EXPECT_EQ(a[k].n, b[k].n);
    EXPECT_EQ(a[k].T.matrix(), b[k].T.matrix());
  }

  std::mt19937_64 rng(5);
  std::vector<Isometry3d> poses;
  for (int k = 0; k < 10; ++k) poses.push_back(randomAxisAngleTransform(rng, 180.0, 3.0));
  writeRedwoodTrajectory(dir + "/t.log", poses);
  const auto entries = readRedwoodLog(dir + "/t.log");
  ASSERT_EQ(entries.size(), 10u);
  EXPECT_EQ(entries[7].i, 7);
  EXPECT_EQ(entries[7].n, 8);
  EXPECT_EQ(entries[7].T.matrix(), poses[7].matrix());

  // gt.log: fragment pairs (i < j, n fragments); the matrix aligns j to i.
  std::vector<FragmentPair> pairs{{0, 2, 57, poses[0]}, {4, 6, 57, poses[1]}};
  writeFragmentPairs(dir + "/gt.log", pairs);
  const auto pb = readFragmentPairs(dir + "/gt.log");
  ASSERT_EQ(pb.size(), 2u);
  EXPECT_EQ(pb[1].id1, 4);
  EXPECT_EQ(pb[1].id2, 6);
  EXPECT_EQ(pb[1].num_fragments, 57);
  EXPECT_EQ(pb[1].T_id1_id2.matrix(), poses[1].matrix());

  RedwoodInfoEntry info;
  info.i = 4;
  info.j = 6;
  info.n = 57;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) info.information(r, c) = 1.0 / (1 + r + c) + (r == c ? 100 : 0);
  writeRedwoodInfo(dir + "/gt.info", {info, info});
  const auto ib = readRedwoodInfo(dir + "/gt.info");
  ASSERT_EQ(ib.size(), 2u);
  EXPECT_EQ(ib[1].n, 57);
  EXPECT_EQ(ib[1].information, info.information);
}

TEST(RedwoodLog, MalformedFilesNameFileAndLine) {
  const std::string dir = test::scratchDir("redwood_bad");
  const std::string item = "0 1 3\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  writeText(dir + "/trunc.log", item + "1 2 3\n1 0 0 0\n0 1 0 0\n");
  try {
    readRedwoodLog(dir + "/trunc.log");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.file(), dir + "/trunc.log");
    EXPECT_NE(std::string(e.what()).find("line 6"), std::string::npos) << e.what();
  }
  writeText(dir + "/cols.log", item + "1 2 3\n1 0 0 0\n0 1 0\n0 0 1 0\n0 0 0 1\n");
  try {
    readRedwoodLog(dir + "/cols.log");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 8u);
  }
  writeText(dir + "/meta.log", "0 1.5 3\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  try {
    readRedwoodLog(dir + "/meta.log");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 1u);
  }
  writeText(dir + "/row.log", "0 1 3\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n");
  try {
    readRedwoodLog(dir + "/row.log");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 5u);
  }
  writeText(dir + "/empty.log", "\n");
  EXPECT_TRUE(readRedwoodLog(dir + "/empty.log").empty());
  EXPECT_THROW(readRedwoodLog(dir + "/missing.log"), IoError);
  EXPECT_THROW(readRedwoodInfo(dir + "/trunc.log"), FormatError);  // 4 numbers per row, not 6
}
