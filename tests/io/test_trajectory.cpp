// Trajectory files (TUM, KITTI) and the associate.py-style time-stamp association.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/trajectory.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::io;

namespace {

const char* const kTumFiles[] = {"tum/rgbd_dataset_freiburg1_xyz-groundtruth.txt",
                                 "tum/rgbd_dataset_freiburg2_desk-groundtruth.txt"};

void writeText(const std::string& path, const std::string& s) {
  std::ofstream os(path, std::ios::binary);
  os << s;
}

double maxAbsDiff(const Isometry3d& a, const Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

/// The TUM benchmark's associate.py, literally: all candidates, sorted by (diff, a, b), greedy.
std::vector<std::pair<std::size_t, std::size_t>> referenceAssociate(const std::vector<double>& a,
                                                                    const std::vector<double>& b,
                                                                    double max_diff,
                                                                    double offset) {
  std::vector<std::tuple<double, double, double, std::size_t, std::size_t>> cand;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double d = std::abs(a[i] - (b[j] + offset));
      if (d < max_diff) cand.emplace_back(d, a[i], b[j], i, j);
    }
  std::sort(cand.begin(), cand.end());
  std::vector<bool> ua(a.size()), ub(b.size());
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const auto& c : cand) {
    const auto i = std::get<3>(c), j = std::get<4>(c);
    if (ua[i] || ub[j]) continue;
    ua[i] = ub[j] = true;
    out.emplace_back(i, j);
  }
  std::sort(out.begin(), out.end(), [&](auto x, auto y) { return a[x.first] < a[y.first]; });
  return out;
}

}  // namespace

TEST(TumTrajectory, RealGroundTruthFiles) {
  OBM_REQUIRE_SHARED_DATA("tum");
  for (const char* rel : kTumFiles) {
    const std::string path = test::sharedDataDir() + "/" + rel;
    SCOPED_TRACE(path);
    // Independent count of the data lines and of the stored quaternions' norms.
    std::ifstream is(path);
    std::string line;
    std::size_t data_lines = 0;
    double worst_norm_error = 0.0;
    while (std::getline(is, line)) {
      if (line.empty() || line[0] == '#') continue;
      ++data_lines;
      std::istringstream ls(line);
      double v[8];
      for (double& x : v) ls >> x;
      worst_norm_error = std::max(
          worst_norm_error,
          std::abs(std::sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]) - 1.0));
    }
    // The files store 4 decimals, so the quaternions are unit to ~1e-4.
    EXPECT_LT(worst_norm_error, 1e-3);

    const Trajectory traj = readTumTrajectory(path);
    ASSERT_EQ(traj.size(), data_lines);
    ASSERT_GT(traj.size(), 1000u);
    std::vector<double> dts;
    for (std::size_t i = 0; i < traj.size(); ++i) {
      const Eigen::Matrix3d R = traj[i].T.linear();
      ASSERT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
      ASSERT_NEAR(R.determinant(), 1.0, 1e-12);
      ASSERT_LT(traj[i].T.translation().norm(), 10.0);  // a motion-capture hall
      if (i > 0) {
        // Non-decreasing: freiburg2_desk really holds one repeated time stamp (line 10863).
        ASSERT_GE(traj[i].t, traj[i - 1].t) << i;
        dts.push_back(traj[i].t - traj[i - 1].t);
      }
    }
    EXPECT_GT(traj.front().t, 1.3e9);  // UNIX time of 2011
    std::nth_element(dts.begin(), dts.begin() + dts.size() / 2, dts.end());
    // Motion capture at 100 Hz (freiburg1) to ~300 Hz (freiburg2).
    EXPECT_GT(dts[dts.size() / 2], 0.002);
    EXPECT_LT(dts[dts.size() / 2], 0.012);
  }
}

TEST(TumTrajectory, RealFileRoundTrip) {
  OBM_REQUIRE_SHARED_DATA("tum");
  const Trajectory a = readTumTrajectory(test::sharedDataDir() + "/" + kTumFiles[0]);
  const std::string out = test::scratchDir("tum_rt") + "/traj.txt";
  writeTumTrajectory(out, a);
  const Trajectory b = readTumTrajectory(out);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].t, b[i].t) << i;
    ASSERT_LT(maxAbsDiff(a[i].T, b[i].T), 1e-12) << i;
  }
}

TEST(TumTrajectory, SyntheticRoundTripAndQuaternionSign) {
  std::mt19937_64 rng(7);
  Trajectory a;
  for (int i = 0; i < 50; ++i)
    a.push_back({1311868163.8697 + 0.0333 * i, randomAxisAngleTransform(rng, 180.0, 5.0)});
  const std::string out = test::scratchDir("tum_rt_syn") + "/traj.txt";
  writeTumTrajectory(out, a);
  const Trajectory b = readTumTrajectory(out);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t, b[i].t);
    EXPECT_LT(maxAbsDiff(a[i].T, b[i].T), 1e-12);
  }
  std::ifstream is(out);
  std::string line;
  std::getline(is, line);
  EXPECT_EQ(line[0], '#');
  while (std::getline(is, line)) {
    std::istringstream ls(line);
    double v[8];
    for (double& x : v) ls >> x;
    EXPECT_GE(v[7], 0.0);  // written with qw >= 0
  }
}

