#include "server/scene/surface_opacity.h"

#include "server/scene/texture.h"

#include <algorithm>
#include <cmath>

namespace pbgi {

bool has_opacity(const Material& m) { return m.opacity < 1.f || m.opacity_texture.bound(); }

float soup_opacity(const TriangleSoup& soup, const Material& m, uint32_t triangle, float u, float v) {
  float opacity = m.opacity;
  if (m.opacity_texture.bound()) {
    const uint32_t* c = &soup.indices[3 * size_t(triangle)];
    V2f st(0.f, 0.f);
    bool have_st = false;
    if (!soup.uvs.empty()) {
      st = (1.f - u - v) * soup.uvs[c[0]] + u * soup.uvs[c[1]] + v * soup.uvs[c[2]];
      have_st = std::isfinite(st.x) && std::isfinite(st.y);
    }
    const TextureBinding& b = m.opacity_texture;
    opacity = (b.uses_uvs && !have_st ? evaluate_texture_mean(b) : evaluate_texture(b, st)).x;
  }
  return std::isfinite(opacity) ? std::clamp(opacity, 0.f, 1.f) : 1.f;
}

bool surface_present(const Material& m, float opacity, uint32_t ray_hash) {
  if (m.opacity_threshold > 0.f) return opacity >= m.opacity_threshold;
  if (opacity >= 1.f) return true;
  // The top 24 bits as a uniform number in [0, 1).
  return float(ray_hash >> 8) * 0x1p-24f < opacity;
}

float surface_coverage(const Scene& scene, uint32_t triangle, float b1, float b2) {
  const TriangleRef r = scene.triangle(triangle);
  const Material& m = scene.materials[r.material()];
  if (!has_opacity(m)) return 1.f;
  // Back to the soup's order: a mirroring instance swaps corners 1 and 2.
  const bool swapped = r.instance && r.instance->mirrored;
  const float opacity = soup_opacity(*r.soup, m, r.index, swapped ? b2 : b1, swapped ? b1 : b2);
  if (m.opacity_threshold > 0.f) return opacity >= m.opacity_threshold ? 1.f : 0.f;
  return opacity;
}

}  // namespace pbgi
