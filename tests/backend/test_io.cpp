// g2o and TORO/MRPT `.graph` round trips (bit-exact), layouts and the no-vertex initial guess.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <sstream>

#include "obm/backend/graph_io.hpp"
#include "obm/backend/metrics.hpp"
#include "obm/core/errors.hpp"

using namespace obm;
using namespace obm::backend;

namespace {

bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

double awkward(std::mt19937_64& rng) {
  // Values whose decimal form needs all 17 digits, plus tiny and huge magnitudes.
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> e(-300, 300), k(0, 9);
  const int kind = k(rng);
  if (kind == 0) return u(rng) * std::pow(10.0, e(rng));
  if (kind == 1) return 0.1 * u(rng) / 3.0;
  return u(rng) * 100.0;
}

PoseGraph randomGraph3(std::mt19937_64& rng) {
  PoseGraph g;
  for (NodeId i = 0; i < 6; ++i)
    g.nodes3[i] = Node3{i, Pose3(Eigen::Vector3d(awkward(rng), awkward(rng), awkward(rng)),
                                 Eigen::Quaterniond(awkward(rng), awkward(rng), awkward(rng),
                                                    1.0 + std::abs(awkward(rng))))};
  for (NodeId i = 0; i < 5; ++i) {
    Edge3 e;
    e.from = i;
    e.to = (i * 7 + 3) % 6 == i ? i + 1 : (i * 7 + 3) % 6;
    e.T_from_to = Pose3(
        Eigen::Vector3d(awkward(rng), awkward(rng), awkward(rng)),
        Eigen::Quaterniond(0.3 + std::abs(awkward(rng)), awkward(rng), awkward(rng), awkward(rng)));
    Matrix6d A;
    std::uniform_real_distribution<double> u(-1, 1);
    for (int k = 0; k < 36; ++k) A(k) = u(rng) / 3.0;
    e.information = A * A.transpose() + Matrix6d::Identity() * 1.0 / 3.0;
    e.is_loop = isLoopByIds(e.from, e.to);
    g.edges3.push_back(e);
  }
  g.fixed = {0, 2};
  return g;
}

void expectSame3(const PoseGraph& a, const PoseGraph& b) {
  ASSERT_EQ(a.nodes3.size(), b.nodes3.size());
  ASSERT_EQ(a.edges3.size(), b.edges3.size());
  EXPECT_EQ(a.fixed, b.fixed);
  for (const auto& [id, n] : a.nodes3) {
    const auto& m = b.nodes3.at(id);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(sameBits(n.T_world_node.t[k], m.T_world_node.t[k]));
    for (int k = 0; k < 4; ++k)
      EXPECT_TRUE(sameBits(n.T_world_node.q.coeffs()[k], m.T_world_node.q.coeffs()[k]));
  }
  for (std::size_t i = 0; i < a.edges3.size(); ++i) {
    const auto &e = a.edges3[i], &f = b.edges3[i];
    EXPECT_EQ(e.from, f.from);
    EXPECT_EQ(e.to, f.to);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(sameBits(e.T_from_to.t[k], f.T_from_to.t[k]));
    for (int k = 0; k < 4; ++k)
      EXPECT_TRUE(sameBits(e.T_from_to.q.coeffs()[k], f.T_from_to.q.coeffs()[k]));
    for (int k = 0; k < 36; ++k) EXPECT_TRUE(sameBits(e.information(k), f.information(k))) << k;
  }
}

}  // namespace

TEST(GraphIo, G2o3dRoundTripIsBitExact) {
  std::mt19937_64 rng(1);
  const PoseGraph g = randomGraph3(rng);
  std::stringstream s1;
  writeG2o(g, s1);
  const PoseGraph r = readG2o(s1, "mem.g2o");
  expectSame3(g, r);
  std::stringstream s2;
  writeG2o(r, s2);
  EXPECT_EQ(s1.str(), s2.str());
}

