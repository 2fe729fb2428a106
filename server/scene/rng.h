// Deterministic random numbers for sampling: a PCG32 generator (O'Neill
// 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good
// Algorithms for Random Number Generation") seeded from a hash of
// (seed, point id, ...). Every shading point, triangle or pixel derives its
// own generator from its identity, so results do not depend on how work
// was split across threads or tiles.
//
// Thread-safety: a Rng is a small value; give each task its own.
#pragma once

#include <cstdint>

namespace pbgi {

// SplitMix64 finalizer (Steele et al. 2014): a bijective 64-bit mixer whose
// output bits all depend on all input bits; used to turn structured ids
// (0, 1, 2, ...) into unrelated seeds.
inline uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// Hash of an ordered list of ids (order matters).
inline uint64_t hash_ids(uint64_t a, uint64_t b) { return mix64(a ^ mix64(b)); }
inline uint64_t hash_ids(uint64_t a, uint64_t b, uint64_t c) { return hash_ids(hash_ids(a, b), c); }
inline uint64_t hash_ids(uint64_t a, uint64_t b, uint64_t c, uint64_t d) {
  return hash_ids(hash_ids(a, b, c), d);
}

class Rng {
 public:
  // `seed` picks the starting state, `stream` the sequence (any value; it is
  // made odd internally as PCG requires).
  explicit Rng(uint64_t seed, uint64_t stream = 0) {
    inc_ = (mix64(stream) << 1u) | 1u;
    state_ = 0u;
    next_u32();
    state_ += mix64(seed);
    next_u32();
  }

  uint32_t next_u32() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
  }

  // Uniform in [0, 1): the top 24 bits, so the result is exactly
  // representable and never rounds up to 1.
  float uniform() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }

 private:
  uint64_t state_ = 0;
  uint64_t inc_ = 1;
};

}  // namespace pbgi
