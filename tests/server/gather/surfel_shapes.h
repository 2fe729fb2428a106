// Test helper: surfel samplings of simple shapes with exact total area
// (each surfel's disk has the area it stands for, as the real sampler
// makes them), evenly spread so that the gather sees closed surfaces.
#pragma once

#include "storage/tree/surfel.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <vector>

namespace pbgi::test {

// Disk of radius R around `center` facing `normal`, `count` surfels on a
// Vogel (sunflower) spiral, each of area pi R^2 / count.
void add_disk(std::vector<Surfel>& out, const Imath::V3f& center, const Imath::V3f& normal,
              float radius, uint32_t count, const Imath::C3f& radiance);

// Parallelogram corner + a*u + b*v (a, b in [0,1]) on an nu x nv grid of
// cell centers; normal = normalize(u x v) unless `flip`.
void add_quad(std::vector<Surfel>& out, const Imath::V3f& corner, const Imath::V3f& u,
              const Imath::V3f& v, uint32_t nu, uint32_t nv, const Imath::C3f& radiance,
              bool flip = false);

// Sphere facing outwards, `count` surfels on a Fibonacci lattice.
void add_sphere(std::vector<Surfel>& out, const Imath::V3f& center, float radius, uint32_t count,
                const Imath::C3f& radiance);

// An axis-aligned box room [0,size]^3 seen from inside (normals inwards)
// with an emissive ceiling patch and two blocks on the floor: a small
// closed scene with occlusion, for benchmarks. About `target` surfels.
std::vector<Surfel> box_room(float size, uint32_t target);

}  // namespace pbgi::test
