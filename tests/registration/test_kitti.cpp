// ICP on the real KITTI HDL-64E sample scans (no ground truth): consecutive scans register from
// the identity, and the two-step composition agrees with the direct registration.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "obm/core/cloud_ops.hpp"
#include "obm/io/kitti.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"
#include "test_data.hpp"

namespace obm {
namespace {

class KittiIcp : public ::testing::Test {
 protected:
  void SetUp() override {
    OBM_REQUIRE_SHARED_DATA("kitti/hdl64_sample/000002.bin");
    for (std::size_t i = 0; i < 3; ++i) {
      const std::string path =
          test::sharedDataDir() + "/kitti/hdl64_sample/" + io::kittiScanFileName(i);
      scans.push_back(voxelDownsample(cropRange(io::readKittiVelodyne(path), 2.0, 100.0), 0.3));
    }
  }
  std::vector<PointCloud> scans;
};

TEST_F(KittiIcp, ConsecutiveScansConvergeFromIdentityAndCompose) {
  registration::IcpParams p;  // defaults: 1 m gate, Huber 0.1 m, point-to-plane, LM
  const registration::IcpMatcher icp(p);
  const registration::PreparedTarget t0 = icp.prepare(scans[0]);
  const registration::PreparedTarget t1 = icp.prepare(scans[1]);
  const registration::MatchResult r01 = icp.match(scans[1], t0);
  const registration::MatchResult r12 = icp.match(scans[2], t1);
  const registration::MatchResult r02 = icp.match(scans[2], t0);  // the prepared target 0 again
  for (const auto* r : {&r01, &r12, &r02}) {
    EXPECT_EQ(r->status, registration::MatchStatus::Ok) << r->message;
    EXPECT_TRUE(r->converged);
    EXPECT_GT(r->inlier_ratio, 0.5);
    EXPECT_GT(r->quality, 0.5);
    EXPECT_GT(r->conditioning, registration::ConfidenceParams().degeneracy_threshold);
    EXPECT_TRUE(r->information.isApprox(r->information.transpose(), 1e-9));
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(r->information).eigenvalues()(0), 0.0);
    // The vehicle moved: the solution is not the starting point.
    EXPECT_GT(r->T_target_source.translation().norm(), 0.1);
  }
  const Isometry3d composed = r01.T_target_source * r12.T_target_source;
  const auto [dt, dr] = test::poseError(r02.T_target_source, composed);
  EXPECT_LT(dt, 0.05) << "consistency translation [m]";
  EXPECT_LT(dr, 0.2) << "consistency rotation [deg]";
  RecordProperty("consistency_cm", std::to_string(100 * dt));
}

}  // namespace
}  // namespace obm
