#include "storage/cache/frequency_sketch.h"

#include <algorithm>
#include <bit>

namespace pbgi::storage {

namespace {
constexpr size_t kMinItems = 8;
constexpr uint32_t kCountersPerItem = 8;
constexpr uint64_t kAdditionsPerItem = 10;  // TinyLFU's sample: 10 x the cache's entries
// Odd multipliers, one per row of the count-min sketch.
constexpr uint64_t kSeeds[4] = {0xC3A5C85C97CB3127ull, 0xB492B66FBE98F273ull, 0x9AE16A3B2F90404Full,
                                0xCBF29CE484222325ull};
}  // namespace

FrequencySketch::FrequencySketch(size_t items) { resize(items); }

void FrequencySketch::resize(size_t items) {
  items_ = std::max(items, kMinItems);
  const uint64_t counters = std::bit_ceil(uint64_t(items_) * kCountersPerItem);
  counter_bits_ = uint32_t(std::countr_zero(counters));
  words_.assign(counters / 16, 0);
  sample_size_ = kAdditionsPerItem * items_;
  additions_ = 0;
}

void FrequencySketch::locate(uint64_t hash, uint32_t word[4], uint32_t shift[4]) const {
  for (int i = 0; i < 4; ++i) {
    uint64_t h = (hash + uint64_t(i)) * kSeeds[i];
    h ^= h >> 32;
    const auto counter = uint32_t(h >> (64 - counter_bits_));
    word[i] = counter >> 4;
    shift[i] = (counter & 15u) * 4;
  }
}

uint32_t FrequencySketch::estimate(uint64_t hash) const {
  uint32_t word[4], shift[4];
  locate(hash, word, shift);
  uint32_t least = 15;
  for (int i = 0; i < 4; ++i) least = std::min(least, uint32_t(words_[word[i]] >> shift[i]) & 15u);
  return least;
}

void FrequencySketch::add(uint64_t hash) {
  uint32_t word[4], shift[4];
  locate(hash, word, shift);
  uint32_t least = 15;
  for (int i = 0; i < 4; ++i) least = std::min(least, uint32_t(words_[word[i]] >> shift[i]) & 15u);
  if (least == 15) return;  // saturated: nothing to raise, no sample counted
  for (int i = 0; i < 4; ++i) {
    bool seen = false;  // two rows may share a counter: raised once
    for (int j = 0; j < i; ++j) seen = seen || (word[j] == word[i] && shift[j] == shift[i]);
    if (!seen && (uint32_t(words_[word[i]] >> shift[i]) & 15u) == least) words_[word[i]] += uint64_t(1) << shift[i];
  }
  if (++additions_ >= sample_size_) halve();
}

void FrequencySketch::halve() {
  // Each nibble shifted right by one: the bit shifted in from the nibble
  // above is masked off.
  for (uint64_t& w : words_) w = (w >> 1) & 0x7777777777777777ull;
  additions_ /= 2;
}

}  // namespace pbgi::storage
