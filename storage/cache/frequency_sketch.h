// How often each key was used lately, approximately, in 4 bits a counter:
// the frequency sketch of TinyLFU (Einziger, Friedman & Manes, "TinyLFU: A
// Highly Efficient Cache Admission Policy", ACM ToS 2017). The page cache
// asks it whether a page about to enter is used more often than the page
// it would evict (page_cache.h).
//
// A count-min sketch: each key maps to four counters (one per hash); add()
// raises the smallest of them (conservative update: a counter shared with
// other keys is raised only when this key needs it), estimate() returns
// the smallest. Counters saturate at 15. After 10 additions per counter
// group (sample_size()), every counter is halved: frequencies age, so a
// page used often long ago yields to one used often now.
//
// Not thread-safe (the cache calls it under its mutex). Deterministic: the
// same sequence of calls gives the same estimates on every machine.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pbgi::storage {

class FrequencySketch {
 public:
  // Sized for `items` keys in use at once (at least 8): 8 counters per
  // key, rounded up to a power of two. Resizing forgets every count.
  explicit FrequencySketch(size_t items = 8);
  void resize(size_t items);
  // The items it is sized for (what resize() was given, at least 8).
  size_t items() const { return items_; }

  void add(uint64_t hash);
  // 0..15: how often `hash` was added, lately (never less than the truth
  // since the last halving, halved with it).
  uint32_t estimate(uint64_t hash) const;

  // Bytes of counters held (4 bits each).
  uint64_t bytes() const { return words_.size() * sizeof(uint64_t); }
  // Additions between two halvings.
  uint64_t sample_size() const { return sample_size_; }

 private:
  // The four counters of `hash`: word index and nibble shift of each.
  void locate(uint64_t hash, uint32_t word[4], uint32_t shift[4]) const;
  void halve();

  std::vector<uint64_t> words_;  // 16 counters of 4 bits per word
  uint32_t counter_bits_ = 0;    // log2 of the counter count
  size_t items_ = 0;
  uint64_t sample_size_ = 0;
  uint64_t additions_ = 0;
};

}  // namespace pbgi::storage