TEST(TumTrajectory, CommentsSeparatorsAndErrors) {
  const std::string dir = test::scratchDir("tum_parse");
  writeText(dir + "/ok.txt",
            "# ground truth\n\n  # indented comment\n"
            "1.5 1 2 3 0 0 0 2\r\n"  // CRLF, non-unit quaternion (normalised)
            "2.5,1,2,3,0,0,0.7071067811865476,0.7071067811865476\n");  // comma separated
  const Trajectory t = readTumTrajectory(dir + "/ok.txt");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].t, 1.5);
  EXPECT_LT(maxAbsDiff(t[0].T, makeIsometry(Eigen::Matrix3d::Identity(), {1, 2, 3})), 1e-15);
  // qz = qw = 1/√2: 90° about z.
  EXPECT_LT((t[1].T.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-15);

  writeText(dir + "/cols.txt", "# c\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n");
  try {
    readTumTrajectory(dir + "/cols.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 3u);
    EXPECT_NE(std::string(e.what()).find("cols.txt:3"), std::string::npos) << e.what();
  }
  writeText(dir + "/zero.txt", "1 0 0 0 0 0 0 0\n");
  EXPECT_THROW(readTumTrajectory(dir + "/zero.txt"), FormatError);
  writeText(dir + "/nan.txt", "1 0 nan 0 0 0 0 1\n");
  EXPECT_THROW(readTumTrajectory(dir + "/nan.txt"), FormatError);
  writeText(dir + "/word.txt", "1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 one\n");
  try {
    readTumTrajectory(dir + "/word.txt");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 2u);
    EXPECT_NE(std::string(e.what()).find("qw"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readTumTrajectory(dir + "/missing.txt"), IoError);
}

TEST(KittiTrajectory, RandomRoundTripWithin1e12) {
  std::mt19937_64 rng(11);
  std::vector<Isometry3d> a;
  for (int i = 0; i < 200; ++i) a.push_back(randomAxisAngleTransform(rng, 180.0, 1000.0));
  const std::string out = test::scratchDir("kitti_traj_rt") + "/t.txt";
  writeKittiTrajectory(out, a);
  const auto b = readKittiTrajectory(out);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_LE(maxAbsDiff(a[i], b[i]), 1e-12);
  const Trajectory st = stampPoses(b, std::vector<double>(b.size(), 0.5));
  EXPECT_EQ(posesOf(st).size(), b.size());
  EXPECT_EQ(timestampsOf(st).back(), 0.5);
  EXPECT_THROW(stampPoses(b, {1.0}), ContractError);
}

TEST(Associate, AssociatePySemanticsOnHandCase) {
  const std::vector<double> first{0.0, 1.0, 2.0, 3.0};
  const std::vector<double> second{3.019, 0.012, 0.005, 1.015, 2.5};  // unsorted on purpose
  const auto m = associateTimestamps(first, second, 0.02);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].first, 0u);
  EXPECT_EQ(m[0].second, 2u);  // 0.005 beats 0.012
  EXPECT_NEAR(m[0].difference, 0.005, 1e-15);
  EXPECT_EQ(m[1].first, 1u);
  EXPECT_EQ(m[1].second, 3u);
  EXPECT_EQ(m[2].first, 3u);
  EXPECT_EQ(m[2].second, 0u);
  // Greedy by difference: the closer pair wins even when it is not the first element's nearest.
  const auto g = associateTimestamps({0.0, 0.01}, {0.008}, 0.02);
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(g[0].first, 1u);
  // Strict bound, and the offset is added to the second sequence.
  EXPECT_TRUE(associateTimestamps({0.0}, {0.5}, 0.5).empty());
  const auto o = associateTimestamps({10.0}, {0.001, 5.0}, 0.02, 10.0);
  ASSERT_EQ(o.size(), 1u);
  EXPECT_EQ(o[0].second, 0u);
  EXPECT_THROW(associateTimestamps({std::nan("")}, {1.0}), ContractError);
}

TEST(Associate, MatchesLiteralAssociatePyOnRandomStreams) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> jitter(-0.015, 0.015);
  for (int trial = 0; trial < 20; ++trial) {
    // A 30 Hz and a 25 Hz stream with jitter and dropped frames.
    std::vector<double> a, b;
    for (int i = 0; i < 120; ++i)
      if (rng() % 5) a.push_back(100.0 + i / 30.0 + jitter(rng));
    for (int i = 0; i < 100; ++i)
      if (rng() % 4) b.push_back(100.0 + i / 25.0 + jitter(rng));
    std::shuffle(b.begin(), b.end(), rng);
    const double offset = trial % 2 ? 0.01 : 0.0;
    const auto ref = referenceAssociate(a, b, 0.02, offset);
    const auto got = associateTimestamps(a, b, 0.02, offset);
    ASSERT_EQ(got.size(), ref.size()) << trial;
    ASSERT_GT(got.size(), 10u);
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].first, ref[k].first) << trial << " " << k;
      EXPECT_EQ(got[k].second, ref[k].second) << trial << " " << k;
    }
  }
}

TEST(Associate, RealTrajectoryWithShiftedCopy) {
  OBM_REQUIRE_SHARED_DATA("tum");
  const Trajectory gt = readTumTrajectory(test::sharedDataDir() + "/" + kTumFiles[0]);
  Trajectory shifted = gt;
  // A clock offset of half the 100 Hz period (plus whole periods): without the offset every
  // time stamp falls ~5 ms from the nearest partner, so a 3 ms window matches almost nothing.
  for (auto& p : shifted) p.t -= 0.255;
  EXPECT_LT(associate(gt, shifted, 0.003).size(), gt.size() / 10);
  const auto m = associate(gt, shifted, 0.003, 0.255);
  ASSERT_EQ(m.size(), gt.size());
  for (std::size_t k = 0; k < m.size(); ++k) ASSERT_EQ(m[k].second, m[k].first);
}
