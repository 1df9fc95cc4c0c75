// Point-to-plane ICP: kernels, prepared targets, exact convergence on noise-free synthetic
// scenes (parametrised over kernels, solvers and metrics), outlier rejection, determinism and
// the expected-failure statuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <limits>
#include <tuple>

#include "obm/core/errors.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"

namespace obm {
namespace {

using test::makeSource;
using test::perturbation;
using test::poseError;
using test::roomScene;

const Isometry3d kTruth =
    makeIsometry(Eigen::AngleAxisd(12.0 * kDegToRad, Eigen::Vector3d(0.2, 0.1, 1.0).normalized())
                     .toRotationMatrix(),
                 Eigen::Vector3d(0.8, -0.4, 0.1));

registration::IcpParams exactParams() {
  registration::IcpParams p;
  p.max_correspondence_distance = 1.0;
  p.kernel_scale = 0.5;
  p.translation_tolerance = 1e-7;
  p.rotation_tolerance = 1e-7;
  p.max_iterations = 100;
  return p;
}

// ---------------------------------------------------------------------------------------------
TEST(RobustKernel, WeightIsDerivativeOverResidual) {
  for (auto k : {registration::RobustKernel::None, registration::RobustKernel::Huber,
                 registration::RobustKernel::Cauchy, registration::RobustKernel::GemanMcClure,
                 registration::RobustKernel::Tukey}) {
    const double c = 0.3;
    EXPECT_DOUBLE_EQ(registration::robustWeight(k, 0.0, c), 1.0) << toString(k);
    EXPECT_DOUBLE_EQ(registration::robustCost(k, 0.0, c), 0.0) << toString(k);
    for (double r : {-0.7, -0.25, 0.01, 0.1, 0.29, 0.31, 0.9, 2.5}) {
      const double h = 1e-6;
      const double deriv =
          (registration::robustCost(k, r + h, c) - registration::robustCost(k, r - h, c)) / (2 * h);
      EXPECT_NEAR(registration::robustWeight(k, r, c), deriv / r, 1e-5)
          << toString(k) << " r=" << r;
      EXPECT_GE(registration::robustWeight(k, r, c), 0.0);
      EXPECT_LE(registration::robustWeight(k, r, c), 1.0);
    }
    EXPECT_EQ(registration::parseRobustKernel(toString(k)), k);
  }
  EXPECT_EQ(registration::robustWeight(registration::RobustKernel::Tukey, 0.31, 0.3),
            0.0);  // hard rejection beyond c
  EXPECT_EQ(registration::parseRobustKernel("gm"), registration::RobustKernel::GemanMcClure);
  EXPECT_THROW(registration::parseRobustKernel("welsch"), ConfigError);
}

// ---------------------------------------------------------------------------------------------
TEST(PreparedTarget, NormalsNearestAndKnn) {
  // A plane z = -1 seen from the origin: normals ±z, oriented towards the origin (+z).
  const PointCloud plane = test::planeScene(4.0, 3);
  registration::PreparedTarget::Options all;
  all.min_planarity = 0.0;  // also trust elongated neighbourhoods: every normal is checked
  registration::PreparedTarget pt(plane, all);
  ASSERT_EQ(pt.size(), plane.size());
  for (std::size_t i = 0; i < pt.size(); ++i) {
    ASSERT_EQ(pt.normalValid()[i], 1);
    EXPECT_NEAR(pt.normals()[i].z(), 1.0f, 1e-4f);
  }
  // Nearest against brute force, with the gate respected.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> U(-9.f, 9.f);
  for (int q = 0; q < 200; ++q) {
    const Vector3f query(U(rng), U(rng), -1.f + 0.1f * U(rng));
    std::size_t best = 0;
    float best_d2 = std::numeric_limits<float>::max();
    for (std::size_t i = 0; i < plane.size(); ++i) {
      const float d2 = (plane.points[i] - query).squaredNorm();
      if (d2 < best_d2) best_d2 = d2, best = i;
    }
    std::size_t idx = 0;
    float d2 = 0.f;
    ASSERT_TRUE(pt.nearest(query, 10.0, idx, d2));
    EXPECT_FLOAT_EQ(d2, best_d2);
    EXPECT_EQ(idx, best);
    const double gate = 0.5 * std::sqrt(best_d2);
    EXPECT_FALSE(pt.nearest(query, gate, idx, d2));
    std::vector<std::size_t> ki;
    std::vector<float> kd;
    ASSERT_EQ(pt.knn(query, 5, ki, kd), 5u);
    EXPECT_EQ(ki[0], best);
    for (int j = 1; j < 5; ++j) EXPECT_LE(kd[j - 1], kd[j]);
  }
  // Points on a line have no trustworthy normal.
  PointCloud line;
  for (int i = 0; i < 50; ++i) line.push_back(Vector3f(0.1f * i, 2.f, 0.f));
  registration::PreparedTarget pl(line);
  for (auto v : pl.normalValid()) EXPECT_EQ(v, 0);
  // Non-finite points are dropped; voxelisation applies.
  PointCloud dirty = plane;
  dirty.points[0].x() = std::numeric_limits<float>::quiet_NaN();
  registration::PreparedTarget::Options o;
  EXPECT_EQ(registration::PreparedTarget(dirty, o).size(), plane.size() - 1);
  o.voxel = 2.0;
  EXPECT_LT(registration::PreparedTarget(dirty, o).size(), 150u);
  o.normal_neighbors = 2;
  EXPECT_THROW(registration::PreparedTarget(plane, o), ContractError);
}

// ---------------------------------------------------------------------------------------------
// Exact convergence on a noise-free scene from a perturbed guess, for every kernel × solver ×
// metric.
using ConvergenceCase =
    std::tuple<registration::RobustKernel, registration::IcpSolver, registration::IcpMetric>;
class IcpConvergence : public ::testing::TestWithParam<ConvergenceCase> {};

TEST_P(IcpConvergence, NoiseFreeRoomFromPerturbedGuess) {
  const auto [kernel, solver, metric] = GetParam();
  registration::IcpParams p = exactParams();
  p.kernel = kernel;
  p.solver = solver;
  p.metric = metric;
  const PointCloud target = roomScene(20.0, 1);
  const PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 2);
  registration::IcpMatcher icp(p);
  for (const auto& [trans, deg] : {std::pair{0.3, 5.0}, std::pair{-0.4, -8.0}}) {
    const Isometry3d guess = kTruth * perturbation(trans, deg);
    const registration::MatchResult r = icp.match(source, target, guess);
    EXPECT_EQ(r.status, registration::MatchStatus::Ok) << r.message;
    EXPECT_TRUE(r.converged);
    const auto [et, er] = poseError(r.T_target_source, kTruth);
    EXPECT_LT(et, 1e-4) << "translation error [m]";
    EXPECT_LT(er, 1e-3) << "rotation error [deg]";
    EXPECT_GT(r.iterations, 1);
    EXPECT_NEAR(r.inlier_ratio, 1.0, 1e-9);
    EXPECT_LT(r.rmse, 1e-4);
    EXPECT_GT(r.quality, 0.5);
  }
}

INSTANTIATE_TEST_SUITE_P(
    KernelsSolversMetrics, IcpConvergence,
    ::testing::Combine(::testing::Values(registration::RobustKernel::None,
                                         registration::RobustKernel::Huber,
                                         registration::RobustKernel::Cauchy,
                                         registration::RobustKernel::GemanMcClure,
                                         registration::RobustKernel::Tukey),
                       ::testing::Values(registration::IcpSolver::GaussNewton,
                                         registration::IcpSolver::LevenbergMarquardt),
                       ::testing::Values(registration::IcpMetric::PointToPlane,
                                         registration::IcpMetric::PointToPoint)),
    [](const auto& info) {
      return toString(std::get<0>(info.param)) + "_" + toString(std::get<1>(info.param)) + "_" +
             toString(std::get<2>(info.param));
    });

// ---------------------------------------------------------------------------------------------
TEST(Icp, AnnealedGateRecoversLargerOffset) {
  const PointCloud target = roomScene(20.0, 1);
  const PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 2);
  const Isometry3d guess = kTruth * perturbation(1.2, 10.0);
  registration::IcpParams p = exactParams();
  p.max_correspondence_distance = 0.2;
  p.initial_max_correspondence_distance = 2.0;
  const registration::MatchResult r = registration::IcpMatcher(p).match(source, target, guess);
  EXPECT_TRUE(r.converged) << r.message;
  const auto [et, er] = poseError(r.T_target_source, kTruth);
  EXPECT_LT(et, 1e-4);
  EXPECT_LT(er, 1e-3);
}

