// obm::mrpt_bridge: conversions, the covariance of the returned CPose3DPDFGaussian (checked by
// Monte Carlo), and registration side by side with MRPT's own CICP on the same clouds.
#include <gtest/gtest.h>

#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationPointCloud.h>
#include <mrpt/obs/CObservationRotatingScan.h>
#include <mrpt/obs/CObservationVelodyneScan.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/opengl/COpenGLScene.h>
#include <mrpt/poses/CPose3DInterpolator.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/io/point_cloud_io.hpp"
#include "obm/mrpt_bridge/conversions.hpp"
#include "obm/mrpt_bridge/export.hpp"
#include "obm/mrpt_bridge/mrpt_matcher.hpp"
#include "test_data.hpp"
#ifdef OBM_TEST_HAS_CICP
#include <mrpt/slam/CICP.h>
#endif

using namespace obm;
using namespace obm::mrpt_bridge;

namespace {

constexpr double kPi = 3.14159265358979323846;

double rotationErrorDeg(const Isometry3d& A, const Isometry3d& B) {
  return rotationAngle(A.linear().transpose() * B.linear()) * kRadToDeg;
}

/// A street-like scene sampled on its own: ground, two facades with recesses, posts and boxes.
PointCloud sceneSamples(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const double u = U(rng), a = -25 + 50 * U(rng), b = U(rng);
    if (u < 0.35) {
      c.points.emplace_back(a, -10 + 20 * b, 0.02 * std::sin(a));
    } else if (u < 0.6) {  // facade at y = -8 with 1 m recesses every 7 m
      const double y = std::fmod(a + 100, 7.0) < 2.0 ? -9.0 : -8.0;
      c.points.emplace_back(a, y, 8 * b);
    } else if (u < 0.8) {  // facade at y = 8, windows every 4 m
      const double y = std::fmod(a + 100, 4.0) < 1.0 ? 8.4 : 8.0;
      c.points.emplace_back(a, y, 8 * b);
    } else {  // boxes 1 m wide at x = -15, -3, 6, 17
      const double xs[4] = {-15, -3, 6, 17}, ys[4] = {-5, 4, -2, 3};
      const int k = static_cast<int>(U(rng) * 4) % 4;
      const double fx = U(rng), fy = U(rng), fz = U(rng);
      const int face = static_cast<int>(U(rng) * 3);
      Eigen::Vector3d p(xs[k] + fx, ys[k] + fy, 1.5 * fz);
      if (face == 0) p.x() = xs[k] + (fx < 0.5 ? 0.0 : 1.0);
      else if (face == 1) p.y() = ys[k] + (fy < 0.5 ? 0.0 : 1.0);
      else p.z() = 1.5;
      c.points.emplace_back(p.cast<float>());
    }
  }
  return c;
}

PointCloud transformed(const PointCloud& c, const Isometry3d& T) {
  PointCloud o = c;
  for (auto& p : o.points) p = (T * p.cast<double>()).cast<float>();
  return o;
}

registration::ScanMatcherConfig lidarIcp() {
  registration::ScanMatcherConfig cfg;
  cfg.type = registration::MatcherKind::Icp;
  cfg.icp.max_correspondence_distance = 1.0;
  cfg.icp.initial_max_correspondence_distance = 2.0;
  cfg.icp.max_iterations = 60;
  cfg.confidence.inlier_threshold = 0.2;
  return cfg;
}

}  // namespace

TEST(MrptBridge, PoseRoundTripAndConvention) {
  const Isometry3d T = makeIsometry(
      Eigen::Matrix3d(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.4, 1).normalized())),
      Eigen::Vector3d(1.5, -2, 0.3));
  const auto p = toCPose3D(T);
  EXPECT_NEAR(p.x(), 1.5, 1e-12);
  EXPECT_NEAR(p.y(), -2.0, 1e-12);
  EXPECT_TRUE(fromCPose3D(p).isApprox(T, 1e-12));
  // MRPT's (yaw, pitch, roll): R = Rz(yaw)·Ry(pitch)·Rx(roll).
  const mrpt::poses::CPose3D q(0, 0, 0, 0.3, -0.2, 0.1);
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  EXPECT_TRUE(fromCPose3D(q).linear().isApprox(R, 1e-12));
}

