// Coincident coplanar surfaces: two copies of the same wall (a duplicated
// mesh, a second mesh laid over part of the first) are one surface to the
// renderers -- a ray hits one of them -- but a sampler that samples every
// triangle would count the area twice, and the gather would then see twice
// the projected coverage there. The samplers divide the area a sample stands
// for by the number of pieces covering its point (cover()), so the area of
// the union is counted once.
//
// Pieces are coincident when they have the same facing (unit normals within
// kNormalTolerance per component), lie in the same plane (offsets within
// the plane tolerance) and their triangles overlap with positive area
// (neighbours sharing an edge do not). The two faces of a thin wall (opposite
// normals) are not coincident: each is a surface of its own.
//
// Method: pieces are hashed by quantized (normal, plane offset), each under
// every key within the tolerances of its own, so coincident pieces always
// share a key; inside a key, a 2D grid in the plane pairs pieces whose
// bounds overlap, then a separating-axis test keeps those whose triangles
// overlap. Cost about linear in the pieces for ordinary meshes (measured:
// 2M triangles of one plane in ~2 s on 2 cores, against 0.3 s for the
// uniform sampler itself).
//
// Thread-safety: immutable after construction; cover() may be called from
// any thread.
#pragma once

#include "server/scene/scene.h"

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace pbgi {

// A planar convex piece of a triangle (the triangle itself, or its part
// inside a box): the triangle's frame for inside tests, and the piece's
// bounds for pairing.
struct PlanarPiece {
  V3f p0{0.f};                   // the triangle's first vertex
  V3f e1{0.f}, e2{0.f}, n{0.f};  // unit in-plane axes (e1 along p0->p1) and unit normal
  float u1 = 0.f;  // p1 = p0 + u1 e1
  float u2 = 0.f, v2 = 0.f;  // p2 = p0 + u2 e1 + v2 e2
  Box3f bounds;    // of the piece

  // The frame of triangle (a, b, c); false if it is degenerate.
  static bool of_triangle(const V3f& a, const V3f& b, const V3f& c, PlanarPiece* out);
  // Barycentrics (of b and c) of the in-plane coordinates (u, v); true if
  // inside the triangle.
  bool barycentrics(float u, float v, float& b1, float& b2) const {
    b2 = v / v2;
    b1 = (u - u2 * b2) / u1;
    return b1 >= 0.f && b2 >= 0.f && b1 + b2 <= 1.f;
  }
};

class CoincidentCover {
 public:
  static constexpr float kNormalTolerance = 1e-3f;
  // A point is inside another piece when its barycentrics there all exceed
  // this, so points on the shared edge of two adjacent triangles of one
  // mesh are not counted twice.
  static constexpr float kInsideMargin = 1e-5f;

  // Piece i of `count` into *out; false for a piece to leave out (empty,
  // degenerate). Called at most twice per piece, from the constructor.
  using PieceFn = std::function<bool(uint32_t i, PlanarPiece* out)>;

  CoincidentCover() = default;
  // `centre`: a point near the pieces (plane offsets are measured from it,
  // to keep them precise); `plane_tolerance`: how far apart two planes may
  // be and still be one (world units, > 0). Memory: 16 bytes per piece
  // while constructing; afterwards only the coincident pieces are kept.
  CoincidentCover(uint32_t count, const PieceFn& piece, const V3f& centre, float plane_tolerance);

  // True if some pieces are coincident.
  bool any() const { return !pairs_.empty(); }
  // How many pieces cover point p of piece i (p inside piece i): 1 + the
  // coincident partners of i that contain p.
  uint32_t cover(uint32_t i, const V3f& p) const;

 private:
  std::vector<std::pair<uint32_t, uint32_t>> pairs_;     // both directions, sorted
  std::vector<std::pair<uint32_t, PlanarPiece>> frames_;  // of the paired pieces, by index
};

}  // namespace pbgi
