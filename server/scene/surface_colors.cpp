#include "server/scene/surface_colors.h"

#include "server/scene/texture.h"

#include <cmath>

namespace pbgi {
namespace {

bool finite(const V2f& v) { return std::isfinite(v.x) && std::isfinite(v.y); }
bool finite(const C3f& c) { return std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z); }

// The footprint in st units: world width times the square root of the
// triangle's st-area per world-area (its mean texture stretch).
float st_footprint(const TriangleRef& r, const std::array<uint32_t, 3>& idx, float footprint) {
  if (!(footprint > 0.f)) return 0.f;
  const TriangleSoup& t = *r.soup;
  const V3f p0 = r.position(0);
  const float world = (r.position(1) - p0).cross(r.position(2) - p0).length();
  const V2f e1 = t.uvs[idx[1]] - t.uvs[idx[0]], e2 = t.uvs[idx[2]] - t.uvs[idx[0]];
  const float st = std::fabs(e1.x * e2.y - e1.y * e2.x);
  if (!(world > 0.f)) return 0.f;
  return footprint * std::sqrt(st / world);
}

C3f clamp_negative(const C3f& c) { return C3f(std::fmax(c.x, 0.f), std::fmax(c.y, 0.f), std::fmax(c.z, 0.f)); }

C3f evaluate(const TextureBinding& binding, bool have_st, const V2f& st, float st_width) {
  if (binding.uses_uvs && !have_st) return evaluate_texture_mean(binding);
  return evaluate_texture(binding, st, st_width);
}

}  // namespace

bool has_varying_colors(const Material& m) {
  return m.albedo_texture.bound() || m.emission_texture.bound() || m.albedo_from_vertex_colors;
}

SurfaceColors surface_colors(const Scene& scene, uint32_t triangle, float b1, float b2,
                             float footprint) {
  const TriangleRef r = scene.triangle(triangle);
  const Material& m = scene.materials[r.material()];
  SurfaceColors out{m.albedo, m.emission};
  if (!has_varying_colors(m)) return out;

  const TriangleSoup& t = *r.soup;
  const std::array<uint32_t, 3> idx = r.corners();
  const float b0 = 1.f - b1 - b2;

  if (m.albedo_from_vertex_colors && !t.colors.empty()) {
    const C3f c = b0 * t.colors[idx[0]] + b1 * t.colors[idx[1]] + b2 * t.colors[idx[2]];
    if (finite(c)) out.albedo = c;
  }
  if (!m.albedo_texture.bound() && !m.emission_texture.bound()) return out;

  bool have_st = false;
  V2f st(0.f, 0.f);
  float st_width = 0.f;
  if (!t.uvs.empty()) {
    st = b0 * t.uvs[idx[0]] + b1 * t.uvs[idx[1]] + b2 * t.uvs[idx[2]];
    have_st = finite(st);
    if (have_st) st_width = st_footprint(r, idx, footprint);
  }
  // A bias or a filtered HDR texel may go below zero: no negative light.
  if (m.albedo_texture.bound())
    out.albedo = clamp_negative(evaluate(m.albedo_texture, have_st, st, st_width));
  if (m.emission_texture.bound())
    out.emission = clamp_negative(evaluate(m.emission_texture, have_st, st, st_width));
  return out;
}

}  // namespace pbgi