TEST(Icp, RobustKernelsRejectInjectedOutliers) {
  const PointCloud target = roomScene(20.0, 1);
  PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 2);
  // 25 % of the source displaced by 0.2–0.4 m along one direction (a ghost copy of the scene):
  // within the gate, so they pair with something, and they pull least squares one way.
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> U(0.2, 0.4);
  const Eigen::Vector3d ghost = Eigen::Vector3d(0.6, 0.3, 0.7).normalized();
  for (std::size_t i = 0; i < source.size(); i += 4)
    source.points[i] += (U(rng) * ghost).cast<float>();
  const Isometry3d guess = kTruth * perturbation(0.1, 2.0);
  auto run = [&](registration::RobustKernel k) {
    registration::IcpParams p = exactParams();
    p.kernel = k;
    p.kernel_scale = 0.05;
    p.max_correspondence_distance = 0.5;
    return registration::IcpMatcher(p).match(source, target, guess);
  };
  const auto plain = run(registration::RobustKernel::None);
  const double plain_err = poseError(plain.T_target_source, kTruth).first;
  EXPECT_GT(plain_err, 0.02) << "the outliers must bias least squares for this test to mean much";
  // Every kernel reduces the bias; the redescending ones with a fast-decaying influence
  // (Geman-McClure, Tukey) remove it.
  for (auto k : {registration::RobustKernel::Huber, registration::RobustKernel::Cauchy,
                 registration::RobustKernel::GemanMcClure, registration::RobustKernel::Tukey}) {
    const registration::MatchResult r = run(k);
    const auto [et, er] = poseError(r.T_target_source, kTruth);
    RecordProperty(toString(k) + "_error_mm", std::to_string(1e3 * et));
    EXPECT_LT(et, 0.5 * plain_err) << toString(k) << " vs least squares " << plain_err;
    if (k == registration::RobustKernel::GemanMcClure || k == registration::RobustKernel::Tukey) {
      EXPECT_LT(et, 2e-3) << toString(k);
      EXPECT_LT(er, 0.05) << toString(k);
    }
  }
}

