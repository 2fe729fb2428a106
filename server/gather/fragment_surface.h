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
#include <cstdint>
#include <vector>

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

// Two known surfaces share an index of a SurfaceTable only when their
// normals are within this cosine (2.6 degrees) and their planes within the
// smaller tolerance: a fragment is then tested with a plane that is its own
// to within its tolerance. With kSameSurfaceCos instead, a fragment of a
// curved surface took a plane up to 25 degrees off its own (0.18 m off at
// 3 m on a sphere, beyond the tolerance), and pieces of the sphere around
// a receiver at its center were hidden as lying behind each other (1.2%
// of the irradiance lost, GlossyGather.UniformSphereReflectsTheLobesAlbedo).
inline constexpr float kSameIndexCos = 0.999f;

inline bool same_index_surface(const FragmentSurface& a, const FragmentSurface& b) {
  return a.n.dot(b.n) > kSameIndexCos && std::abs(a.plane - b.plane) <= std::min(a.tolerance, b.tolerance);
}

// The same for two surfaces known to be known.
inline bool same_known_surface(const FragmentSurface& a, const FragmentSurface& b) {
  return a.n.dot(b.n) > kSameSurfaceCos && std::abs(a.plane - b.plane) <= std::max(a.tolerance, b.tolerance);
}

inline bool same_surface(const FragmentSurface& a, const FragmentSurface& b) {
  if (!a.known() || !b.known()) return true;
  return same_known_surface(a, b);
}

// Where the ray along unit `dir` meets a known surface's plane, kept within
// the depths [near / grow, far * grow] its fragments span (a ray nearly
// parallel to the plane meets it anywhere); `near` for an unknown surface
// or a plane the ray does not meet from its front.
inline float surface_depth(const FragmentSurface& s, const Imath::V3f& dir, float near, float far, float grow) {
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

// A surface registered in a buffer's SurfaceTable; 0 is the unknown one.
struct SurfaceId {
  uint32_t index = 0;
};

// The surfaces a buffer's fragments lie on, for one receiver (or one far
// buffer). Fragments hold an index into it rather than the plane: they
// stay small (a pixel's list is copied and sorted at every resolve), and
// the common test, whether a fragment lies on the surface of the one
// before it in its pixel, is an integer comparison. add() gives a surface
// the index of one of the last kRecent registered when the two are one
// (same_index_surface, stricter than same_surface): neighbouring splats of
// a wall arrive close together from the walk (interleaved with those of
// the floor it meets, hence more than one recent index), and their
// fragments then compare by index. An index stands for the plane first
// registered under it, with the smallest tolerance given it.
class SurfaceTable {
 public:
  static constexpr uint32_t kRecent = 16;

  void clear() {
    planes_.resize(1);
    for (uint32_t& r : recent_) r = 0;
  }
  SurfaceId add(const FragmentSurface& s) {
    if (!s.known()) return {};
    for (uint32_t i = 0; i < kRecent && recent_[i] != 0; ++i) {
      const uint32_t r = recent_[i];
      if (same_index_surface(planes_[r], s)) {
        // The index keeps the tightest tolerance given it: a far splat's
        // (1% of its distance) must not loosen a near one's test.
        planes_[r].tolerance = std::min(planes_[r].tolerance, s.tolerance);
        // Most recent first.
        for (uint32_t j = i; j > 0; --j) recent_[j] = recent_[j - 1];
        recent_[0] = r;
        return {r};
      }
    }
    planes_.push_back(s);
    for (uint32_t j = kRecent - 1; j > 0; --j) recent_[j] = recent_[j - 1];
    recent_[0] = uint32_t(planes_.size() - 1);
    return {recent_[0]};
  }
  const FragmentSurface& operator[](uint32_t i) const { return planes_[i]; }
  // same_surface() of two indices.
  bool same(uint32_t a, uint32_t b) const {
    return a == b || a == 0 || b == 0 || same_known_surface(planes_[a], planes_[b]);
  }

 private:
  std::vector<FragmentSurface> planes_{FragmentSurface{}};
  uint32_t recent_[kRecent] = {};
};

}  // namespace pbgi::gather
