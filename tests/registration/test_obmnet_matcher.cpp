// The OBMNet matchers with a small random (untrained) model: plumbing, not accuracy — finite
// results, α > 0, a symmetric PSD information matrix, the pre-alignment composition, statuses —
// and exact convergence of the matchers that end with ICP, parametrised over matchers × kernels.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/registration/factory.hpp"
#include "obm/registration/icp.hpp"
#include "scenes.hpp"
#include "test_data.hpp"

namespace obm {
namespace {

using test::makeSource;
using test::perturbation;
using test::poseError;

const Isometry3d kTruth =
    makeIsometry(Eigen::AngleAxisd(9.0 * kDegToRad, Eigen::Vector3d(0.1, -0.2, 1.0).normalized())
                     .toRotationMatrix(),
                 Eigen::Vector3d(0.6, 0.2, -0.1));

class ObmNetMatchers : public ::testing::Test {
 public:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs every test of this suite in its own process, in
    // parallel, and scratchDir() empties the folder it returns.
    dir() = test::scratchDir("registration_obmnet_" + std::to_string(::getpid()));
    torch::manual_seed(17);
    obmnet::ObmNetConfig c;
    c.emb_dims = 16;
    c.n_samples = 8;
    c.n_iters = 1;
    c.n_keypoints = 64;
    obmnet::ObmNet net(c);
    obmnet::ModelMeta meta;
    meta.num_points = 384;
    meta.description = "random test model";
    obmnet::saveModel(dir() + "/small.pt", net, meta);
    // Neighbourhoods of 16 points: refuses clouds smaller than that.
    c.k1 = 16;
    c.k2 = 16;
    obmnet::ObmNet wide(c);
    obmnet::saveModel(dir() + "/k16.pt", wide, meta);
  }
  static std::string& dir() {
    static std::string d;
    return d;
  }
  static registration::ObmNetMatcherParams params(const std::string& file = "small.pt") {
    registration::ObmNetMatcherParams p;
    p.network.model_path = dir() + "/" + file;
    p.network.threads = 1;
    return p;
  }
};

/// ICP run to convergence on the noise-free room (tight tolerances, a wide kernel): what "the
/// matcher reaches the truth exactly" is measured with.
registration::IcpParams exactIcp() {
  registration::IcpParams icp;
  icp.kernel_scale = 0.5;
  icp.translation_tolerance = 1e-7;
  icp.rotation_tolerance = 1e-7;
  icp.max_iterations = 100;
  return icp;
}

void expectSymmetricPsd(const Matrix6d& W) {
  EXPECT_TRUE(W.allFinite());
  EXPECT_TRUE(W.isApprox(W.transpose(), 1e-9)) << W;
  const auto ev = Eigen::SelfAdjointEigenSolver<Matrix6d>(W).eigenvalues();
  EXPECT_GE(ev(0), -1e-9 * std::max(1.0, ev(5)));
}

TEST_F(ObmNetMatchers, ObmNetAloneReportsFiniteDiagnostics) {
  const PointCloud target = test::roomScene(1.5, 1);
  const PointCloud source = makeSource(target, kTruth, 1.0, 0.0, 2);
  ASSERT_LE(source.size(), 384u);  // the network sees every point
  registration::IcpParams icp;
  icp.max_correspondence_distance = 2.0;
  const registration::ObmNetMatcher m(params(), icp);
  EXPECT_EQ(m.name(), "obmnet");
  EXPECT_NE(m.describe().find("random test model"), std::string::npos);
  const registration::MatchResult r = m.match(source, target, kTruth);
  RecordProperty("match_status", toString(r.status));
  RecordProperty("error_m", std::to_string(poseError(r.T_target_source, kTruth).first));
  EXPECT_TRUE(r.T_target_source.matrix().allFinite());
  EXPECT_NEAR(r.T_target_source.linear().determinant(), 1.0, 1e-9);
  EXPECT_GT(r.alpha, 0.0);
  EXPECT_GE(r.overlap, 0.0);
  EXPECT_LE(r.overlap, 1.0);
  EXPECT_GE(r.quality, 0.0);
  EXPECT_LE(r.quality, 1.0);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_GT(r.runtime_ms, 0.0);
  expectSymmetricPsd(r.information);
  if (r.status != registration::MatchStatus::TooFewCorrespondences) {
    EXPECT_GT(r.information.trace(), 0.0);
    EXPECT_GT(r.sigma, 0.0);
  }
  // Deterministic.
  const registration::MatchResult again = m.match(source, target, kTruth);
  EXPECT_TRUE(again.T_target_source.isApprox(r.T_target_source, 0.0));
  EXPECT_TRUE(again.information == r.information);
}

TEST_F(ObmNetMatchers, PreAlignComposesWithTheGuessOtherwiseIgnoresIt) {
  const PointCloud target = test::roomScene(1.5, 3);
  const PointCloud source = makeSource(target, kTruth, 1.0, 0.0, 4);
  const Isometry3d guess = kTruth * perturbation(0.3, 4.0);
  registration::ObmNetMatcherParams p = params();
  p.pre_align = false;
  const registration::ObmNetMatcher raw(p);
  const registration::MatchResult a = raw.match(source, target, guess);
  const registration::MatchResult b = raw.match(source, target, Isometry3d::Identity());
  EXPECT_TRUE(a.T_target_source.isApprox(b.T_target_source, 0.0));
  // pre_align: T = ΔT · T_init with ΔT the network's pose for the moved source.
  p.pre_align = true;
  const registration::ObmNetMatcher pre(p);
  const registration::MatchResult c = pre.match(source, target, guess);
  const registration::MatchResult d = raw.match(source.transformed(guess, "target"), target);
  EXPECT_TRUE(c.T_target_source.isApprox(d.T_target_source * guess, 1e-9))
      << c.T_target_source.matrix() << "\n\n"
      << (d.T_target_source * guess).matrix();
}

TEST_F(ObmNetMatchers, ExpectedFailuresAndBadModels) {
  const PointCloud target = test::roomScene(1.5, 5);
  registration::IcpParams icp;
  icp.min_correspondences = 6;
  const registration::ObmNetMatcher m(params("k16.pt"), icp);
  PointCloud few;
  for (int i = 0; i < 10; ++i) few.push_back(target.points[std::size_t(i)]);
  const registration::MatchResult r = m.match(few, target);
  EXPECT_EQ(r.status,
            registration::MatchStatus::TooFewPoints);  // the network's neighbourhoods need 16
  EXPECT_NE(r.message.find("16"), std::string::npos) << r.message;
  EXPECT_EQ(m.match(PointCloud(), target).status, registration::MatchStatus::EmptyInput);
  const registration::ObmNetIcpMatcher mi(params("k16.pt"), icp);
  EXPECT_EQ(mi.match(few, target).status, registration::MatchStatus::TooFewPoints);
  EXPECT_THROW(registration::ObmNetMatcher(params("missing.pt")), IoError);
}

TEST_F(ObmNetMatchers, QualityAndConditioningAreThoseOfThePoseOnEverySourcePoint) {
  // The loop and recovery thresholds compare the quality of any matcher: for the OBMNet matchers
  // it must be the quality ICP's statistics give at the same pose, on every source point, not one
  // taken on the network's weighted sample or with its predicted overlap.
  const PointCloud target = test::roomScene(20.0, 10);
  const PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 11);
  registration::IcpParams icp;
  icp.kernel_scale = 0.5;
  const registration::ConfidenceParams conf;
  const registration::ObmNetIcpMatcher refined(params(), icp, conf);
  const registration::ObmNetMatcher alone(params(), icp, conf);
  const registration::PreparedTarget prepared = refined.prepare(target);
  for (const registration::ScanMatcher* m :
       {static_cast<const registration::ScanMatcher*>(&refined),
        static_cast<const registration::ScanMatcher*>(&alone)}) {
    const registration::MatchResult r = m->match(source, prepared, kTruth * perturbation(0.2, 3.0));
    ASSERT_NE(r.status, registration::MatchStatus::TooFewCorrespondences)
        << m->name() << ": " << r.message;
    const registration::AlignmentStats all = registration::evaluateAlignment(
        source.points, nullptr, prepared, r.T_target_source, icp, conf);
    EXPECT_DOUBLE_EQ(r.conditioning, all.conditioning) << m->name();
    EXPECT_DOUBLE_EQ(r.quality, registration::matchQuality(all.inlier_ratio, all.rmse, all.overlap,
                                                           all.conditioning,
                                                           icp.max_correspondence_distance, conf))
        << m->name();
    EXPECT_GE(r.network_confidence, 0.0) << m->name() << ": the network's own view is kept";
  }
  // At the exact pose of the refined matcher, ICP reports the same quality.
  const registration::MatchResult r =
      refined.match(source, prepared, kTruth * perturbation(0.2, 3.0));
  const registration::MatchResult i =
      registration::IcpMatcher(icp, conf).match(source, prepared, r.T_target_source);
  EXPECT_GT(r.quality, 0.5);
  EXPECT_NEAR(r.quality, i.quality, 1e-6);
}

