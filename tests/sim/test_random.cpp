// The simulator's own random numbers: reproducible streams and correct normal statistics.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "obm/sim/random.hpp"

using namespace obm::sim;

TEST(Random, StreamsAreReproducibleAndSeedsIndependent) {
  Rng a(7), b(7), c(8);
  for (int i = 0; i < 100; ++i) {
    const auto x = a.next();
    EXPECT_EQ(x, b.next());
    EXPECT_NE(x, c.next());
  }
  std::set<std::uint64_t> h;
  for (std::uint64_t f = 0; f < 100; ++f)
    for (std::uint64_t k = 0; k < 10; ++k) h.insert(hashSeed(1, 2, f, k));
  EXPECT_EQ(h.size(), 1000u);  // (frame, chunk) pairs get distinct streams
  EXPECT_NE(hashSeed(1, 2, 3), hashSeed(1, 3, 2));
}

TEST(Random, NormalQuantileMatchesKnownValues) {
  EXPECT_NEAR(Rng::normalQuantile(0.5), 0.0, 1e-9);
  EXPECT_NEAR(Rng::normalQuantile(0.975), 1.959963985, 1e-7);
  EXPECT_NEAR(Rng::normalQuantile(0.841344746), 1.0, 1e-6);
  EXPECT_NEAR(Rng::normalQuantile(0.001), -3.090232306, 1e-6);
  EXPECT_NEAR(Rng::normalQuantile(0.3), -Rng::normalQuantile(0.7), 1e-12);
}

TEST(Random, BothNormalGeneratorsHaveUnitVarianceAndNormalTails) {
  for (int fast = 0; fast < 2; ++fast) {
    Rng r(99);
    const int n = 400000;
    double s = 0, s2 = 0, s4 = 0;
    int beyond2 = 0;
    for (int i = 0; i < n; ++i) {
      const double x = fast ? r.normalFast() : r.normal();
      s += x;
      s2 += x * x;
      s4 += x * x * x * x;
      if (std::fabs(x) > 2.0) ++beyond2;
    }
    const double mean = s / n, var = s2 / n - mean * mean;
    EXPECT_NEAR(mean, 0.0, 0.01) << (fast ? "fast" : "polar");
    EXPECT_NEAR(var, 1.0, 0.01) << (fast ? "fast" : "polar");
    EXPECT_NEAR(s4 / n, 3.0, 0.1) << (fast ? "fast" : "polar");  // kurtosis of a normal
    EXPECT_NEAR(beyond2 / double(n), 0.0455, 0.002) << (fast ? "fast" : "polar");  // 2σ tails
  }
}
