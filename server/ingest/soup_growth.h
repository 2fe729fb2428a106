// How the stream decoder grows a scene's triangle soups, and what that
// costs while it happens: the decoder decides each array's growth itself
// (reserve, by half) so that it can charge the scene's memory before the
// allocation (scene_read_memory.h, docs/memory-budget.md).
//
// Bytes are capacities, as Scene::geometry_bytes() counts them. Not
// thread-safe per soup; pure functions otherwise.
#pragma once

#include "server/scene/scene.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pbgi {

template <typename T>
uint64_t buffer_bytes(const std::vector<T>& v) {
  return uint64_t(v.capacity()) * sizeof(T);
}

// The capacity a vector holding n elements gets: geometric growth by half
// (libstdc++ doubles), so that a soup read whole holds at most half again
// its size.
template <typename T>
size_t grown_capacity(const std::vector<T>& v, size_t n) {
  return n <= v.capacity() ? v.capacity() : std::max(n, v.capacity() + v.capacity() / 2);
}

// Bytes of the buffer growing `v` to n elements allocates (0: it fits).
template <typename T>
uint64_t new_buffer_bytes(const std::vector<T>& v, size_t n) {
  return n <= v.capacity() ? 0 : uint64_t(grown_capacity(v, n)) * sizeof(T);
}

template <typename T>
void grow_to(std::vector<T>& v, size_t n) {
  if (n > v.capacity()) v.reserve(grown_capacity(v, n));
}

// A soup's arrays (capacities), the strings of its mesh paths apart.
uint64_t array_bytes(const TriangleSoup& s);

// The sizes a soup's arrays reach (0: the array stays empty).
struct SoupSizes {
  size_t vertices = 0, normals = 0, uvs = 0, colors = 0;
  size_t indices = 0, triangles = 0;  // mesh and material ids: one per triangle
};

// Bytes of arrays of exactly these sizes.
uint64_t soup_bytes(const SoupSizes& n);

// Grows each array of `s` to hold `n` (grow_to), one after another.
void grow_to(TriangleSoup& s, const SoupSizes& n);

// The most memory held while grow_to(s, n) runs, `now` bytes held before
// it (0: nothing grows). Each array's new buffer exists beside its old one
// until copied, so the peak is one new buffer beside the rest, not all of
// them at once.
uint64_t growth_peak(const TriangleSoup& s, const SoupSizes& n, uint64_t now);

}  // namespace pbgi
