// Deterministic random surfels for the storage tests: clustered positions
// (so the tree has both dense and sparse regions), random unit normals,
// radii spanning an order of magnitude, random colors.
#pragma once

#include "storage/tree/surfel.h"

#include <cmath>
#include <random>
#include <vector>

namespace pbgi::test {

inline std::vector<Surfel> random_surfels(size_t n, uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> g(0.f, 1.f);
  std::vector<Imath::V3f> clusters;
  for (int i = 0; i < 8; ++i) clusters.emplace_back(10 * u(rng) - 5, 10 * u(rng) - 5, 10 * u(rng) - 5);
  std::vector<Surfel> out(n);
  for (auto& s : out) {
    const Imath::V3f& c = clusters[rng() % clusters.size()];
    const float spread = 0.2f + 2.f * u(rng);
    s.position = c + spread * Imath::V3f(g(rng), g(rng), g(rng));
    Imath::V3f nrm(g(rng), g(rng), g(rng));
    while (nrm.length() < 1e-3f) nrm = Imath::V3f(g(rng), g(rng), g(rng));
    s.normal = nrm.normalized();
    s.radius = 0.005f + 0.05f * u(rng);
    s.albedo = Imath::C3f(u(rng), u(rng), u(rng));
    s.emission = u(rng) < 0.1f ? Imath::C3f(5 * u(rng), 5 * u(rng), 5 * u(rng)) : Imath::C3f(0.f);
    s.radiance = s.emission + Imath::C3f(u(rng), u(rng), u(rng));
  }
  return out;
}

inline bool same_surfel(const Surfel& a, const Surfel& b) {
  return a.position == b.position && a.normal == b.normal && a.radius == b.radius &&
         a.albedo == b.albedo && a.emission == b.emission && a.radiance == b.radiance &&
         a.gloss.alpha == b.gloss.alpha && a.gloss.f0 == b.gloss.f0;
}

}  // namespace pbgi::test
