#include "server/scene/dome_light.h"

#include "server/scene/environment_map.h"
#include "server/scene/sample_patterns.h"

#include <Imath/ImathMatrixAlgo.h>

#include <cmath>
#include <limits>

namespace pbgi {
namespace {

// The dome's rotation (row vectors: world = local * R). A degenerate
// matrix (zero scale) leaves the dome unrotated rather than failing.
M44f dome_rotation(const Light& light) {
  M44f r = light.local_to_world;
  r[3][0] = r[3][1] = r[3][2] = 0.f;
  V3f scale, shear;
  if (!Imath::extractAndRemoveScalingAndShear(r, scale, shear, false)) return M44f();
  return r;
}

V3f to_world(const M44f& r, const V3f& local) {
  V3f w;
  r.multDirMatrix(local, w);
  return w.normalized();
}

V3f to_local(const M44f& r, const V3f& world) {
  V3f l;
  r.transposed().multDirMatrix(world, l);  // R is orthonormal: R^-1 = R^T
  return l.normalized();
}

constexpr float kUniformSpherePdf = 1.f / (4.f * kPi);

}  // namespace

LightSample sample_dome(const Light& light, float u1, float u2) {
  LightSample s;
  s.distance = std::numeric_limits<float>::infinity();
  const M44f r = dome_rotation(light);
  if (!light.environment) {
    const float z = 1.f - 2.f * u1;
    const float sr = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u2;
    s.direction = V3f(sr * std::cos(phi), sr * std::sin(phi), z);
    s.pdf = kUniformSpherePdf;
    s.radiance = light.radiance;
    return s;
  }
  C3f value;
  const V3f local = light.environment->sample(u1, u2, &s.pdf, &value);
  s.direction = to_world(r, local);
  s.radiance = value * light.radiance;
  return s;
}

C3f dome_radiance(const Light& light, const V3f& dir, float* pdf) {
  if (!light.environment) {
    if (pdf) *pdf = kUniformSpherePdf;
    return light.radiance;
  }
  const V3f local = to_local(dome_rotation(light), dir);
  if (pdf) *pdf = light.environment->pdf(local);
  return light.environment->eval(local) * light.radiance;
}

float dome_power(const Light& light) {
  const C3f mean = light.environment ? light.environment->mean() * light.radiance : light.radiance;
  return kPi * (mean.x + mean.y + mean.z) / 3.f;
}

C3f environment_radiance(const Scene& scene, const V3f& dir) {
  C3f sum(0.f, 0.f, 0.f);
  for (const Light& light : scene.lights)
    if (light.kind == LightKind::Dome) sum += dome_radiance(light, dir);
  return sum;
}

}  // namespace pbgi
