#include "server/surfels/glossy_shading.h"

#include "server/scene/brdf.h"
#include "server/scene/direct_lighting.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "storage/tree/page_records.h"

#include <bit>
#include <cstring>
#include <vector>

namespace pbgi {

namespace {
constexpr uint64_t kGlossDomain = 0x676c6f7373ull;  // "gloss"

uint64_t position_id(const V3f& p) {
  uint32_t b[3];
  std::memcpy(b, &p, sizeof(b));
  return hash_ids(b[0], b[1], b[2]);
}
}  // namespace

SceneGlossyShader::SceneGlossyShader(const RayScene& rays, uint32_t light_samples, uint64_t seed,
                                     uint32_t lobe_samples)
    : rays_(rays), light_samples_(light_samples), seed_(seed), lobe_samples_(std::max(lobe_samples, 1u)) {}

void SceneGlossyShader::add_lobe(const Surfel& s, const SurfelGloss& g, const storage::CubeLayout& layout,
                                 float weight, std::span<float> cube) const {
  const uint64_t id = hash_ids(seed_, kGlossDomain, position_id(s.position));
  thread_local std::vector<IncidentSample> light;
  const V3f lit = s.position + s.normal * (storage::kDecodedPositionSlack * s.radius);
  incident_light(rays_, lit, s.normal, light_samples_, id, light);
  if (light.empty()) return;
  BrdfLobes lobes;
  lobes.f0 = g.f0;
  lobes.alpha = std::max(g.alpha, kMinGgxAlpha);
  lobes.specular = true;
  const Brdf brdf(lobes, s.normal);
  Rng rng(id, 1);
  // lobe_samples_ directions in all, shared among the light samples (an
  // area light's 16 samples already spread the lobe).
  const uint32_t m = std::max<uint32_t>(1, (lobe_samples_ + uint32_t(light.size()) - 1) / uint32_t(light.size()));
  const float inv_m = weight / static_cast<float>(m);
  for (const IncidentSample& in : light) {
    for (uint32_t k = 0; k < m; ++k) {
      const Imath::V2f u = stratified_sample(k, m, rng);
      // Reciprocity: sampling from the light's direction draws outgoing
      // directions with weight f(wi, w) |n.w| / pdf(w).
      const BrdfSample b = brdf.sample(in.direction, u.x, u.y);
      if (!(b.pdf > 0.f) || !(s.normal.dot(b.wi) > 0.f)) continue;
      uint32_t f, x, y;
      layout.pixel(b.wi, f, x, y);
      const float scale = inv_m / layout.solid_angle(x, y);
      const C3f v = in.irradiance * b.weight * scale;
      cube[layout.index(f, 0, x, y)] += v.x;
      cube[layout.index(f, 1, x, y)] += v.y;
      cube[layout.index(f, 2, x, y)] += v.z;
    }
  }
}

}  // namespace pbgi
