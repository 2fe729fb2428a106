#include "server/scene/direct_lighting.h"

#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/brdf.h"
#include "server/scene/dome_light.h"
#include "server/scene/light_sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {

// Estimator: E = sum over lights of (1/N) sum_k L_k cos_k / pdf_k, with the
// N samples of each area light stratified on the light's parameter square.
// Shadow rays start at p offset along n by p's rounding-error bound (the
// point itself lies on a surface; RayScene::offset_ray_origin, relative to
// p's coordinates so it stays tight far from the origin) and stop just short
// of the light sample so that geometry modelled at the emitter's position (a
// light's housing quad) does not shadow its own light. Unoccluded shadow
// rays are attenuated by the scene's fog (RayScene::transmittance).
namespace {
// Calls add(direction, L cos / pdf) for every unshadowed sample of a light,
// then end_light(sample count) once per light.
template <class Add, class EndLight>
void visit_light_samples(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples, uint64_t seed,
                         Add&& add, EndLight&& end_light) {
  const std::vector<Light>& lights = rays.scene().lights;
  const V3f origin = rays.offset_ray_origin(p, n, n);
  const float eps = (origin - p).length();
  const uint32_t count = std::max(samples, 1u);
  for (size_t li = 0; li < lights.size(); ++li) {
    const Light& light = lights[li];
    // One stream per (point, light): adding a light does not change the
    // samples the others get.
    Rng rng(seed, li);
    const bool delta = light.kind == LightKind::Distant;
    const uint32_t n_samples = delta ? 1u : count;
    // A dome lights p through its cosine-weighted hemisphere: sampling the
    // dome's own distribution alone (uniform on the sphere for a constant
    // dome) sends half the rays below the horizon and weights none by the
    // cosine, several times the variance. Its first n_dome samples follow
    // the dome's distribution (an HDR map's sun), the others the cosine,
    // combined by the balance heuristic (the mixture density); a constant
    // dome takes the cosine alone.
    const bool dome = light.kind == LightKind::Dome;
    const uint32_t n_dome = dome ? (light.environment ? n_samples / 2 : 0u) : n_samples;
    const uint32_t n_cosine = n_samples - n_dome;
    for (uint32_t k = 0; k < n_samples; ++k) {
      const bool cosine = k >= n_dome;
      const Imath::V2f u = cosine ? stratified_sample(k - n_dome, n_cosine, rng) : stratified_sample(k, n_dome, rng);
      LightSample s;
      float p_dome = 0.f;
      if (cosine) {
        s.direction = cosine_hemisphere(n, u.x, u.y);
        s.distance = std::numeric_limits<float>::infinity();
        s.radiance = dome_radiance(light, s.direction, &p_dome);
      } else {
        s = sample_light(light, p, u.x, u.y);
        p_dome = s.pdf;
      }
      if (dome) {
        // Mixture density of both strategies, scaled so that end_light's
        // division by n_samples gives sum f / (n_dome p_dome + n_cosine p_cos).
        const float p_cos = std::max(n.dot(s.direction), 0.f) * kInvPi;
        if (n_dome == 0) p_dome = 0.f;
        s.pdf = (float(n_dome) * p_dome + float(n_cosine) * p_cos) / float(n_samples);
      }
      if (!(s.pdf > 0.f)) continue;
      const float cos_r = n.dot(s.direction);
      if (!(cos_r > 0.f)) continue;  // below the receiver's hemisphere
      if (s.radiance.x <= 0.f && s.radiance.y <= 0.f && s.radiance.z <= 0.f) continue;
      const float tmax = std::isinf(s.distance)
                             ? s.distance
                             : s.distance * (1.f - 1e-4f) - 2.f * eps;
      if (!(tmax > 0.f)) continue;
      if (rays.occluded(origin, s.direction, 0.f, tmax)) continue;
      // Fog between the point and the light (participating_medium.h).
      const float tr = rays.transmittance(origin, s.direction, 0.f, tmax);
      add(s.direction, s.radiance * (tr * cos_r / s.pdf));
    }
    end_light(n_samples);
  }
}
}  // namespace

C3f direct_irradiance(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples,
                      uint64_t seed) {
  C3f e(0, 0, 0), sum(0, 0, 0);
  visit_light_samples(
      rays, p, n, samples, seed, [&](const V3f&, const C3f& c) { sum += c; },
      [&](uint32_t n_samples) {
        e += sum / static_cast<float>(n_samples);
        sum = C3f(0, 0, 0);
      });
  return e;
}

void incident_light(const RayScene& rays, const V3f& p, const V3f& n, uint32_t samples, uint64_t seed,
                    std::vector<IncidentSample>& out) {
  out.clear();
  size_t first = 0;  // this light's first sample in `out`
  visit_light_samples(
      rays, p, n, samples, seed, [&](const V3f& w, const C3f& c) { out.push_back({w, c}); },
      [&](uint32_t n_samples) {
        for (size_t i = first; i < out.size(); ++i) out[i].irradiance /= static_cast<float>(n_samples);
        first = out.size();
      });
}

}  // namespace pbgi
