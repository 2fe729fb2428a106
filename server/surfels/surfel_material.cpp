#include "server/surfels/surfel_material.h"

#include "server/scene/brdf.h"

namespace pbgi {

void set_surfel_material(const Scene& scene, uint32_t triangle, const SurfaceColors& colors,
                         float glossy_roughness, Surfel& s) {
  s.albedo = colors.albedo;
  s.emission = colors.emission;
  s.gloss = {};
  if (!(glossy_roughness > 0.f)) return;
  const Material& m = scene.materials[scene.triangle(triangle).material()];
  if (!(m.roughness < glossy_roughness)) return;
  const BrdfLobes lobes = brdf_lobes(m, colors.albedo);
  if (!lobes.specular) return;
  s.albedo = lobes.diffuse;
  s.gloss.alpha = lobes.alpha;
  s.gloss.f0 = lobes.f0;
}

}  // namespace pbgi
