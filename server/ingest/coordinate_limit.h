// The coordinates ingest lets through: finite and within
// +-kMaxSceneCoordinate. Everything downstream computes in float, and the
// first thing to overflow is a triangle's area: 0.5 |(b - a) x (c - a)|,
// whose squared length Imath forms in float. With |coordinate| <= B the
// edges are <= 2B, the cross product's components <= 8 B^2 and its squared
// length <= 192 B^4, finite up to B = 1.15e9; 1e9 is the round number below.
// (Draco's quantizer, Embree -- which drops primitives beyond 1.844e18 --
// and bounding-box spans overflow much later.) At 1e9 a float's step is
// 64 units, so nothing a renderer can use is lost.
//
// The scene stream decoder applies the limit to every mesh chunk, refined
// cage and instance placement (server/ingest/scene_stream_decoder.h), and
// .drc scenes apply it too, so that nothing downstream -- the chunk store's
// Draco encoder, areas, BVHs, surfels -- ever sees such values.
#pragma once

#include "server/scene/scene.h"

#include <cmath>
#include <cstddef>

namespace pbgi {

inline constexpr float kMaxSceneCoordinate = 1e9f;

// False for NaN, +-inf and |v| > kMaxSceneCoordinate.
inline bool usable_coordinate(float v) { return std::abs(v) <= kMaxSceneCoordinate; }

template <typename T>  // V2f, V3f, C3f
bool usable_values(const T& v) {
  for (size_t k = 0; k < sizeof(T) / sizeof(float); ++k)
    if (!usable_coordinate(v[k])) return false;
  return true;
}

// What drop_unusable_geometry changed in one range of a soup.
struct UnusableGeometry {
  size_t vertices = 0;   // positions removed (not finite or beyond the limit)
  size_t triangles = 0;  // triangles removed because they used one of them
  size_t uvs = 0;        // uvs made "none" (NaN): infinite or beyond the limit
  size_t colors = 0;     // colours made "none" likewise

  bool any() const { return vertices + uvs + colors > 0; }
};

// Checks the vertices [first_vertex, end) and the triangles [first_index,
// end) of `soup`, whose indices must already be soup-global and in range.
// Triangles using an unusable position are removed and so are those
// positions (every per-vertex array of the soup's size is compacted alike
// and the remaining indices renumbered); uvs and colours that are infinite
// or beyond the limit become NaN, TriangleSoup's "none" (NaN itself is
// "none" already). Per-triangle arrays (material, mesh) are the caller's:
// call this before appending them.
UnusableGeometry drop_unusable_geometry(TriangleSoup& soup, size_t first_vertex, size_t first_index);

}  // namespace pbgi
