// AUROC of a confidence score as a detector of correct registrations.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "obm/eval/statistics.hpp"

using obm::eval::auroc;

TEST(Auroc, PerfectSeparationIsOneAndReversedIsZero) {
  EXPECT_DOUBLE_EQ(auroc({0.9, 0.8, 0.2, 0.1}, {true, true, false, false}), 1.0);
  EXPECT_DOUBLE_EQ(auroc({0.1, 0.2, 0.8, 0.9}, {true, true, false, false}), 0.0);
}

TEST(Auroc, TiesCountOneHalf) {
  // Every positive ties with every negative: chance.
  EXPECT_DOUBLE_EQ(auroc({0.5, 0.5, 0.5}, {true, false, false}), 0.5);
  // Positives {3, 1}, negatives {2, 1}: pairs (3>2) (3>1) (1<2) (1=1) → (1 + 1 + 0 + 0.5) / 4.
  EXPECT_DOUBLE_EQ(auroc({3.0, 1.0, 2.0, 1.0}, {true, true, false, false}), 0.625);
}

TEST(Auroc, MatchesTheDefinitionOnAnUnsortedMix) {
  const std::vector<double> s{0.3, 0.7, 0.1, 0.9, 0.4, 0.6, 0.2};
  const std::vector<bool> y{false, true, false, true, true, false, false};
  double wins = 0, pairs = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (std::size_t j = 0; j < s.size(); ++j)
      if (y[i] && !y[j]) {
        pairs += 1;
        wins += s[i] > s[j] ? 1.0 : s[i] == s[j] ? 0.5 : 0.0;
      }
  EXPECT_DOUBLE_EQ(auroc(s, y), wins / pairs);
}

TEST(Auroc, OneClassIsNaNAndSizesMustAgree) {
  EXPECT_TRUE(std::isnan(auroc({0.1, 0.2}, {true, true})));
  EXPECT_THROW(auroc({0.1, 0.2}, {true}), std::invalid_argument);
}