TEST(Icp, DeterministicAndThreadCountIndependent) {
  const PointCloud target = roomScene(40.0, 4);
  const PointCloud source = makeSource(target, kTruth, 0.7, 0.01, 5);
  const Isometry3d guess = kTruth * perturbation(0.2, 3.0);
  registration::IcpParams p;
  p.threads = 1;
  const registration::MatchResult a = registration::IcpMatcher(p).match(source, target, guess);
  p.threads = 2;
  const registration::MatchResult b = registration::IcpMatcher(p).match(source, target, guess);
  const registration::MatchResult c = registration::IcpMatcher(p).match(source, target, guess);
  ASSERT_GT(source.size(), 4096u);  // several chunks of 1024 points, so both threads work
  EXPECT_TRUE(a.T_target_source.isApprox(b.T_target_source, 0.0));
  EXPECT_TRUE(b.T_target_source.isApprox(c.T_target_source, 0.0));
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_TRUE(a.information == b.information);
}

TEST(Icp, PreparedTargetIsReusable) {
  const PointCloud target = roomScene(20.0, 1);
  registration::IcpMatcher icp(exactParams());
  const registration::PreparedTarget prepared = icp.prepare(target);
  for (std::uint64_t seed : {11u, 12u}) {
    const PointCloud source = makeSource(target, kTruth, 0.5, 0.0, seed);
    const Isometry3d guess = kTruth * perturbation(0.2, 4.0);
    const registration::MatchResult a = icp.match(source, prepared, guess);
    const registration::MatchResult b = icp.match(source, target, guess);
    EXPECT_TRUE(a.T_target_source.isApprox(b.T_target_source, 0.0));
    EXPECT_LT(poseError(a.T_target_source, kTruth).first, 1e-4);
  }
}

