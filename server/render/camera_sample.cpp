#include "server/render/camera_sample.h"

#include "server/scene/brdf.h"
#include "server/scene/direct_lighting.h"
#include "server/scene/dome_light.h"
#include "server/scene/light_sampling.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/surface_colors.h"

#include <algorithm>
#include <vector>

namespace pbgi {
namespace {

// Nearest light along the ray before tmax, if any.
bool nearest_light(const std::vector<Light>& lights, const Ray& ray, float tmax, C3f* radiance) {
  bool found = false;
  for (const Light& light : lights) {
    C3f l;
    float t, pdf;
    if (intersect_light(light, ray.origin, ray.direction, tmax, &l, &t, &pdf)) {
      tmax = t;
      *radiance = l;
      found = true;
    }
  }
  return found;
}

}  // namespace

Imath::V2f pixel_sample_offset(uint32_t k, uint32_t spp, Rng& rng) {
  return spp == 1 ? Imath::V2f(0.5f, 0.5f) : stratified_sample(k, spp, rng);
}

SurfaceSample trace_sample(const RayScene& rays, const Ray& ray, uint32_t light_samples, uint64_t light_seed,
                           bool dome_visible) {
  SurfaceSample out;
  PixelValue& v = out.value;
  const Scene& scene = rays.scene();
  // Only what lies within the camera's clipping range is seen (camera_ray
  // sets tmin/tmax from it): a near plane cuts through occluders in front.
  const Hit hit = rays.intersect(ray.origin, ray.direction, ray.tmin, ray.tmax);

  // 1. An emitter in front of the first surface: its radiance, nothing to gather.
  C3f emitted(0.f);
  if (nearest_light(scene.lights, ray, hit.valid() ? hit.t : ray.tmax, &emitted)) {
    v.beauty = v.direct = emitted;
    v.ao = 1.f;
    return out;
  }
  // 2. Miss: the dome behind the scene (the sky), or black; fully
  // accessible. The dome is seen past the far clip too: it is at infinity.
  if (!hit.valid()) {
    if (dome_visible) v.beauty = v.direct = environment_radiance(scene, ray.direction.normalized());
    v.ao = 1.f;
    return out;
  }
  // 3. Surface: the receiver faces the camera (surfaces seen from behind
  // are lit on the side the camera sees); the shading normal is flipped with
  // it and falls back to the geometric one if it points below the surface.
  const TriangleRef tri = scene.triangle(hit.triangle);
  const V3f p = (1.f - hit.u - hit.v) * tri.position(0) + hit.u * tri.position(1) + hit.v * tri.position(2);
  V3f ng = hit.geometric_normal;
  V3f ns = rays.shading_normal(hit);
  if (ng.dot(-ray.direction) < 0.f) {
    ng = -ng;
    ns = -ns;
  }
  if (ns.dot(ng) <= 0.f) ns = ng;
  const SurfaceColors mat = surface_colors(scene, hit.triangle, hit.u, hit.v);  // textures applied
  out.brdf = mat.albedo * kInvPi;
  // Indirect light is reflected by the material's BRDF (brdf.h), as in the
  // reference's "indirect" AOV (path_tracer.h): its diffuse lobe times the
  // gathered irradiance plus its GGX lobe, which the gather convolves
  // towards the camera (the receiver's glossy part, set below).
  const Material& material = scene.materials[tri.material()];
  const BrdfLobes lobes = brdf_lobes(material, mat.albedo);
  out.indirect_brdf = lobes.diffuse * kInvPi;

  v.albedo = mat.albedo;
  if (light_samples == 0) {
    v.direct = mat.emission;
  } else if (!lobes.specular) {
    const C3f e_direct = direct_irradiance(rays, p, ns, light_samples, light_seed);
    v.direct = out.brdf * e_direct + mat.emission;
  } else {
    // A GGX lobe reflects each light sample through the whole BRDF, as the
    // reference's direct AOV does (a metal's highlight, and no Lambertian
    // term it does not have): the same samples and shadow rays as
    // direct_irradiance(), each weighted by f(wo, wi).
    thread_local std::vector<IncidentSample> light;
    incident_light(rays, p, ns, light_samples, light_seed, light);
    const Brdf brdf(lobes, ns);
    const V3f wo = -ray.direction.normalized();
    C3f reflected(0, 0, 0);
    for (const IncidentSample& in : light) reflected += brdf.eval(wo, in.direction) * in.irradiance;
    v.direct = reflected + mat.emission;
  }
  out.gathers = true;
  out.mesh = scene.mesh_ordinal(hit.triangle);
  out.depth = hit.t * ray.direction.length();
  // Off the surface by the hit point's own rounding bound (not a scene-wide
  // epsilon), so receivers far from the origin keep their precision.
  out.receiver = {RayScene::offset_ray_origin(rays.hit_point(hit), ng, ng), ns};
  if (lobes.specular) {
    out.receiver.glossy.view = -ray.direction.normalized();
    out.receiver.glossy.roughness = std::clamp(material.roughness, 0.f, 1.f);
    out.receiver.glossy.specular = lobes.f0;
  }
  return out;
}

PixelValue finish_sample(const SurfaceSample& s, const GatherResult& g) {
  PixelValue v = s.value;
  if (!s.gathers) return v;
  v.indirect = s.indirect_brdf * g.irradiance + g.glossy;
  v.ao = g.ao;
  v.beauty = v.direct + v.indirect;
  return v;
}

}  // namespace pbgi