TEST(MrptBridge, PointsMapRoundTrip) {
  const PointCloud c = sceneSamples(500, 1);
  const auto m = toPointsMap(c);
  ASSERT_EQ(m.size(), c.size());
  const PointCloud back = toPointCloud(m);
  ASSERT_EQ(back.size(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(back.points[i], c.points[i]);
}

TEST(MrptBridge, CovarianceMatchesMonteCarloInMrptParameters) {
  // Ω over the right twist δ = [ρ; θ]: samples T·Exp(δ), δ ~ N(0, Ω⁻¹), expressed in MRPT's
  // (x, y, z, yaw, pitch, roll) must have the covariance toPose3DPDFGaussian returns.
  const Isometry3d T = makeIsometry(
      Eigen::Matrix3d(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, 0.5, 1).normalized())),
      Eigen::Vector3d(4, 1, -0.5));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> G(0.0, 1.0);
  Matrix6d A;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) A(r, c) = G(rng);
  const Matrix6d cov_delta = 1e-4 * (A * A.transpose() + 0.5 * Matrix6d::Identity());
  const Matrix6d Omega = cov_delta.inverse();
  const auto pdf = toPose3DPDFGaussian(T, Omega);
  EXPECT_TRUE(fromCPose3D(pdf.mean).isApprox(T, 1e-12));

  const Matrix6d L = cov_delta.llt().matrixL();
  const int N = 40000;
  std::vector<Vector6d> xs;
  Vector6d mean = Vector6d::Zero();
  for (int i = 0; i < N; ++i) {
    Vector6d z;
    for (int k = 0; k < 6; ++k) z[k] = G(rng);
    const Vector6d d = L * z;
    const auto p = toCPose3D(T * expSE3(d));
    Vector6d x;
    x << p.x(), p.y(), p.z(), p.yaw(), p.pitch(), p.roll();
    xs.push_back(x);
    mean += x / N;
  }
  Matrix6d emp = Matrix6d::Zero();
  for (const auto& x : xs) emp += (x - mean) * (x - mean).transpose() / (N - 1);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      const double scale = std::sqrt(emp(r, r) * emp(c, c));
      EXPECT_NEAR(pdf.cov(r, c), emp(r, c), 0.05 * scale) << "(" << r << ", " << c << ")";
    }
}

TEST(MrptBridge, UnconstrainedDirectionsGetTheStatedVariance) {
  Matrix6d Omega = Matrix6d::Zero();
  Omega(1, 1) = 100.0;  // only y is measured
  const auto pdf = toPose3DPDFGaussian(Isometry3d::Identity(), Omega, 25.0);
  EXPECT_NEAR(pdf.cov(1, 1), 0.01, 1e-12);
  EXPECT_NEAR(pdf.cov(0, 0), 25.0, 1e-9);
  EXPECT_NEAR(pdf.cov(3, 3), 25.0, 1e-6);
}

