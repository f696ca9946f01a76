// Mix64: scrambles a 64-bit key so that its low bits depend on all of its
// bits, for hash tables indexed by `Mix64(key) & mask` (the CPU kernel's site
// cache, the caching risk evaluator).
//
// The constants are fixed, not seeded: the tables' slots, and so which
// entries collide and which are kept, must come out the same on every run and
// every machine.
#ifndef RISKPLAN_CORE_BASE_HASH_MIX_H_
#define RISKPLAN_CORE_BASE_HASH_MIX_H_

#include <cstdint>

namespace riskplan {

// A bijection on 64-bit values (xor-shifts and odd multipliers, after
// SplitMix64's finaliser with other shifts and constants).
constexpr uint64_t Mix64(uint64_t key) {
  key ^= key >> 31;
  key *= 0x7fb5d329728ea185ULL;
  key ^= key >> 27;
  key *= 0x81dadef4bc2dd44dULL;
  return key ^ (key >> 33);
}

}  // namespace riskplan

#endif  // RISKPLAN_CORE_BASE_HASH_MIX_H_
