#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/io/convert.hpp"
#include "obm/io/frame_stream.hpp"
#include "obm/io/kitti.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;
namespace fs = std::filesystem;

namespace {

/// A KITTI folder of `n` scans (scan s has 40 + s points at x = s) with poses.txt.
std::string makeKitti(const std::string& name, int n) {
  const std::string dir = test::scratchDir(name);
  fs::create_directories(dir + "/velodyne");
  std::vector<double> times;
  std::vector<Isometry3d> poses;
  for (int s = 0; s < n; ++s) {
    PointCloud c;
    for (int i = 0; i < 40 + s; ++i) c.points.emplace_back(static_cast<float>(s), 0.1f * i, 1.0f);
    c.intensity.assign(c.points.size(), 0.5f);
    writeKittiVelodyne(dir + "/velodyne/" + kittiScanFileName(static_cast<std::size_t>(s)), c);
    times.push_back(0.1 * s);
    Isometry3d T = Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.0, 0.0, 1.0 * s);
    poses.push_back(T);
  }
  writeKittiTimes(dir + "/times.txt", times);
  writeKittiCalib(dir + "/calib.txt", KittiCalib{});
  writeKittiPoses(dir + "/poses.txt", poses);
  return dir;
}

}  // namespace

TEST(FrameStream, KittiFramesComeInOrderWithTheirTimesAndGroundTruth) {
  const std::string dir = makeKitti("stream_kitti", 5);
  auto s = FrameStream::open(dir);
  EXPECT_EQ(s->kind(), DatasetKind::Kitti);
  ASSERT_EQ(s->size(), 5u);
  const std::vector<double> t = s->timestamps();
  ASSERT_EQ(t.size(), 5u);
  ASSERT_NE(s->kittiCalib(), nullptr);

  PointCloud c;
  ASSERT_TRUE(s->next(c));
  EXPECT_EQ(c.size(), 40u);
  EXPECT_DOUBLE_EQ(c.timestamp, t[0]);
  // skip() moves past a frame without reading it; the next frame is the one after.
  ASSERT_TRUE(s->skip());
  ASSERT_TRUE(s->next(c));
  EXPECT_EQ(c.size(), 42u);
  EXPECT_FLOAT_EQ(c.points[0].x(), 2.0f);
  EXPECT_DOUBLE_EQ(c.timestamp, t[2]);
  ASSERT_TRUE(s->next(c));
  ASSERT_TRUE(s->next(c));
  EXPECT_FALSE(s->next(c));
  EXPECT_FALSE(s->skip());
  EXPECT_EQ(s->readErrors(), 0u);

  const FrameGroundTruth gt = s->groundTruth(t, 0.02);
  ASSERT_EQ(gt.T_world_body.size(), 5u);
  for (const auto& T : gt.T_world_body) EXPECT_TRUE(T.has_value());
  EXPECT_FALSE(gt.path.empty());
}

TEST(FrameStream, AnUnreadableScanIsAnEmptyCountedFrameNotTheEndOfTheRun) {
  const std::string dir = makeKitti("stream_kitti_corrupt", 3);
  // 7 bytes: not a whole number of (x, y, z, intensity) records.
  std::ofstream(dir + "/velodyne/" + kittiScanFileName(1), std::ios::binary | std::ios::trunc)
      << "garbage";
  auto s = FrameStream::open(dir);
  PointCloud c;
  ASSERT_TRUE(s->next(c));
  EXPECT_EQ(c.size(), 40u);
  ASSERT_TRUE(s->next(c));
  EXPECT_TRUE(c.empty());
  EXPECT_EQ(s->readErrors(), 1u);
  ASSERT_TRUE(s->next(c));
  EXPECT_EQ(c.size(), 42u);
}

TEST(FrameStream, RawlogTimesBeforeReadingMatchTheFramesPlayed) {
  const std::string dir = makeKitti("stream_rawlog_src", 4);
  const std::string rawlog = test::scratchDir("stream_rawlog") + "/seq.rawlog";
  ASSERT_EQ(kittiToRawlog(dir, rawlog), 4u);
  auto s = FrameStream::open(rawlog);
  EXPECT_EQ(s->kind(), DatasetKind::Rawlog);
  EXPECT_EQ(s->size(), 0u);  // a stream: unknown before reading
  const std::vector<double> t = s->timestamps();
  ASSERT_EQ(t.size(), 4u);
  std::vector<double> played;
  PointCloud c;
  while (s->next(c)) {
    EXPECT_FALSE(c.empty());
    played.push_back(c.timestamp);
  }
  ASSERT_EQ(played.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(played[i], t[i], 1e-6) << i;
}

TEST(FrameStream, AMissingGroundTruthFileIsNamed) {
  const std::string dir = makeKitti("stream_kitti_gt", 2);
  FrameStreamOptions o;
  o.ground_truth = dir + "/no_such_poses.txt";
  try {
    FrameStream::open(dir, o);
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_poses.txt"), std::string::npos) << e.what();
  }
}
