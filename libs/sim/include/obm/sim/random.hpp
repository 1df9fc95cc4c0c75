#pragma once
/// \file random.hpp
/// Small, fast, platform-independent random numbers for the simulator. The standard library's
/// distributions are implementation-defined (libstdc++ and libc++ give different normals for the
/// same engine state), so a seeded sequence would not be reproducible across toolchains; these are
/// fully specified here: SplitMix64 for seeding and hashing, xoshiro256** for streams, and the
/// Marsaglia polar method for normal deviates.
#include <cmath>
#include <cstdint>

namespace obm::sim {

/// SplitMix64 step (Steele, Lea & Flood 2014): a bijective 64-bit mixer, used to hash seeds.
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Hashes a seed and up to three integers (e.g. frame index, chunk index, stream id) into one
/// 64-bit value, so every independent piece of work gets its own reproducible stream regardless
/// of the order or the thread in which it runs.
inline std::uint64_t hashSeed(std::uint64_t seed, std::uint64_t a = 0, std::uint64_t b = 0,
                              std::uint64_t c = 0) {
  std::uint64_t s = seed;
  std::uint64_t h = splitmix64(s);
  s = h ^ a;
  h = splitmix64(s);
  s = h ^ b;
  h = splitmix64(s);
  s = h ^ c;
  return splitmix64(s);
}

/// xoshiro256** (Blackman & Vigna 2018) with uniform and normal helpers.
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) { reseed(seed); }

  void reseed(std::uint64_t seed) {
    std::uint64_t s = seed;
    for (auto& w : s_) w = splitmix64(s);
    has_spare_ = false;
  }

  /// Next raw 64-bit value.
  std::uint64_t next() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  /// Uniform in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Uniform float in [0, 1) with 24 random bits (cheaper, for per-ray decisions).
  float uniformf() { return static_cast<float>(next() >> 40) * 0x1.0p-24f; }
  /// Uniform integer in [0, n) (n > 0); the modulo bias is below 2⁻³² for n < 2³².
  std::uint64_t index(std::uint64_t n) { return next() % n; }
  /// True with probability p.
  bool bernoulli(double p) { return uniform() < p; }

  /// Standard normal deviate (Marsaglia polar method; the second value of each pair is cached).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double m = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * m;
    has_spare_ = true;
    return u * m;
  }
  /// Normal deviate with the given mean and standard deviation.
  double normal(double mean, double sigma) { return mean + sigma * normal(); }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace obm::sim
