// Normal cones: a unit axis and the cosine of the half angle such that every
// normal n below a node has dot(axis, n) >= cos. cos = -1 means the normals
// point every way (the cone is the whole sphere). Results are conservative:
// the half angle is widened by a small epsilon to absorb rounding.
#pragma once

#include "storage/tree/surfel.h"

#include <Imath/ImathVec.h>

#include <span>

namespace pbgi::tree {

struct NormalCone {
  Imath::V3f axis{0, 0, 1};
  float cos_half_angle = -1.f;
  bool is_wide() const { return cos_half_angle <= -1.f; }
};

// A cone around the mean normal of `surfels` (not necessarily the tightest).
NormalCone cone_of_normals(std::span<const Surfel> surfels);

// The smallest cone containing cones a and b (Conty Estevez & Kulla 2018,
// "Importance sampling of many lights with adaptive tree splitting", Alg. 1).
NormalCone merge_cones(const NormalCone& a, const NormalCone& b);

}  // namespace pbgi::tree