/// Registers `source` onto `target` with obmslam's ICP through the MRPT API and with MRPT's own
/// CICP (Align3DPDF, classic point-to-point ICP, MRPT's defaults with LiDAR-sized gates), both from
/// `init`; returns the two poses.
static std::pair<Isometry3d, Isometry3d> bothRegistrations(const PointCloud& target,
                                                           const PointCloud& source,
                                                           const Isometry3d& init,
                                                           MrptScanMatcher::Result* ours_out) {
  const auto m1 = toPointsMap(target), m2 = toPointsMap(source);
  MrptScanMatcher ours(lidarIcp());
  const auto r = ours.align(m1, m2, toCPose3D(init));
  EXPECT_TRUE(r.match.ok()) << toString(r.match.status) << " " << r.match.message;
  if (ours_out) *ours_out = r;
  Isometry3d mrpt_T = Isometry3d::Identity();
#ifdef OBM_TEST_HAS_CICP
  mrpt::slam::CICP icp;
  icp.options.thresholdDist = 1.0;
  icp.options.thresholdAng = 0.0;
  icp.options.ALFA = 0.5;
  icp.options.smallestThresholdDist = 0.05;
  icp.options.maxIterations = 200;
  icp.options.skip_cov_calculation = true;
  const auto pdf = icp.Align3DPDF(&m1, &m2, mrpt::poses::CPose3DPDFGaussian(toCPose3D(init)));
  mrpt::poses::CPose3D mean;
  pdf->getMean(mean);
  mrpt_T = fromCPose3D(mean);
#endif
  return {r.match.T_target_source, mrpt_T};
}

/// Prints both registrations' errors against `T_ref` (MRPT's when CICP is built); returns ours
/// (translation [m], rotation [deg]).
static std::pair<double, double> printBoth(const std::string& label, const Isometry3d& ours,
                                           const Isometry3d& theirs, const Isometry3d& T_ref) {
  const double et = (ours.translation() - T_ref.translation()).norm();
  const double er = rotationErrorDeg(ours, T_ref);
  std::printf("%s: obmslam ICP %.4f m / %.4f deg", label.c_str(), et, er);
#ifdef OBM_TEST_HAS_CICP
  std::printf(", MRPT CICP %.4f m / %.4f deg", (theirs.translation() - T_ref.translation()).norm(),
              rotationErrorDeg(theirs, T_ref));
#endif
  std::printf("\n");
  return {et, er};
}

TEST(MrptBridge, IcpNextToMrptCicpOnIndependentlySampledScene) {
  // Two independent samplings of one scene, the second moved by a known pose: both ICPs from the
  // identity; ours is asserted accurate and reported beside CICP.
  const Isometry3d T_true = makeIsometry(
      Eigen::Matrix3d(Eigen::AngleAxisd(4.0 * kPi / 180, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(0.6, -0.3, 0.05));
  const PointCloud target = sceneSamples(20000, 11);
  const PointCloud source = transformed(sceneSamples(20000, 12), T_true.inverse());
  MrptScanMatcher::Result r;
  const auto [ours, theirs] = bothRegistrations(target, source, Isometry3d::Identity(), &r);
  const auto [et_ours, er_ours] = printBoth("synthetic scene", ours, theirs, T_true);
  EXPECT_LT(et_ours, 0.05);
  EXPECT_LT(er_ours, 0.2);
  // The PDF: mean = the match, covariance symmetric positive definite and small where the scene
  // constrains the pose.
  EXPECT_TRUE(fromCPose3D(r.pose.mean).isApprox(ours, 1e-9));
  Eigen::Matrix<double, 6, 6> C;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) C(i, j) = r.pose.cov(i, j);
  EXPECT_TRUE(C.isApprox(C.transpose(), 1e-12));
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(C).eigenvalues().minCoeff(), 0.0);
  EXPECT_LT(std::sqrt(C(0, 0)), 0.05);
  EXPECT_LT(std::sqrt(C(3, 3)), 0.01);
}

TEST(MrptBridge, IcpNextToMrptCicpOnARealLidarPair) {
  OBM_REQUIRE_SHARED_DATA("real_pairs/lidar_small_gicp/source.ply");
  const std::string dir = test::sharedDataDir() + "/real_pairs/lidar_small_gicp";
  const PointCloud source = voxelDownsample(io::readPointCloud(dir + "/source.ply"), 0.4);
  const PointCloud target = voxelDownsample(io::readPointCloud(dir + "/target.ply"), 0.4);
  const Isometry3d T_ref = test::readMatrix4(dir + "/T_target_source.txt");
  MrptScanMatcher::Result r;
  const auto [ours, theirs] = bothRegistrations(target, source, Isometry3d::Identity(), &r);
  const auto [et, er] = printBoth("real LiDAR pair (" + std::to_string(source.size()) + " / " +
                                      std::to_string(target.size()) + " points, against the data's "
                                      "own alignment)", ours, theirs, T_ref);
  EXPECT_LT(et, 0.1);
  EXPECT_LT(er, 0.5);
}