TEST(GraphIo, G2o2dRoundTripKeepsUnwrappedAngles) {
  std::mt19937_64 rng(2);
  PoseGraph g;
  g.dimension = 2;
  for (NodeId i = 0; i < 5; ++i) {
    Pose2 p;
    p.x = awkward(rng);
    p.y = awkward(rng);
    p.theta = 3.5 + i;  // outside (−π, π]: must be kept as is
    g.nodes2[i * 3] = Node2{i * 3, p};
  }
  for (NodeId i = 0; i < 4; ++i) {
    Edge2 e;
    e.from = i * 3;
    e.to = i * 3 + 3;
    e.T_from_to.x = awkward(rng);
    e.T_from_to.y = awkward(rng);
    e.T_from_to.theta = -4.0;
    e.information << 3, 0.1, 0.2, 0.1, 4, 0.3, 0.2, 0.3, 5;
    e.information *= 1.0 / 3.0;
    g.edges2.push_back(e);
  }
  std::stringstream s1;
  writeG2o(g, s1);
  const PoseGraph r = readG2o(s1, "mem.g2o");
  ASSERT_EQ(r.dimension, 2);
  for (const auto& [id, n] : g.nodes2) {
    const auto& m = r.nodes2.at(id).T_world_node;
    EXPECT_TRUE(sameBits(n.T_world_node.x, m.x));
    EXPECT_TRUE(sameBits(n.T_world_node.y, m.y));
    EXPECT_TRUE(sameBits(n.T_world_node.theta, m.theta));
  }
  for (std::size_t i = 0; i < g.edges2.size(); ++i) {
    EXPECT_TRUE(sameBits(g.edges2[i].T_from_to.theta, r.edges2[i].T_from_to.theta));
    for (int k = 0; k < 9; ++k)
      EXPECT_TRUE(sameBits(g.edges2[i].information(k), r.edges2[i].information(k)));
  }
  std::stringstream s2;
  writeG2o(r, s2);
  EXPECT_EQ(s1.str(), s2.str());
}

TEST(GraphIo, ToroRoundTripIsBitExact) {
  const std::string text =
      "VERTEX3 0 0 0 0 0 0 0\n"
      "VERTEX3 1 1.0000000000000002 -0.30000000000000004 2.5 0.10000000000000001 -0.2 "
      "3.0000000000000004\n"
      "VERTEX3 2 2 0.5 -1e-300 -3.1 1.2345678901234567 0.7\n"
      "FIX 0\n"
      "EDGE3 0 1 1 -0.3 2.5 0.1 -0.2 3 10 1 0 0 0 0.5 10 0 0 0 0 10 0 0 0 20 0.25 0 20 0 20\n"
      "EDGE3 1 2 1.1 0.8 -2.5 2.9 0.333 -0.7 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n";
  std::istringstream in(text);
  const PoseGraph g = readToro(in, "mem.graph");
  ASSERT_EQ(g.dimension, 3);
  ASSERT_EQ(g.nodes3.size(), 3u);
  EXPECT_EQ(g.fixed, std::set<NodeId>{0});
  std::stringstream s1;
  writeToro(g, s1);
  const PoseGraph r = readToro(s1, "mem2.graph");
  expectSame3(g, r);
  for (const auto& [id, n] : g.nodes3)
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(sameBits((*n.T_world_node.rpy_from_file)[k],
                           (*r.nodes3.at(id).T_world_node.rpy_from_file)[k]));
  std::stringstream s2;
  writeToro(r, s2);
  EXPECT_EQ(s1.str(), s2.str());
  // The written angles are the file's own (e.g. node 1's yaw 3.0000000000000004).
  EXPECT_NE(s1.str().find("3.0000000000000004"), std::string::npos);
}