TEST(Icp, SourceVoxelisationStillConverges) {
  const PointCloud target = roomScene(60.0, 1);
  const PointCloud source = makeSource(target, kTruth, 1.0, 0.0, 2);
  registration::IcpParams p = exactParams();
  p.source_voxel = 0.3;
  p.target_voxel = 0.0;
  const registration::MatchResult r =
      registration::IcpMatcher(p).match(source, target, kTruth * perturbation(0.2, 3.0));
  // Voxel centroids are off the surfaces only at edges: a few mm at most.
  const auto [et, er] = poseError(r.T_target_source, kTruth);
  EXPECT_LT(et, 0.01);
  EXPECT_LT(er, 0.1);
  EXPECT_LT(r.num_correspondences, source.size() / 3);
}

// ---------------------------------------------------------------------------------------------
TEST(Icp, ExpectedFailuresReturnAStatus) {
  const PointCloud target = roomScene(10.0, 1);
  const PointCloud source = makeSource(target, kTruth, 0.5, 0.0, 2);
  const registration::IcpMatcher icp;
  PointCloud empty;
  auto r = icp.match(empty, target);
  EXPECT_EQ(r.status, registration::MatchStatus::EmptyInput);
  EXPECT_FALSE(r.message.empty());
  EXPECT_EQ(icp.match(source, empty).status, registration::MatchStatus::EmptyInput);
  // Only non-finite points = empty.
  PointCloud nan_cloud;
  nan_cloud.push_back(Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_EQ(icp.match(nan_cloud, target).status, registration::MatchStatus::EmptyInput);
  // Too few points.
  PointCloud few;
  for (int i = 0; i < 10; ++i) few.push_back(source.points[std::size_t(i)]);
  r = icp.match(few, target, kTruth);
  EXPECT_EQ(r.status, registration::MatchStatus::TooFewPoints);
  EXPECT_TRUE(r.T_target_source.isApprox(kTruth, 0.0));  // the guess comes back
  EXPECT_EQ(r.quality, 0.0);
  // The clouds 100 m apart: nothing within the gate.
  r = icp.match(source, target, makeIsometry(Eigen::Matrix3d::Identity(), {100, 0, 0}));
  EXPECT_EQ(r.status, registration::MatchStatus::TooFewCorrespondences);
  EXPECT_EQ(r.quality, 0.0);
  EXPECT_TRUE(r.information.isZero());
  // Iteration limit.
  registration::IcpParams p;
  p.max_iterations = 1;
  r = registration::IcpMatcher(p).match(source, target, kTruth * perturbation(0.3, 5.0));
  EXPECT_EQ(r.status, registration::MatchStatus::NotConverged);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 1);
  // A non-finite guess is a contract violation, not an expected failure.
  Isometry3d bad = Isometry3d::Identity();
  bad(0, 3) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(icp.match(source, target, bad), ContractError);
  // Bad parameters are contract violations too.
  p = registration::IcpParams();
  p.kernel_scale = 0.0;
  EXPECT_THROW(registration::IcpMatcher{p}, ContractError);
}

}  // namespace
}  // namespace obm

