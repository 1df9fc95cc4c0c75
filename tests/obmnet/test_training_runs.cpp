// Whole training runs of the small trainer: a run interrupted after an epoch and resumed ends on
// the very weights of the uninterrupted run, and the self-supervised pose-label term.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/obmnet/trainer.hpp"
#include "small_training.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

TrainConfig twoEpochConfig() {
  TrainConfig tc = test::smallTrainConfig();
  tc.model.n_iters = 1;
  tc.val_pairs = 2;
  tc.pairs_per_epoch = 8;
  tc.epochs = 2;
  return tc;
}

}  // namespace

TEST(TrainingRuns, ResumedRunIsBitIdenticalToTheUninterruptedOne) {
  const TrainConfig tc = twoEpochConfig();
  const std::vector<PointCloud> clouds = test::blobClouds(3, 150, 70);
  const std::string dir = test::scratchDir("resume_identical");
  std::filesystem::remove_all(dir);
  // Straight through: two epochs.
  std::vector<float> straight;
  {
    Trainer t(tc, clouds, clouds, dir + "/straight");
    ASSERT_EQ(t.run(false).size(), 2u);
    straight = t.parameterVector();
  }
  // Stopped after epoch 1 (a new process would start from the checkpoint alone), then resumed.
  {
    TrainConfig one = tc;
    one.epochs = 1;
    Trainer t(one, clouds, clouds, dir + "/resumed");
    ASSERT_EQ(t.run(false).size(), 1u);
  }
  Trainer t(tc, clouds, clouds, dir + "/resumed");
  const auto s = t.run(true);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].epoch, 2);
  const auto resumed = t.parameterVector();
  ASSERT_EQ(resumed.size(), straight.size());
  EXPECT_EQ(resumed, straight) << "a resumed run must continue bit-identically";
}

TEST(TrainingRuns, PoseLabelTermNeedsLabelsAndEntersTheLoss) {
  TrainConfig tc = twoEpochConfig();
  tc.epochs = 1;
  tc.pose_loss_weight = 5.0;
  const std::vector<PointCloud> clouds = test::blobClouds(3, 150, 80);
  const std::string dir = test::scratchDir("pose_label_term");
  std::filesystem::remove_all(dir);
  // Object pairs have ground truth and no label: asking for L_p is a configuration error.
  {
    Trainer t(tc, clouds, clouds, dir + "/unlabelled");
    EXPECT_THROW(t.run(false), ConfigError);
  }
  // Labelled pairs (here the synthetic motion, standing in for a mapping trajectory).
  const auto protocol = tc.protocol;
  PairSampler labelled = [clouds, protocol](std::mt19937_64& rng, int) {
    auto p = makePair(clouds[0], protocol, rng);
    p.has_pose_label = true;
    p.T_target_source_label = p.T_target_source;
    return p;
  };
  std::mt19937_64 vr(5);
  std::vector<RegistrationPair> val{makePair(clouds[1], protocol, vr)};
  Trainer t(tc, labelled, val, dir + "/labelled");
  const auto s = t.run(false);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_GT(s[0].loss_pose, 0.0);
  EXPECT_NEAR(s[0].loss, s[0].loss_global + s[0].loss_neighbor + s[0].loss_spatial + s[0].loss_pose,
              1e-3 * std::abs(s[0].loss) + 1e-6);
}

TEST(TrainingRuns, ValidationInlierRatioScoresTheMatchesAgainstTheTruePose) {
  // Two validation pairs whose target is the source itself. Without overlap sampling the two
  // clouds then have equal features, so every point's most probable match is itself: all inliers
  // under the identity as the true pose, none under a true pose 5 units away. The mean is 0.5
  // whatever the weights, which checks the metric and its point order, not the model.
  TrainConfig tc = twoEpochConfig();
  tc.model.use_overlap_sampling = false;
  tc.model.use_bias_prediction = false;
  tc.inlier_radius = 1e-3;
  const std::vector<PointCloud> clouds = test::blobClouds(1, 150, 90);
  const auto val = test::sameCloudPairs(clouds[0]);
  const PairSampler sampler = test::cloudPairSampler(clouds[0], tc.protocol);
  const std::string dir = test::scratchDir("inlier_ratio");
  std::filesystem::remove_all(dir);
  Trainer t(tc, sampler, val, dir);
  EXPECT_DOUBLE_EQ(t.validate().inlier_ratio, 0.5);
  Trainer only_same(tc, sampler, {val[0]}, dir + "/same");
  EXPECT_DOUBLE_EQ(only_same.validate().inlier_ratio, 1.0);
}
