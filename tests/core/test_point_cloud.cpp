#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "obm/core/errors.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

using namespace obm;

TEST(PointCloud, RemoveNonFiniteKeepsAttributesAligned) {
  PointCloud pc;
  pc.points = {{0, 0, 0}, {NAN, 0, 0}, {1, 2, 3}, {0, std::numeric_limits<float>::infinity(), 0}};
  pc.intensity = {0.f, 1.f, 2.f, 3.f};
  EXPECT_EQ(pc.removeNonFinite(), 2u);
  ASSERT_EQ(pc.size(), 2u);
  EXPECT_FLOAT_EQ(pc.intensity[1], 2.f);
  EXPECT_FLOAT_EQ(pc.points[1].z(), 3.f);
}

TEST(PointCloud, ValidateCatchesMismatch) {
  PointCloud pc;
  pc.points = {{0, 0, 0}, {1, 1, 1}};
  pc.intensity = {1.f};
  EXPECT_THROW(pc.validate(), ContractError);
}

TEST(PointCloud, TransformAndSelect) {
  PointCloud pc;
  pc.points = {{1, 0, 0}, {0, 1, 0}};
  const Isometry3d T = makeIsometry(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
                                    Eigen::Vector3d(1, 0, 0));
  const PointCloud out = pc.transformed(T, "world");
  EXPECT_EQ(out.frame_id, "world");
  EXPECT_NEAR(out.points[0].x(), 1.f, 1e-6);
  EXPECT_NEAR(out.points[0].y(), 1.f, 1e-6);
  EXPECT_NEAR(out.points[1].x(), 0.f, 1e-6);
  const PointCloud s = pc.select({1});
  ASSERT_EQ(s.size(), 1u);
  EXPECT_FLOAT_EQ(s.points[0].y(), 1.f);
  EXPECT_THROW(pc.select({5}), ContractError);
  EXPECT_TRUE(pc.centroid().isApprox(Vector3f(0.5f, 0.5f, 0.f)));
}