TEST(GraphIo, ToroLayoutsFollowMrpt) {
  // EDGE2: I_xx I_xy I_xθ I_yy I_yθ I_θθ (MRPT 2.x reads the g2o order).
  std::istringstream in2("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 11 12 13 22 23 33\n");
  const PoseGraph g2 = readToro(in2, "mem.graph");
  Eigen::Matrix3d expect;
  expect << 11, 12, 13, 12, 22, 23, 13, 23, 33;
  EXPECT_EQ(g2.edges2[0].information, expect);

  // EDGE3: angles roll pitch yaw with R = Rz(yaw)·Ry(pitch)·Rx(roll); information over
  // (x y z roll pitch yaw), converted to g2o's (t, vec q) by diag(1,1,1,2,2,2).
  std::istringstream in3(
      "VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 0 0 0 0.1 0.2 0.3\n"
      "EDGE3 0 1 1 2 3 0.1 0.2 0.3 1 0 0 0 0 0 2 0 0 0 0 3 0 0 0 4 0.5 0 5 0 6\n");
  const PoseGraph g3 = readToro(in3, "mem.graph");
  const Eigen::Matrix3d R = g3.nodes3.at(1).T_world_node.q.toRotationMatrix();
  const Eigen::Matrix3d Rexp = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  EXPECT_LT((R - Rexp).norm(), 1e-15);
  const Matrix6d& O = g3.edges3[0].information;
  EXPECT_EQ(O(0, 0), 1);
  EXPECT_EQ(O(2, 2), 3);
  EXPECT_EQ(O(3, 3), 16);  // 4·2·2
  EXPECT_EQ(O(3, 4), 2);   // 0.5·2·2
  EXPECT_EQ(O(4, 3), 2);
  EXPECT_EQ(O(5, 5), 24);
  // For a small error, eᵀΩe in g2o units ≈ the TORO quadratic form in angles.
  PoseGraph g = g3;
  g.nodes3.at(1).T_world_node = g.edges3[0].T_from_to;  // zero error first
  EXPECT_NEAR(chi2(g), 0.0, 1e-20);
  const Eigen::Vector3d d_rpy(1e-4, -2e-4, 3e-4);
  const Pose3 Z = g.edges3[0].T_from_to;
  const Eigen::Quaterniond dq = quaternionFromRpy(d_rpy);
  g.nodes3.at(1).T_world_node = Pose3(Z.t, (Z.q * dq).normalized());
  const double toro = 4 * d_rpy.x() * d_rpy.x() + 2 * 0.5 * d_rpy.x() * d_rpy.y() +
                      5 * d_rpy.y() * d_rpy.y() + 6 * d_rpy.z() * d_rpy.z();
  EXPECT_NEAR(chi2(g), toro, 1e-3 * toro);
}

TEST(GraphIo, G2oToToroToG2oPreservesPoses) {
  std::mt19937_64 rng(4);
  PoseGraph g = randomGraph3(rng);
  for (auto& [id, n] : g.nodes3) n.T_world_node.q.normalize();
  std::stringstream s;
  writeToro(g, s);
  const PoseGraph r = readToro(s, "mem.graph");
  for (const auto& [id, n] : g.nodes3) {
    const auto& m = r.nodes3.at(id).T_world_node;
    EXPECT_TRUE(n.T_world_node.t == m.t);
    EXPECT_NEAR(n.T_world_node.q.angularDistance(m.q), 0.0, 1e-14);
  }
  for (std::size_t i = 0; i < g.edges3.size(); ++i)
    EXPECT_LT((g.edges3[i].information - r.edges3[i].information).norm(),
              1e-15 * g.edges3[i].information.norm());
}

TEST(GraphIo, EdgesWithoutVerticesGetOdometryChain) {
  // 0→1, 1→2 odometry and a loop 0→2 whose measurement disagrees: the guess follows odometry.
  std::istringstream in(
      "EDGE_SE2 0 1 1 0 0.5 1 0 0 1 0 1\n"
      "EDGE_SE2 1 2 2 0 0 1 0 0 1 0 1\n"
      "EDGE_SE2 0 2 9 9 0 1 0 0 1 0 1\n");
  const PoseGraph g = readG2o(in, "edges_only.g2o");
  ASSERT_EQ(g.nodes2.size(), 3u);
  const Pose2& p2 = g.nodes2.at(2).T_world_node;
  EXPECT_NEAR(p2.x, 1 + 2 * std::cos(0.5), 1e-12);
  EXPECT_NEAR(p2.y, 2 * std::sin(0.5), 1e-12);
  EXPECT_NEAR(p2.theta, 0.5, 1e-12);
  EXPECT_TRUE(g.edges2[2].is_loop);
  EXPECT_FALSE(g.edges2[0].is_loop);
}

TEST(GraphIo, FormatByExtension) {
  EXPECT_EQ(formatFromPath("a/b.g2o"), GraphFormat::G2o);
  EXPECT_EQ(formatFromPath("x.graph"), GraphFormat::Toro);
  EXPECT_THROW(formatFromPath("x.txt"), IoError);
}
