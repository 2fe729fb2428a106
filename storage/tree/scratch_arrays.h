// Per-thread scratch arrays that page decoding reuses from page to page (a
// page cache miss decodes one page; allocating its temporaries anew was a
// tenth of a small page's load). They keep what a typical page needs, not
// what the largest one did.
#pragma once

#include <cstddef>
#include <vector>

namespace pbgi::tree {

// Bytes a scratch array keeps between pages.
inline constexpr size_t kScratchKeepBytes = size_t(256) << 10;

// Frees `v`'s memory when its capacity exceeds kScratchKeepBytes.
template <class T>
void trim_scratch(std::vector<T>& v) {
  if (v.capacity() * sizeof(T) > kScratchKeepBytes) std::vector<T>().swap(v);
}

}  // namespace pbgi::tree
