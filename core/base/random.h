// Rng: a small, fast, deterministic random number generator (xoshiro256**
// seeded through splitmix64). Unlike the <random> distributions, its uniform
// and normal variates are the same on every standard library, which the
// planners' bit-for-bit reproducibility needs.
#ifndef RISKPLAN_CORE_BASE_RANDOM_H_
#define RISKPLAN_CORE_BASE_RANDOM_H_

#include <cmath>
#include <cstdint>

#include "core/base/check.h"

namespace riskplan {

class Rng {
 public:
  explicit Rng(uint64_t seed) {
    uint64_t x = seed;
    for (uint64_t& s : state_) s = SplitMix64(&x);
  }

  uint64_t Next() {
    const uint64_t result = Rotl(state_[1] * 5, 7) * 9;
    const uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = Rotl(state_[3], 45);
    return result;
  }

  // Uniform in [0, 1), 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

  // Uniform integer in [0, n). REQUIRES: n > 0.
  uint64_t Below(uint64_t n) {
    RISKPLAN_DCHECK(n > 0);
    return static_cast<uint64_t>(Uniform() * static_cast<double>(n));
  }

  // Standard normal (Box-Muller; the second variate is kept for the next call).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = Uniform();
    while (u <= 0.0) u = Uniform();
    const double v = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u));
    spare_ = r * std::sin(2.0 * 3.14159265358979323846 * v);
    has_spare_ = true;
    return r * std::cos(2.0 * 3.14159265358979323846 * v);
  }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static uint64_t SplitMix64(uint64_t* x) {
    uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

  uint64_t state_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_RANDOM_H_
