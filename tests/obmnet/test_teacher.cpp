// Self-training labels (teacher.hpp) and the correspondence term L_c (losses.hpp): ICP that
// recovers a motion, labels that are the nearest target points within the radius, the start of
// better fit chosen per pair, and L_c as the cross-entropy of the labelled rows.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include <ATen/CPUGeneratorImpl.h>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/obmnet/losses.hpp"
#include "obm/obmnet/teacher.hpp"
#include "obm/obmnet/trainer.hpp"
#include "small_training.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

/// B×3×N float tensor of `count` blob clouds of `points` points.
torch::Tensor blobBatch(int count, int points, std::uint64_t seed) {
  std::vector<torch::Tensor> out;
  for (const auto& c : test::blobClouds(count, points, seed)) {
    auto t = torch::empty({3, points}, torch::kFloat32);
    for (int i = 0; i < points; ++i)
      for (int d = 0; d < 3; ++d) t[d][i] = c.points[static_cast<std::size_t>(i)][d];
    out.push_back(t);
  }
  return torch::stack(out);
}

/// Rotations about z by `deg` (B×3×3) and translation `t` for every pair.
RigidTransforms zRotation(int64_t B, double deg, std::array<float, 3> t) {
  const double a = deg * M_PI / 180.0;
  auto R = torch::eye(3, torch::kFloat32);
  R[0][0] = std::cos(a);
  R[0][1] = -std::sin(a);
  R[1][0] = std::sin(a);
  R[1][1] = std::cos(a);
  return {R.unsqueeze(0).repeat({B, 1, 1}),
          torch::tensor({t[0], t[1], t[2]}).unsqueeze(0).repeat({B, 1})};
}

