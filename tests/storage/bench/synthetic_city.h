// A synthetic surfel source of any size for the out-of-core benchmarks and
// tests: a city of box buildings on a ground plane, every face covered by
// a jittered grid of surfels at one spacing, shaded by a sun and a sky
// (cosine falloff, no shadows) with emissive window bands. Surfels come in
// generation order (face by face, as a sampler over meshes would produce
// them), batch by batch, so nothing proportional to the count is held.
#pragma once

#include "storage/tree/surfel.h"

#include <Imath/ImathBox.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <span>
#include <vector>

namespace pbgi::test {

class SyntheticCity {
 public:
  // About `target_surfels` surfels over `blocks` x `blocks` buildings.
  SyntheticCity(uint64_t target_surfels, uint32_t blocks = 64, uint32_t seed = 1) : seed_(seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const float cell = 10.f, size = 10.f * float(blocks);
    add_face({0, 0, 0}, {size, 0, 0}, {0, size, 0}, {0.35f, 0.35f, 0.33f}, false);  // ground
    for (uint32_t i = 0; i < blocks; ++i) {
      for (uint32_t j = 0; j < blocks; ++j) {
        const float w = 4.f + 4.f * u(rng), d = 4.f + 4.f * u(rng), h = 3.f + 40.f * u(rng) * u(rng);
        const Imath::V3f o(cell * float(i) + 1.f, cell * float(j) + 1.f, 0.f);
        const Imath::C3f wall(0.3f + 0.5f * u(rng), 0.3f + 0.4f * u(rng), 0.3f + 0.3f * u(rng));
        add_face(o + Imath::V3f(0, 0, h), {w, 0, 0}, {0, d, 0}, {0.5f, 0.5f, 0.5f}, false);  // roof
        add_face(o, {w, 0, 0}, {0, 0, h}, wall, true);                                       // -y
        add_face(o + Imath::V3f(w, 0, 0), {0, d, 0}, {0, 0, h}, wall, true);                 // +x
        add_face(o + Imath::V3f(w, d, 0), {-w, 0, 0}, {0, 0, h}, wall, true);                // +y
        add_face(o + Imath::V3f(0, d, 0), {0, -d, 0}, {0, 0, h}, wall, true);                // -x
      }
    }
    double area = 0;
    for (const Face& f : faces_) area += f.a.cross(f.b).length();
    spacing_ = float(std::sqrt(area / double(std::max<uint64_t>(target_surfels, 1))));
    for (Face& f : faces_) {
      f.nu = std::max<uint32_t>(1, uint32_t(std::lround(f.a.length() / spacing_)));
      f.nv = std::max<uint32_t>(1, uint32_t(std::lround(f.b.length() / spacing_)));
      count_ += uint64_t(f.nu) * f.nv;
    }
    bounds_.extendBy(Imath::V3f(0, 0, 0));
    bounds_.extendBy(Imath::V3f(size, size, 50.f));
  }

  uint64_t count() const { return count_; }
  float spacing() const { return spacing_; }
  const Imath::Box3f& bounds() const { return bounds_; }
  float size() const { return bounds_.max.x; }

  // Calls `sink` with batches of at most `batch` surfels, in order.
  void generate(size_t batch, const std::function<void(std::span<const Surfel>)>& sink) const {
    std::vector<Surfel> out;
    out.reserve(batch);
    const Imath::V3f sun = Imath::V3f(0.4f, 0.3f, 0.85f).normalized();
    uint64_t index = 0;
    for (const Face& f : faces_) {
      const Imath::V3f n = f.a.cross(f.b).normalized();
      const float cell_area = f.a.cross(f.b).length() / float(uint64_t(f.nu) * f.nv);
      const float radius = std::sqrt(cell_area / 3.14159265f);
      for (uint32_t j = 0; j < f.nv; ++j) {
        for (uint32_t i = 0; i < f.nu; ++i, ++index) {
          const uint64_t h = mix(index ^ (uint64_t(seed_) << 40));
          const float ju = float(h & 0xffff) / 65536.f, jv = float((h >> 16) & 0xffff) / 65536.f;
          Surfel s;
          const float fu = (float(i) + ju) / float(f.nu), fv = (float(j) + jv) / float(f.nv);
          s.position = f.origin + fu * f.a + fv * f.b;
          s.normal = n;
          s.radius = radius;
          s.albedo = f.albedo;
          // Window bands on walls: every third storey glows.
          const bool window = f.wall && std::fmod(s.position.z, 3.f) > 1.2f && std::fmod(s.position.z, 3.f) < 2.f &&
                              ((h >> 32) & 7) == 0;
          s.emission = window ? Imath::C3f(4.f, 3.2f, 2.f) : Imath::C3f(0.f);
          const float e = 3.f * std::max(0.f, n.dot(sun)) + 0.3f * (0.5f + 0.5f * n.z);
          s.radiance = s.emission + s.albedo * e;
          out.push_back(s);
          if (out.size() == batch) {
            sink(out);
            out.clear();
          }
        }
      }
    }
    if (!out.empty()) sink(out);
  }

 private:
  struct Face {
    Imath::V3f origin, a, b;  // the parallelogram origin + [0,1]a + [0,1]b, normal a x b
    Imath::C3f albedo;
    bool wall = false;
    uint32_t nu = 1, nv = 1;
  };
  void add_face(const Imath::V3f& o, const Imath::V3f& a, const Imath::V3f& b, const Imath::C3f& albedo,
                bool wall) {
    faces_.push_back({o, a, b, albedo, wall});
  }
  static uint64_t mix(uint64_t x) {
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
  }

  uint32_t seed_;
  std::vector<Face> faces_;
  float spacing_ = 1.f;
  uint64_t count_ = 0;
  Imath::Box3f bounds_;
};

}  // namespace pbgi::test