// ---------------------------------------------------------------------------------------------
namespace obm {
namespace {

/// A bumpy closed surface of radius ≈ 1 (an object-scale shape): `n` points sampled from `seed`.
PointCloud bumpyObject(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, 1.0);
  PointCloud c;
  while (c.size() < n) {
    const Eigen::Vector3d d = Eigen::Vector3d(N(rng), N(rng), N(rng)).normalized();
    const double r = 1.0 + 0.15 * std::sin(4.0 * d.x()) * std::cos(3.0 * d.y()) + 0.1 * d.z() * d.z();
    c.push_back((r * d).cast<float>());
  }
  return c;
}

PointCloud jittered(const PointCloud& c, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0.0, sigma);
  PointCloud out = c;
  for (auto& p : out.points) p += Eigen::Vector3d(N(rng), N(rng), N(rng)).cast<float>();
  return out;
}

/// Mean rotation error [deg] of point-to-plane ICP without and with the point-to-point polish,
/// started at the true pose, over 8 pairs of 640-point clouds with σ = 0.01 jitter. `same_points`:
/// both clouds jitter the same surface samples (the object protocols: the source is the target's
/// points moved and jittered); otherwise each cloud samples the surface on its own.
std::pair<double, double> planeVsPolish(bool same_points) {
  registration::IcpParams p;
  p.max_correspondence_distance = 0.1;
  p.kernel_scale = 0.02;
  p.normal_neighbors = 10;
  p.max_iterations = 60;
  p.threads = 1;
  registration::IcpParams polished = p;
  polished.polish_max_correspondence_distance = 0.05;
  double plane = 0.0, polish = 0.0;
  const int runs = 8;
  for (int k = 0; k < runs; ++k) {
    const PointCloud surface = bumpyObject(640, 10 + k);
    const PointCloud target = jittered(surface, 0.01, 20 + k);
    const PointCloud source =
        jittered(same_points ? surface : bumpyObject(640, 100 + k), 0.01, 30 + k)
            .transformed(kTruth.inverse(), "source");
    const registration::MatchResult a = registration::IcpMatcher(p).match(source, target, kTruth);
    const registration::MatchResult b =
        registration::IcpMatcher(polished).match(source, target, kTruth);
    EXPECT_NE(a.status, registration::MatchStatus::TooFewCorrespondences) << a.message;
    EXPECT_NE(b.status, registration::MatchStatus::TooFewCorrespondences) << b.message;
    plane += poseError(a.T_target_source, kTruth).second / runs;
    polish += poseError(b.T_target_source, kTruth).second / runs;
  }
  return {plane, polish};
}

}  // namespace

// Started at the true pose, point-to-plane ICP drifts on jittered clouds: the PCA normals tilt
// with the noise and move the minimum. When both clouds jitter the same samples, the
// point-to-point polish's minimum is the true pose (the jitter averages out) and it removes the
// drift; when each cloud samples the surface independently, nearest points are not the same
// points and the polish is worse — which is why it is off by default (IcpParams).
TEST(Icp, PointToPointPolishHelpsOnlyWhenBothCloudsShareTheSamples) {
  const auto [plane_same, polish_same] = planeVsPolish(true);
  const auto [plane_indep, polish_indep] = planeVsPolish(false);
  std::printf("mean rotation error from the true pose [deg]: same samples: plane %.3f, + polish "
              "%.3f; independent samples: plane %.3f, + polish %.3f\n",
              plane_same, polish_same, plane_indep, polish_indep);
  EXPECT_LT(polish_same, 0.6 * plane_same);
  EXPECT_GT(polish_indep, plane_indep);
}