TEST(MrptBridge, DepthFrameUnprojectedByMrpt) {
  // A CObservation3DRangeScan as a Kinect driver fills it: a 64×48 depth image of a wall 2 m in
  // front of the camera; MRPT's own unprojection makes the points (robot frame: +x forward).
  mrpt::obs::CObservation3DRangeScan obs;
  obs.sensorLabel = "KINECT";
  obs.hasRangeImage = true;
  obs.range_is_depth = true;
  obs.rangeUnits = 0.001f;
  obs.rangeImage_setSize(48, 64);
  for (int r = 0; r < 48; ++r)
    for (int c = 0; c < 64; ++c) obs.rangeImage(r, c) = 2000;  // [mm]
  obs.cameraParams.ncols = 64;
  obs.cameraParams.nrows = 48;
  obs.cameraParams.fx(50);
  obs.cameraParams.fy(50);
  obs.cameraParams.cx(32);
  obs.cameraParams.cy(24);
  const PointCloud c = observationToPointCloud(obs);
  ASSERT_EQ(c.size(), 64u * 48u);
  for (const auto& p : c.points) {
    ASSERT_NEAR(p.x(), 2.0f, 1e-3f) << p.transpose();
    ASSERT_LT(std::abs(p.y()), 1.4f);
    ASSERT_LT(std::abs(p.z()), 1.0f);
  }
  // Two frames of the wall, the second 10 cm closer: registered through the MRPT API. A flat
  // wall constrains x only: the covariance says so (large along the wall, small across it).
  mrpt::obs::CObservation3DRangeScan closer = obs;
  for (int r = 0; r < 48; ++r)
    for (int col = 0; col < 64; ++col) closer.rangeImage(r, col) = 1900;
  registration::ScanMatcherConfig cfg;
  cfg.icp.max_correspondence_distance = 0.3;
  const auto res = MrptScanMatcher(cfg).align(obs, closer);
  EXPECT_NEAR(res.pose.mean.x(), 0.1, 0.01) << toString(res.match.status);
  EXPECT_LT(res.pose.cov(0, 0), 1e-3);
  EXPECT_GT(res.pose.cov(1, 1), 100 * res.pose.cov(0, 0));
}

TEST(MrptBridge, RotatingScanOfMrptsDatasetIsAClearError) {
  // MRPT's rot_scan_velodyne.rawlog holds a CObservationRotatingScan: a range image without the
  // lasers' elevation table (MRPT 2.5 stores none), which MRPT itself cannot turn into points.
  // The bridge says so, naming the sensor, instead of returning an empty cloud.
  const std::string path = "/usr/share/mrpt/datasets/rot_scan_velodyne.rawlog";
  if (!std::filesystem::exists(path)) {
    if (test::inCI()) FAIL() << "missing " << path << " (Debian package mrpt-common)";
    GTEST_SKIP() << "no " << path;
  }
  mrpt::obs::CRawlog log;
  ASSERT_TRUE(log.loadFromRawLogFile(path));
  ASSERT_GE(log.size(), 1u);
  ASSERT_EQ(log.getType(0), mrpt::obs::CRawlog::etObservation);
  const auto o = log.getAsObservation(0);
  ASSERT_TRUE(IS_CLASS(*o, mrpt::obs::CObservationRotatingScan));
  try {
    (void)observationToPointCloud(*o);
    ADD_FAILURE() << "expected a FormatError";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("Velodyne1_SCAN"), std::string::npos) << e.what();
  }
}

