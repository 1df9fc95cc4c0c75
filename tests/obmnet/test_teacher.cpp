// Self-training labels (teacher.hpp) and the correspondence term L_c (losses.hpp): ICP that
// recovers a motion, labels that are the nearest target points within the radius, the start of
// better fit chosen per pair, and L_c as the cross-entropy of the labelled rows.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

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