namespace {

/// n points uniform on the surface of a 1.8 × 1 × 0.6 box about the origin (area-weighted faces):
/// sharp edges, where PCA normals of a few neighbours are wrong.
PointCloud boxSurface(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const Eigen::Vector3d half(0.9, 0.5, 0.3);
  const double areas[3] = {half.y() * half.z(), half.x() * half.z(), half.x() * half.y()};
  std::discrete_distribution<int> face(
      {areas[0], areas[0], areas[1], areas[1], areas[2], areas[2]});
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  PointCloud c;
  while (c.size() < n) {
    const int f = face(rng), axis = f / 2;
    Eigen::Vector3d p(U(rng) * half.x(), U(rng) * half.y(), U(rng) * half.z());
    p[axis] = (f % 2 ? 1.0 : -1.0) * half[axis];
    c.push_back(p.cast<float>());
  }
  return c;
}

/// The object benchmark's ICP (unit-sphere scale: 0.1 gate, Huber at 0.02, 10-neighbour normals,
/// 60 iterations, one thread), converged when the step is below `tolerance` in units and degrees.
registration::IcpParams objectScaleParams(double tolerance) {
  registration::IcpParams p = exactParams();
  p.max_correspondence_distance = 0.1;
  p.kernel_scale = 0.02;
  p.normal_neighbors = 10;
  p.max_iterations = 60;
  p.translation_tolerance = tolerance;
  p.rotation_tolerance = tolerance * kDegToRad;
  p.threads = 1;
  return p;
}

/// The `keep` points of `c` nearest to its point farthest along `dir` (a partial view, as the
/// object protocols crop).
PointCloud cropAround(const PointCloud& c, const Eigen::Vector3f& dir, std::size_t keep) {
  std::size_t far = 0;
  for (std::size_t i = 1; i < c.size(); ++i)
    if (c.points[i].dot(dir) > c.points[far].dot(dir)) far = i;
  std::vector<std::size_t> order(c.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return (c.points[a] - c.points[far]).squaredNorm() <
           (c.points[b] - c.points[far]).squaredNorm();
  });
  PointCloud out;
  for (std::size_t k = 0; k < keep; ++k) out.push_back(c.points[order[k]]);
  return out;
}

}  // namespace

// Two partial views of a box, each sampled on its own (1024 points, 768 kept around its own far
// point) with σ = 0.005 jitter, ICP started at the true pose: with the object benchmark's kernel
// (c = 0.02) the minimum lies off the truth, pulled by pairs across the box's edges, where PCA
// normals of ten neighbours are wrong; a last stage at c = 0.005 (final_kernel_scale) ends closer
// on average. On the benchmark's meshes the gain is larger (docs/benchmarks.md); here the test
// holds the direction of the effect, that the stage runs after the wide kernel settled, and that
// it keeps an exact pair exact.
TEST(Icp, FinalNarrowKernelEndsCloserOnIndependentPartialSamplings) {
  const registration::IcpParams wide = objectScaleParams(1e-4);
  registration::IcpParams tight = wide;
  tight.final_kernel_scale = 0.005;
  double err_wide = 0.0, err_tight = 0.0;
  const int runs = 24;
  for (int k = 0; k < runs; ++k) {
    const PointCloud target = cropAround(jittered(boxSurface(1024, 60 + k), 0.005, 70 + k),
                                         Eigen::Vector3f(1, 0.2f, 0), 768);
    const PointCloud source = cropAround(jittered(boxSurface(1024, 80 + k), 0.005, 90 + k),
                                         Eigen::Vector3f(0.7f, 0.7f, 0.1f), 768)
                                  .transformed(kTruth.inverse(), "source");
    const auto a = registration::IcpMatcher(wide).match(source, target, kTruth);
    const auto b = registration::IcpMatcher(tight).match(source, target, kTruth);
    ASSERT_NE(a.status, registration::MatchStatus::TooFewCorrespondences) << a.message;
    ASSERT_NE(b.status, registration::MatchStatus::TooFewCorrespondences) << b.message;
    err_wide += poseError(a.T_target_source, kTruth).second / runs;
    err_tight += poseError(b.T_target_source, kTruth).second / runs;
  }
  std::printf("mean rotation error from the true pose [deg]: c = 0.02 %.3f, then c = 0.005 %.3f\n",
              err_wide, err_tight);
  EXPECT_LT(err_tight, err_wide);
  // Noise-free, the same scene: both end at the truth, the narrow stage after the wide one.
  const PointCloud exact_target = boxSurface(1024, 5);
  const PointCloud exact_source = exact_target.transformed(kTruth.inverse(), "source");
  const Isometry3d start = kTruth * perturbation(0.05, 4.0);
  const auto a = registration::IcpMatcher(wide).match(exact_source, exact_target, start);
  const auto b = registration::IcpMatcher(tight).match(exact_source, exact_target, start);
  EXPECT_LT(poseError(a.T_target_source, kTruth).first, 1e-4);
  EXPECT_LT(poseError(b.T_target_source, kTruth).first, 1e-4);
  EXPECT_LT(poseError(b.T_target_source, kTruth).second, 1e-3);
  EXPECT_GT(b.iterations, a.iterations);
  registration::IcpParams bad = wide;
  bad.final_kernel_scale = -1.0;
  EXPECT_THROW(bad.validate(), ContractError);
}

