// The surface a microbuffer fragment lies on, when the gather knows it, and
// the tests the compositing rule makes with it (microbuffer.h, rule 3;
// far_field.h): whether two fragments lie on one surface, where the
// pixel's ray meets a surface, and whether a point lies behind one.
//
// A depth cluster (fragments within the depth band of each other) may
// hold pieces of several surfaces: a floor and a wall meeting in a corner
// (side by side: their coverages add), or a wall and the ground just
// behind its foot (one hides the other). Knowing each fragment's plane
// tells the two apart.
//
// Thread-safety: plain values and pure functions.
#pragma once

#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

// The unit normal `n` facing the receiver, the plane's offset
// `plane` = n . (point - receiver) (< 0 in front of it) and how far off that
// plane pieces of the same surface may lie (`tolerance`, same units). A zero
// normal means unknown (wide-cone nodes, fog): such a fragment goes with
// any surface.
struct FragmentSurface {
  Imath::V3f n{0, 0, 0};
  float plane = 0.f;
  float tolerance = 0.f;

  bool known() const { return n.x != 0.f || n.y != 0.f || n.z != 0.f; }
};

// Two known surfaces are one when their normals are within this cosine (25
// degrees) and their planes within either's tolerance.
inline constexpr float kSameSurfaceCos = 0.906f;

inline bool same_surface(const FragmentSurface& a, const FragmentSurface& b) {
  if (!a.known() || !b.known()) return true;
  return a.n.dot(b.n) > kSameSurfaceCos && std::abs(a.plane - b.plane) <= std::max(a.tolerance, b.tolerance);
}

// Where the ray along unit `dir` meets a known surface's plane, kept within
// the depths [near / grow, far * grow] its fragments span (a ray nearly
// parallel to the plane meets it anywhere); `near` for an unknown surface
// or a plane the ray does not meet from its front.
inline float surface_depth(const FragmentSurface& s, const Imath::V3f& dir, float near, float far,
                           float grow) {
  if (!s.known()) return near;
  const float dn = s.n.dot(dir);
  if (!(dn < 0.f)) return near;
  return std::clamp(s.plane / dn, near / grow, far * grow);
}

// Whether point x (relative to the receiver) lies behind a known surface's
// plane by more than its tolerance.
inline bool lies_behind(const FragmentSurface& s, const Imath::V3f& x) {
  return s.known() && s.n.dot(x) - s.plane < -s.tolerance;
}

}  // namespace pbgi::gather
