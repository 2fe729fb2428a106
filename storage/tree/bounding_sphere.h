// Bounding spheres of surfel disks and of other spheres. Results are
// conservative in float arithmetic: they are computed in double and the
// radius is rounded up, so "contains" holds for the stored floats.
#pragma once

#include "storage/tree/surfel.h"

#include <Imath/ImathVec.h>

#include <span>

namespace pbgi::tree {

struct Sphere {
  Imath::V3f center{0, 0, 0};
  float radius = 0.f;
};

// Distance from `p` to the farthest point of the disk of surfel `s`.
double farthest_disk_distance(const Imath::V3d& p, const Surfel& s);

// A sphere enclosing every disk of `surfels` (not only their centers):
// centered on the bounding box of the disks, radius to the farthest disk
// point. `surfels` must not be empty.
Sphere sphere_of_disks(std::span<const Surfel> surfels);

// The smallest sphere enclosing spheres a and b.
Sphere merge_spheres(const Sphere& a, const Sphere& b);

}  // namespace pbgi::tree