namespace {

/// n points uniform on a flat 1.0 × 0.6 plate in the z = 0 plane (its own sampling per seed),
/// jittered by σ = 0.005: no normal has an in-plane component but the noise's.
PointCloud flatPlate(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> X(-0.5, 0.5), Y(-0.3, 0.3);
  std::normal_distribution<double> N(0.0, 0.005);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i)
    c.points.push_back(Eigen::Vector3d(X(rng), Y(rng), N(rng)).cast<float>());
  return c;
}

}  // namespace

// Two independent samplings of a flat plate, ICP started at the true pose: the plane residuals
// leave the in-plane slide and the turn about the normal free, the noise-tilted normals pull
// along them and the iterations walk off the truth. With weak_direction_threshold those
// directions are left out of the steps: the pose stays where it started in them, and the normal
// direction and the two tilts are still solved (a start lifted off the plate and tilted is
// brought back).
TEST(Icp, WeakDirectionsOfAFlatPlateAreNotMoved) {
  const registration::IcpParams free = objectScaleParams(1e-5);
  registration::IcpParams held = free;
  held.weak_direction_threshold = 0.01;
  const Isometry3d truth = makeIsometry(
      Eigen::AngleAxisd(20.0 * kDegToRad, Eigen::Vector3d(0.3, -0.2, 1.0).normalized())
          .toRotationMatrix(),
      Eigen::Vector3d(0.2, -0.1, 0.05));
  // Lifted 3 cm along the plate's normal and tilted 2° about an in-plane axis.
  const Isometry3d off = makeIsometry(
      Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitX()).toRotationMatrix(),
      Eigen::Vector3d(0.0, 0.0, 0.03));
  double slide_free = 0.0, slide_held = 0.0, err_held = 0.0;
  const int runs = 8;
  for (int k = 0; k < runs; ++k) {
    const PointCloud target = flatPlate(700, 40 + k).transformed(truth, "target");
    const PointCloud source = flatPlate(700, 50 + k);
    const auto a = registration::IcpMatcher(free).match(source, target, truth);
    const auto b = registration::IcpMatcher(held).match(source, target, truth);
    const auto c = registration::IcpMatcher(held).match(source, target, truth * off);
    ASSERT_NE(a.status, registration::MatchStatus::TooFewCorrespondences) << a.message;
    ASSERT_NE(b.status, registration::MatchStatus::TooFewCorrespondences) << b.message;
    ASSERT_NE(c.status, registration::MatchStatus::TooFewCorrespondences) << c.message;
    slide_free += poseError(a.T_target_source, truth).first / runs;
    slide_held += poseError(b.T_target_source, truth).first / runs;
    // From the lifted, tilted start: the lift and the tilt are removed (the in-plane offset
    // the tilt's pivot adds stays, as it should: a weak direction keeps its start).
    const Isometry3d d = truth.inverse() * c.T_target_source;
    err_held += (std::abs(d.translation().z()) +
                 std::abs(std::asin(std::clamp(d.linear()(2, 1), -1.0, 1.0)))) / runs;
  }
  std::printf("flat plate from the true pose, mean drift: free %.4f, weak directions held %.4f; "
              "lift + tilt left from a lifted start %.5f\n",
              slide_free, slide_held, err_held);
  EXPECT_LT(slide_held, 0.25 * slide_free);
  EXPECT_LT(slide_held, 0.005);
  EXPECT_LT(err_held, 0.002);
}

}  // namespace obm