TEST(MrptBridge, AnObservationWithoutPointsIsAClearError) {
  mrpt::obs::CObservationPointCloud empty;
  empty.sensorLabel = "LIDAR_TOP";
  empty.pointcloud = mrpt::maps::CSimplePointsMap::Create();
  try {
    (void)observationToPointCloud(empty);
    ADD_FAILURE() << "an empty observation must throw";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("LIDAR_TOP"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("CObservationPointCloud"), std::string::npos) << e.what();
  }
}

TEST(MrptBridgeExport, SimpleMapRoundTripsThroughMrpt) {
  std::vector<ExportKeyframe> kfs;
  for (int i = 0; i < 3; ++i) {
    ExportKeyframe k;
    k.timestamp = 100.0 + i;
    k.T_world_sensor = makeIsometry(
        Eigen::Matrix3d(Eigen::AngleAxisd(0.2 * i, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(2.0 * i, 0.5 * i, 0.0));
    k.information = (i == 0 ? 1e6 : 400.0) * Matrix6d::Identity();
    k.cloud = sceneSamples(300 + 10 * static_cast<std::size_t>(i), 20 + static_cast<std::uint64_t>(i));
    kfs.push_back(k);
  }
  const std::string dir = test::scratchDir("mrpt_export");
  const std::string path = dir + "/kf.simplemap";
  writeSimpleMap(path, kfs);
  const auto back = readSimpleMap(path);
  ASSERT_EQ(back.size(), kfs.size());
  for (std::size_t i = 0; i < kfs.size(); ++i) {
    EXPECT_TRUE(back[i].T_world_sensor.isApprox(kfs[i].T_world_sensor, 1e-9)) << i;
    EXPECT_NEAR(back[i].timestamp, kfs[i].timestamp, 1e-5);
    ASSERT_EQ(back[i].cloud.size(), kfs[i].cloud.size());
    EXPECT_EQ(back[i].cloud.points.front(), kfs[i].cloud.points.front());
    // σ² = 1/400 in x, y, z (translation block of Ω = 400·I, rotated by R: still 1/400·I).
    EXPECT_NEAR(back[i].covariance(0, 0), i == 0 ? 1e-6 : 1.0 / 400.0, 1e-9);
  }
  EXPECT_THROW(readSimpleMap(dir + "/none.simplemap"), IoError);
  EXPECT_THROW(writeSimpleMap(dir + "/no_such_folder/kf.simplemap", kfs), IoError);
}

TEST(MrptBridgeExport, SceneAndInterpolatorLoadInMrpt) {
  const std::string dir = test::scratchDir("mrpt_export");
  SceneContent c;
  std::vector<double> stamps;
  for (int i = 0; i < 20; ++i) {
    c.trajectory.push_back(makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0.1 * i, 0)));
    c.ground_truth.push_back(makeIsometry(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0)));
    stamps.push_back(0.1 * i);
  }
  c.keyframes = {c.trajectory.front(), c.trajectory.back()};
  c.map_points = sceneSamples(1000, 3);
  c.loops.emplace_back(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(19, 1.9, 0));
  write3DScene(dir + "/scene.3Dscene", c);
  mrpt::opengl::COpenGLScene scene;
  ASSERT_TRUE(scene.loadFromFile(dir + "/scene.3Dscene"));
  // grid, origin axes, map cloud, ground truth, trajectory, loops, two keyframe axes
  EXPECT_EQ(scene.getViewport()->size(), 8u);

  writePoseInterpolatorText(dir + "/traj.txt", stamps, c.trajectory);
  mrpt::poses::CPose3DInterpolator interp;
  ASSERT_TRUE(interp.loadFromTextFile(dir + "/traj.txt"));
  ASSERT_EQ(interp.size(), 20u);
  mrpt::poses::CPose3D p;
  bool valid = false;
  interp.interpolate(mrpt::Clock::fromDouble(0.55), p, valid);
  EXPECT_TRUE(valid);
  EXPECT_NEAR(p.x(), 5.5, 1e-4);  // spline between stamps stored with 6 decimals
  EXPECT_THROW(writePoseInterpolatorText(dir + "/t2.txt", {0.0}, c.trajectory), ContractError);
}