double maxRotationErrorDeg(const torch::Tensor& R, const torch::Tensor& R_true) {
  const auto d = torch::matmul(R.transpose(1, 2), R_true).to(torch::kFloat64);
  const auto tr = d.diagonal(0, 1, 2).sum(1);
  return (((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos() * 180.0 / M_PI).max().item<double>();
}

/// B×3×N: `count` independent samplings of one ellipsoid surface (semi-axes 1, 0.6, 0.35), each
/// from its own seed: two of them describe the same surface and share no point.
torch::Tensor ellipsoidSamples(int count, int points, std::uint64_t seed) {
  std::vector<torch::Tensor> out;
  for (int c = 0; c < count; ++c) {
    auto g = torch::make_generator<at::CPUGeneratorImpl>(seed + static_cast<std::uint64_t>(c));
    auto d = torch::randn({3, points}, g, torch::kFloat32);
    d = d / d.norm(2, 0, true);
    d[0] *= 1.0f;
    d[1] *= 0.6f;
    d[2] *= 0.35f;
    out.push_back(d);
  }
  return torch::stack(out);
}

}  // namespace

TEST(Teacher, IcpRecoversASmallMotionOfTheSameSamples) {
  const auto src = blobBatch(2, 200, 11);
  const auto T_true = zRotation(2, 12.0, {0.1f, -0.05f, 0.03f});
  const auto tgt = transformPoints(T_true, src);
  const auto I = identityTransforms(2, src.options());
  const auto T = icpRefine(src, tgt, I, 40, 0.5, 0.1);
  EXPECT_LT(maxRotationErrorDeg(T.R, T_true.R), 0.01);
  EXPECT_LT((T.t - T_true.t).abs().max().item<double>(), 1e-3);
  // Without iterations the start is returned unchanged.
  const auto T0 = icpRefine(src, tgt, I, 0, 0.5, 0.1);
  EXPECT_TRUE(torch::equal(T0.R, I.R));
  EXPECT_THROW(icpRefine(src, tgt, I, 5, 0.05, 0.1), ContractError);
}

TEST(Teacher, LabelsAreTheNearestTargetPointsWithinTheRadius) {
  const auto cloud = blobBatch(1, 120, 21);
  const auto I = identityTransforms(1, cloud.options());
  // The same samples under the identity: every point is labelled with itself.
  const auto same = correspondenceLabels(cloud, cloud, I, 1e-4);
  EXPECT_TRUE(torch::equal(same[0], torch::arange(120, torch::kInt64)));
  EXPECT_DOUBLE_EQ(alignmentFitness(cloud, cloud, I, 1e-4).item<double>(), 1.0);
  // A target holding only the points with x > 0: the others have no partner that close.
  const auto keep = torch::nonzero(cloud[0][0] > 0).squeeze(1);
  const auto cropped = cloud.index_select(2, keep);
  const auto lab = correspondenceLabels(cloud, cropped, I, 1e-4)[0];
  int64_t j = 0;
  for (int64_t i = 0; i < 120; ++i) {
    if (cloud[0][0][i].item<float>() > 0) {
      EXPECT_EQ(lab[i].item<int64_t>(), j) << "point " << i;
      ++j;
    } else {
      EXPECT_EQ(lab[i].item<int64_t>(), -1) << "point " << i;
    }
  }
  // A pose 10 units off labels nothing.
  const auto far = zRotation(1, 0.0, {10.f, 0.f, 0.f});
  EXPECT_EQ((correspondenceLabels(cloud, cloud, far, 0.5) >= 0).sum().item<int64_t>(), 0);
}

TEST(Teacher, TheStartOfBetterFitIsKeptPerPair) {
  // Identical clouds, and a network estimate 150° off for both pairs: ICP from it ends in a
  // wrong alignment of the elongated blob, ICP from the identity in the right one.
  const auto cloud = blobBatch(2, 150, 31);
  const auto wrong = zRotation(2, 150.0, {0.f, 0.f, 0.f});
  TeacherParams p;
  p.match_radius = 1e-3;
  torch::Tensor labels;
  p.from_identity = false;
  const auto T_net_only = teacherLabels(cloud, cloud, wrong, p, labels);
  ASSERT_GT(maxRotationErrorDeg(T_net_only.R, torch::eye(3).unsqueeze(0).repeat({2, 1, 1})), 10.0)
      << "precondition: ICP from the wrong estimate must not find the identity by itself";
  p.from_identity = true;
  const auto T = teacherLabels(cloud, cloud, wrong, p, labels);
  EXPECT_LT(maxRotationErrorDeg(T.R, torch::eye(3).unsqueeze(0).repeat({2, 1, 1})), 1e-3);
  for (int64_t b = 0; b < 2; ++b)
    EXPECT_TRUE(torch::equal(labels[b], torch::arange(150, torch::kInt64))) << "pair " << b;
}

TEST(Teacher, NormalsOfAPlaneAndOfASphere) {
  // A plane z = 0.3 (x, y random): every normal is ±z.
  torch::manual_seed(5);
  auto plane = torch::rand({1, 3, 300}, torch::kFloat32) * 2.0 - 1.0;
  plane[0][2].fill_(0.3f);
  const auto n = estimateNormals(plane, 10);
  ASSERT_EQ(n.sizes(), plane.sizes());
  EXPECT_GT(n[0][2].abs().min().item<double>(), 0.999);
  // A dense unit sphere: each normal is along the point's own direction (either sign).
  const auto sphere =
      ellipsoidSamples(1, 2000, 7) / torch::tensor({1.0f, 0.6f, 0.35f}).view({1, 3, 1});
  const auto ns = estimateNormals(sphere, 10);
  const auto cosine = (ns * sphere / sphere.norm(2, 1, true)).sum(1).abs();
  EXPECT_GT(cosine.min().item<double>(), 0.95);
  EXPECT_THROW(estimateNormals(plane, 2), ContractError);
}

TEST(Teacher, PointToPlaneIcpAlignsIndependentSamplingsWherePointToPointStalls) {
  // Two independent samplings of one ellipsoid, 400 points each, the target moved by 12° about
  // z and a small translation: no source point has an exact partner.
  const auto a = ellipsoidSamples(1, 400, 100);
  const auto b = ellipsoidSamples(1, 400, 200);
  const auto T_true = zRotation(1, 12.0, {0.05f, -0.03f, 0.02f});
  const auto tgt = transformPoints(T_true, b);
  const auto I = identityTransforms(1, a.options());
  const auto point = icpRefine(a, tgt, I, 30, 0.3, 0.1);
  const auto plane = icpRefine(a, tgt, I, 30, 0.3, 0.1, estimateNormals(tgt, 10));
  const double e_point = maxRotationErrorDeg(point.R, T_true.R);
  const double e_plane = maxRotationErrorDeg(plane.R, T_true.R);
  std::cout << "independent samplings, 12 deg: point-to-point ICP " << e_point
            << " deg, point-to-plane " << e_plane << " deg\n";
  EXPECT_LT(e_plane, 0.5);
  EXPECT_LT(e_plane, 0.5 * e_point)
      << "point to point " << e_point << "°, point to plane " << e_plane << "°";
  // Normals of the wrong size are refused.
  EXPECT_THROW(icpRefine(a, tgt, I, 3, 0.3, 0.1, torch::zeros({1, 3, 10})), ContractError);
}

TEST(Teacher, TurnedStartsReachAPoseNeitherStartCan) {
  // The same ellipsoid samples turned by 90° about z; the network's estimate is the identity too,
  // and ICP with a tight gate stays where it starts. A start turned by 90° about z is the right
  // one, and it labels every point.
  const auto cloud = ellipsoidSamples(1, 300, 300);
  const auto T_true = zRotation(1, 90.0, {0.f, 0.f, 0.f});
  const auto tgt = transformPoints(T_true, cloud);
  const auto I = identityTransforms(1, cloud.options());
  TeacherParams p;
  p.icp_iterations = 10;
  p.initial_max_distance = 0.1;
  p.max_distance = 0.05;
  p.match_radius = 1e-3;
  torch::Tensor labels;
  const auto T_plain = teacherLabels(cloud, tgt, I, p, labels);
  ASSERT_GT(maxRotationErrorDeg(T_plain.R, T_true.R), 45.0)
      << "precondition: neither the network's start nor the identity reaches the pose";
  p.start_rotation_deg = 90.0;
  const auto T = teacherLabels(cloud, tgt, I, p, labels);
  EXPECT_LT(maxRotationErrorDeg(T.R, T_true.R), 1e-2);
  EXPECT_TRUE(torch::equal(labels[0], torch::arange(300, torch::kInt64)));
}

TEST(Teacher, PairsBelowTheMinimumFitnessAreNotLabelled) {
  // Pair 0: the same samples (every point labelled); pair 1: a target cropped to the points with
  // x > 0, padded with far points (about half the source labelled).
  const auto cloud = ellipsoidSamples(2, 200, 400);
  auto tgt = cloud.clone();
  tgt[1] = torch::where(cloud[1][0].unsqueeze(0) > 0, cloud[1], torch::full_like(cloud[1], 50.f));
  const auto I = identityTransforms(2, cloud.options());
  TeacherParams p;
  p.icp_iterations = 0;
  p.from_identity = false;
  p.match_radius = 1e-3;
  torch::Tensor labels;
  teacherLabels(cloud, tgt, I, p, labels);
  const double share1 = (labels[1] >= 0).to(torch::kFloat64).mean().item<double>();
  ASSERT_GT(share1, 0.3);
  ASSERT_LT(share1, 0.7);
  p.min_fitness = 0.8;
  teacherLabels(cloud, tgt, I, p, labels);
  EXPECT_EQ((labels[0] >= 0).sum().item<int64_t>(), 200);
  EXPECT_EQ((labels[1] >= 0).sum().item<int64_t>(), 0);
}

TEST(Teacher, SettingsAreReadAndCheckedWithTheirKeys) {
  const auto p = TeacherParams::load(ConfigNode::fromString(
      "point_to_plane: true\nnormal_neighbours: 12\nstart_rotation_deg: 30\nmin_fitness: 0.6\n",
      "t.yaml"));
  EXPECT_TRUE(p.point_to_plane);
  EXPECT_EQ(p.normal_neighbours, 12);
  EXPECT_DOUBLE_EQ(p.start_rotation_deg, 30.0);
  EXPECT_DOUBLE_EQ(p.min_fitness, 0.6);
  for (const char* bad : {"normal_neighbours: 2\n", "start_rotation_deg: 200\n",
                          "min_fitness: 1.5\n", "icp_steps: 3\n"}) {
    try {
      TeacherParams::load(ConfigNode::fromString(bad, "t.yaml"));
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const ConfigError& e) {
      const std::string key = std::string(bad).substr(0, std::string(bad).find(':'));
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(Losses, PoseLabelLossIsTheMeanDistanceOfTheMovedPoints) {
  torch::manual_seed(9);
  const auto src = torch::randn({2, 3, 50});
  const auto I = identityTransforms(2, src.options());
  auto t_label = torch::zeros({2, 3});
  t_label[1][0] = 2.0f;  // pair 1's label is 2 units off, pair 0's exact
  EXPECT_NEAR(poseLabelLoss(I.R, I.t, I.R, t_label, src).item<double>(), 1.0, 1e-5);
  EXPECT_NEAR(poseLabelLoss(I.R, I.t, I.R, I.t, src).item<double>(), 0.0, 1e-5);
}

TEST(Losses, CorrespondenceLossIsTheCrossEntropyOfTheLabelledRows) {
  torch::manual_seed(3);
  const auto lm = torch::log_softmax(torch::randn({2, 3, 4}, torch::kFloat64), 2);
  const auto labels = torch::tensor({1, -1, 3, 0, 2, -1}, torch::kInt64).view({2, 3});
  const double expected = -(lm[0][0][1] + lm[0][2][3] + lm[1][0][0] + lm[1][1][2]).item<double>() / 4;
  EXPECT_NEAR(correspondenceLoss(lm, labels).item<double>(), expected, 1e-12);
  // Standardised (κ > 0): the same for logits scaled up or shifted, so it cannot be lowered by
  // flattening the map; still the cross-entropy of the standardised row.
  const auto z = torch::randn({2, 3, 4}, torch::kFloat64);
  const double c1 = correspondenceLoss(z, labels, 3.0).item<double>();
  EXPECT_NEAR(correspondenceLoss(5.0 * z + 2.0, labels, 3.0).item<double>(), c1, 1e-9);
  EXPECT_GT(std::abs(correspondenceLoss(5.0 * z, labels).item<double>() -
                     correspondenceLoss(z, labels).item<double>()),
            1e-3)
      << "precondition: the raw form does depend on the scale";
  const auto zs = 3.0 * (z - z.mean(2, true)) / (z - z.mean(2, true)).pow(2).mean(2, true).sqrt();
  EXPECT_NEAR(c1, correspondenceLoss(torch::log_softmax(zs, 2), labels).item<double>(), 1e-9);
  // No label: no term (and no division by zero).
  EXPECT_EQ(correspondenceLoss(lm, torch::full({2, 3}, -1, torch::kInt64)).item<double>(), 0.0);
  // A label outside the target is refused.
  EXPECT_THROW(correspondenceLoss(lm, torch::full({2, 3}, 4, torch::kInt64)), ContractError);
  // Its gradient raises the labelled entries only.
  auto logits = torch::zeros({1, 2, 3}, torch::kFloat64).requires_grad_(true);
  correspondenceLoss(torch::log_softmax(logits, 2), torch::tensor({{2, -1}}, torch::kInt64))
      .backward();
  const auto g = logits.grad();
  EXPECT_LT(g[0][0][2].item<double>(), 0.0);
  EXPECT_GT(g[0][0][0].item<double>(), 0.0);
  EXPECT_EQ(g[0][1].abs().sum().item<double>(), 0.0);
}

TEST(TrainingRuns, SelfTrainingAddsTheCorrespondenceTermOfTheTeachersLabels) {
  TrainConfig tc = test::smallTrainConfig();
  tc.model.n_iters = 1;
  tc.pairs_per_epoch = 8;
  tc.epochs = 1;
  tc.match_loss_weight = 2.0;
  tc.teacher.match_radius = 0.2;
  const std::vector<PointCloud> clouds = test::blobClouds(3, 150, 40);
  const std::string dir = test::scratchDir("self_training");
  std::filesystem::remove_all(dir);
  Trainer t(tc, clouds, clouds, dir);
  const auto s = t.run(false);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_GT(s[0].loss_match, 0.0);
  EXPECT_GT(s[0].teacher_labelled, 0.0);
  EXPECT_LE(s[0].teacher_labelled, 1.0);
  EXPECT_NEAR(s[0].loss,
              s[0].loss_global + s[0].loss_neighbor + s[0].loss_spatial + s[0].loss_match,
              1e-3 * std::abs(s[0].loss) + 1e-6);
}

TEST(TrainingRuns, ValidationScoresTheTeachersLabelsAgainstTheTruePose) {
  // Validation pairs whose target is the source itself: ICP from the identity aligns them
  // exactly, so the teacher labels every point with itself. Under the identity as the true pose
  // all those labels are right; under a true pose 5 units away none is. Whatever the weights.
  TrainConfig tc = test::smallTrainConfig();
  tc.match_loss_weight = 1.0;
  tc.teacher.match_radius = 1e-3;
  tc.inlier_radius = 1e-3;
  const std::vector<PointCloud> clouds = test::blobClouds(1, 150, 90);
  const auto val = test::sameCloudPairs(clouds[0]);
  const PairSampler sampler = test::cloudPairSampler(clouds[0], tc.protocol);
  const std::string dir = test::scratchDir("teacher_validation");
  std::filesystem::remove_all(dir);
  Trainer t(tc, sampler, val, dir);
  const auto v = t.validate();
  EXPECT_DOUBLE_EQ(v.teacher_labelled, 1.0);
  EXPECT_DOUBLE_EQ(v.teacher_precision, 0.5);
  EXPECT_LT(v.teacher_mie_r, 1e-2);
  // Without self-training the teacher is not scored.
  tc.match_loss_weight = 0.0;
  Trainer off(tc, sampler, {val[0]}, dir + "/off");
  EXPECT_EQ(off.validate().teacher_labelled, 0.0);
}
