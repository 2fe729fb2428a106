// Coincident coplanar copies split across triangle ranges (triangle_ranges.h):
// two instances of one floor placed on top of each other, or an instance
// laid over world geometry. The per-range covers (coincident_surfaces.h,
// built once per soup in its own space) cannot see them: each copy lives in
// a range of its own.
//
// Only triangles lying where two ranges overlap can be such copies, so the
// cover is built in world space over those alone: the ranges' world bounds
// (an instance's from its prototype's, transformed) are put in a grid
// together with the world soup's triangles; a triangle is a candidate when
// its bounds (widened by the plane tolerance) meet the bounds of another
// range (an instance's box, or a world triangle). Memory follows the
// candidates, not the instanced triangle count (a city's buildings standing
// apart on a ground add only the triangles touching the ground).
//
// Cost: the world soup's triangles and every instance whose bounds meet
// another range's are tested triangle by triangle against the grid (in
// parallel); a scene of buildings standing on a ground mesh tests every
// building's triangles. Not measured on the large city scenes.
//
// cover() counts every piece containing a point, whatever its range. A
// point covered by pieces of two or more ranges has all of them among the
// candidates (each contains the point, which lies in both ranges' bounds);
// a point covered within one range only may miss some, which that range's
// own cover counts. The sampler therefore takes the larger of the two.
//
// Thread-safety: immutable after construction; cover() may be called from
// any thread.
#pragma once

#include "server/scene/scene.h"
#include "server/surfels/coincident_surfaces.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace pbgi {

class CrossRangeCover {
 public:
  CrossRangeCover() = default;
  // `centre` and `plane_tolerance` as CoincidentCover's (world space).
  CrossRangeCover(const Scene& scene, const V3f& centre, float plane_tolerance);

  // True if pieces of different ranges (or of one range, among the
  // candidates) are coincident.
  bool any() const { return cover_.any(); }
  // How many candidate pieces contain world point p of triangle j of range
  // r (triangle_range()); 0 when the triangle is not a candidate.
  uint32_t cover(size_t range, uint32_t j, const V3f& p) const;
  // Candidate pieces (for tests and logs).
  size_t candidates() const { return index_.size(); }

 private:
  CoincidentCover cover_;
  // (range << 32 | triangle) -> candidate index, sorted by key.
  std::vector<std::pair<uint64_t, uint32_t>> index_;
};

}  // namespace pbgi