TEST_F(ObmNetMatchers, OverlapStageKeepsTheExactSolution) {
  // The overlap stage (an ICP on the network's most-weighted points first) changes where the full
  // ICP starts, not what it converges to: on the noise-free room both reach the truth.
  const PointCloud target = test::roomScene(20.0, 8);
  const PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 9);
  const registration::IcpParams icp = exactIcp();
  registration::ObmNetMatcherParams p = params();
  for (const double keep : {0.0, 0.5, 1.0}) {
    p.overlap_stage_keep = keep;
    const registration::ObmNetIcpMatcher m(p, icp);
    const registration::MatchResult r = m.match(source, target, kTruth * perturbation(0.3, 5.0));
    EXPECT_EQ(r.status, registration::MatchStatus::Ok) << "keep " << keep << ": " << r.message;
    const auto [et, er] = poseError(r.T_target_source, kTruth);
    EXPECT_LT(et, 1e-4) << "keep " << keep << ": translation error [m]";
    EXPECT_LT(er, 1e-3) << "keep " << keep << ": rotation error [deg]";
  }
}

TEST_F(ObmNetMatchers, BlindHeadingsRegisterASourceTurnedHalfwayRound) {
  // A source turned by 170° about z (a place seen from the other direction): ICP from the guess
  // (the identity) cannot reach it, and the untrained network is no help; with init_headings the
  // ICP from the guess turned by 180° converges, and has the most inliers. The room is nearly
  // symmetric under a half turn (only the two boxes tell), so the untrained network's refined
  // pose, the room turned round, has almost as many: with the default margin (a heading must
  // have 1.08× the network's inliers) the network's pose is kept, with margin 1 the heading wins.
  const PointCloud target = test::roomScene(20.0, 8);
  const Isometry3d truth = makeIsometry(
      Eigen::AngleAxisd(170.0 * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
      Eigen::Vector3d(0.4, -0.3, 0.05));
  const PointCloud source = makeSource(target, truth, 0.6, 0.0, 9);
  const registration::IcpParams icp = exactIcp();
  const registration::IcpMatcher plain(icp);
  const auto [pt, pr] = poseError(plain.match(source, target).T_target_source, truth);
  ASSERT_GT(pr, 10.0)
      << "the scene must defeat ICP from the identity for this test to mean anything";
  registration::ObmNetMatcherParams p = params();
  p.pre_align = false;
  const registration::MatchResult network =
      registration::ObmNetIcpMatcher(p, icp).match(source, target);
  for (const int refine : {1, 0}) {
    p.refine_hypotheses = refine;
    p.init_headings = 4;
    p.init_headings_margin = 1.0;
    const registration::MatchResult r =
        registration::ObmNetIcpMatcher(p, icp).match(source, target);
    EXPECT_EQ(r.status, registration::MatchStatus::Ok) << r.message;
    const auto [et, er] = poseError(r.T_target_source, truth);
    EXPECT_LT(et, 1e-4) << "refine_hypotheses " << refine << ": translation error [m]";
    EXPECT_LT(er, 1e-3) << "refine_hypotheses " << refine << ": rotation error [deg]";
    EXPECT_GT(r.alpha, 0.0);  // the network's diagnostics stay attached to the result
    EXPECT_GT(r.inlier_ratio, network.inlier_ratio);
  }
  p.refine_hypotheses = 1;
  p.init_headings_margin = 1.08;
  const registration::MatchResult kept =
      registration::ObmNetIcpMatcher(p, icp).match(source, target);
  EXPECT_LT(kept.inlier_ratio, 1.08 * network.inlier_ratio) << "the heading was not clearly fitter";
  EXPECT_TRUE(kept.T_target_source.isApprox(network.T_target_source, 1e-9))
      << "within the margin the network's pose must be kept";
}

TEST_F(ObmNetMatchers, RefinementUsesTheColoursOfColouredClouds) {
  // A textured wall seen from a camera moved 4 cm / 3 cm along it and turned 2° about its normal:
  // the geometry leaves the in-plane motion free, the texture pins it. With color_weight > 0 the
  // ICP after the network uses the clouds' colours (as IcpMatcher does); without colours, or with
  // color_weight 0, the refinement is geometric and stays off in the plane.
  const Isometry3d truth =
      makeIsometry(Eigen::AngleAxisd(2.0 * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                   Eigen::Vector3d(0.04, -0.03, 0.0));
  const PointCloud target = test::texturedWall(0.008, 1, test::wallPose());
  const PointCloud source = test::texturedWall(0.012, 2, truth.inverse() * test::wallPose());
  const registration::IcpParams icp = test::wallParams();
  registration::IcpParams colored = icp;
  colored.color_weight = 0.033;
  colored.color_kernel_scale = 0.2;
  const registration::ObmNetIcpMatcher with_colour(params(), colored);
  const registration::MatchResult coloured = with_colour.match(source, target);
  const auto [ct, cr] = poseError(coloured.T_target_source, truth);
  EXPECT_LT(ct, 0.004) << "coloured refinement, translation error [m] (rotation " << cr << "°)";
  EXPECT_LT(cr, 0.3);
  // Its conditioning is that of the coloured cost on every source point, as IcpMatcher reports it.
  const registration::PreparedTarget prepared = with_colour.prepare(target);
  const std::vector<float> source_grey = registration::colorIntensities(source, prepared, colored);
  ASSERT_EQ(source_grey.size(), source.size());
  EXPECT_DOUBLE_EQ(coloured.conditioning,
                   registration::evaluateAlignment(source.points, nullptr, prepared,
                                                   coloured.T_target_source, colored,
                                                   registration::ConfidenceParams(), &source_grey)
                       .conditioning);
  PointCloud grey = source;
  grey.colors.clear();
  const auto [gt, gr] = poseError(with_colour.match(grey, target).T_target_source, truth);
  EXPECT_GT(gt, 0.01) << "a colourless source cannot be pinned in the wall's plane";
  const registration::ObmNetIcpMatcher geometric(params(), icp);
  const auto [mt, mr] = poseError(geometric.match(source, target).T_target_source, truth);
  EXPECT_GT(mt, 0.01) << "color_weight 0 must leave the refinement geometric";
}

// ---------------------------------------------------------------------------------------------
// Every matcher that ends with ICP converges exactly on the noise-free room from a perturbed
// guess, built through the YAML factory.
using MatcherCase = std::tuple<std::string, std::string>;  // type, kernel
class MatcherConvergence : public ObmNetMatchers,
                           public ::testing::WithParamInterface<MatcherCase> {};

TEST_P(MatcherConvergence, NoiseFreeRoomFromPerturbedGuess) {
  const auto& [type, kernel] = GetParam();
  const std::string yaml = "type: " + type + "\nobmnet: {model_path: " + dir() +
                           "/small.pt, threads: 1}\n"
                           "icp: {kernel: " +
                           kernel +
                           ", kernel_scale: 0.5, translation_tolerance: 1.0e-7, "
                           "rotation_tolerance_deg: 1.0e-5, max_iterations: 100}\n";
  const auto matcher = registration::makeScanMatcher(
      registration::ScanMatcherConfig::load(ConfigNode::fromString(yaml)));
  EXPECT_EQ(matcher->name(), type);
  const PointCloud target = test::roomScene(20.0, 6);
  const PointCloud source = makeSource(target, kTruth, 0.6, 0.0, 7);
  for (const auto& [trans, deg] : {std::pair{0.3, 5.0}, std::pair{-0.2, -6.0}}) {
    const registration::MatchResult r =
        matcher->match(source, target, kTruth * perturbation(trans, deg));
    EXPECT_EQ(r.status, registration::MatchStatus::Ok) << r.message;
    const auto [et, er] = poseError(r.T_target_source, kTruth);
    EXPECT_LT(et, 1e-4) << "translation error [m]";
    EXPECT_LT(er, 1e-3) << "rotation error [deg]";
    EXPECT_GT(r.alpha, 0.0);
    EXPECT_GT(r.quality, 0.0);
    EXPECT_LE(r.quality, 1.0);
    expectSymmetricPsd(r.information);
    EXPECT_GT(r.information.trace(), 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(MatchersKernels, MatcherConvergence,
                         ::testing::Combine(::testing::Values("icp", "obmnet+icp"),
                                            ::testing::Values("none", "huber", "cauchy",
                                                              "geman_mcclure", "tukey")),
                         [](const auto& info) {
                           std::string n = std::get<0>(info.param) + "_" + std::get<1>(info.param);
                           for (auto& ch : n)
                             if (ch == '+') ch = '_';
                           return n;
                         });

}  // namespace
}  // namespace obm
