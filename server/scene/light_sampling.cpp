#include "server/scene/light_sampling.h"

#include "server/scene/sample_patterns.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// A light's local frame in world space. USD matrices act on row vectors
// (p_world = p_local * M), which is Imath's convention, so local axes map
// with multDirMatrix and points with multVecMatrix.
struct LightFrame {
  V3f center;    // local origin
  V3f ax, ay;    // images of the local unit X and Y axes (not unit if scaled)
  V3f normal;    // unit normal of the local XY plane, on the local -Z side
  float plane_scale = 0.f;  // |ax x ay|: world area per unit of local XY area
  float axis_scale = 0.f;   // mean length of the three axes (sphere radius)
};

LightFrame frame_of(const Light& light) {
  LightFrame f;
  light.local_to_world.multVecMatrix(V3f(0, 0, 0), f.center);
  V3f az;
  light.local_to_world.multDirMatrix(V3f(1, 0, 0), f.ax);
  light.local_to_world.multDirMatrix(V3f(0, 1, 0), f.ay);
  light.local_to_world.multDirMatrix(V3f(0, 0, 1), az);
  const V3f c = f.ax.cross(f.ay);
  f.plane_scale = c.length();
  // The emitting side is where local -Z goes, whatever the handedness of the
  // transform (a mirrored light still emits toward its image of -Z).
  f.normal = f.plane_scale > 0.f ? c / f.plane_scale : V3f(0, 0, 0);
  if (f.normal.dot(az) > 0.f) f.normal = -f.normal;
  f.axis_scale = (f.ax.length() + f.ay.length() + az.length()) / 3.f;
  return f;
}

// Local plane coordinates (a, b) of a world point q on the light's plane,
// q = center + a*ax + b*ay; solves the 2x2 Gram system so that sheared
// transforms work too.
bool plane_coords(const LightFrame& f, const V3f& q, float* a, float* b) {
  const V3f r = q - f.center;
  const float g11 = f.ax.dot(f.ax), g12 = f.ax.dot(f.ay), g22 = f.ay.dot(f.ay);
  const float det = g11 * g22 - g12 * g12;
  if (!(det > 0.f)) return false;
  const float r1 = r.dot(f.ax), r2 = r.dot(f.ay);
  *a = (r1 * g22 - r2 * g12) / det;
  *b = (r2 * g11 - r1 * g12) / det;
  return true;
}

// Solid-angle pdf of a point sampled uniformly on area `area` at distance
// `dist` along unit `dir`, where the emitter's unit normal is n. Zero when
// the point is seen from behind (one-sided emitters).
float area_to_solid_angle(float area, float dist, const V3f& dir, const V3f& n) {
  const float cos_l = -n.dot(dir);
  if (!(cos_l > 0.f) || !(area > 0.f)) return 0.f;
  return dist * dist / (area * cos_l);
}

LightSample sample_planar(const Light& light, const LightFrame& f, const V3f& p, const V3f& q,
                          float area) {
  LightSample s;
  const V3f d = q - p;
  const float dist = d.length();
  if (!(dist > 0.f)) return s;
  s.direction = d / dist;
  s.distance = dist;
  s.pdf = area_to_solid_angle(area, dist, s.direction, f.normal);
  if (s.pdf > 0.f) s.radiance = light.radiance;
  return s;
}

LightSample sample_rect(const Light& light, const V3f& p, float u1, float u2) {
  const LightFrame f = frame_of(light);
  const V3f q = f.center + ((u1 - 0.5f) * light.width) * f.ax + ((u2 - 0.5f) * light.height) * f.ay;
  return sample_planar(light, f, p, q, light.width * light.height * f.plane_scale);
}

LightSample sample_disk(const Light& light, const V3f& p, float u1, float u2) {
  const LightFrame f = frame_of(light);
  const Imath::V2f d = square_to_disk({u1, u2});
  const V3f q = f.center + (d.x * light.radius) * f.ax + (d.y * light.radius) * f.ay;
  return sample_planar(light, f, p, q, kPi * light.radius * light.radius * f.plane_scale);
}

// Sphere: uniform over the cone of directions that see the sphere when p is
// outside (pbrt-v4's Sphere::Sample, with its small-angle Taylor branch);
// uniform over the surface when p is inside or on it.
LightSample sample_sphere(const Light& light, const V3f& p, float u1, float u2) {
  const LightFrame f = frame_of(light);
  const float r = light.radius * f.axis_scale;
  LightSample s;
  if (!(r > 0.f)) return s;
  const V3f to_center = f.center - p;
  const float dc = to_center.length();
  if (dc <= r * (1.f + 1e-4f)) {
    // Inside: a uniform point on the sphere, seen from inside it faces away
    // (the sphere emits outward), so only points in front count.
    const float z = 1.f - 2.f * u1;
    const float sr = std::sqrt(std::max(0.f, 1.f - z * z));
    const float phi = 2.f * kPi * u2;
    const V3f n(sr * std::cos(phi), sr * std::sin(phi), z);
    const V3f q = f.center + r * n;
    const V3f d = q - p;
    const float dist = d.length();
    if (!(dist > 0.f)) return s;
    s.direction = d / dist;
    s.distance = dist;
    s.pdf = area_to_solid_angle(4.f * kPi * r * r, dist, s.direction, n);
    if (s.pdf > 0.f) s.radiance = light.radiance;
    return s;
  }
  const V3f w = to_center / dc;
  const float sin_max = r / dc;
  const float sin2_max = sin_max * sin_max;
  const float cos_max = std::sqrt(std::max(0.f, 1.f - sin2_max));
  float one_minus_cos_max = 1.f - cos_max;
  float cos_theta = (cos_max - 1.f) * u1 + 1.f;
  float sin2_theta = 1.f - cos_theta * cos_theta;
  if (sin2_max < 0.00068523f) {  // sin^2(1.5 deg): 1 - cos loses all precision
    sin2_theta = sin2_max * u1;
    cos_theta = std::sqrt(1.f - sin2_theta);
    one_minus_cos_max = sin2_max / 2.f;
  }
  // Angle at the sphere's center between -w and the sampled surface point.
  const float cos_alpha =
      sin2_theta / sin_max + cos_theta * std::sqrt(std::max(0.f, 1.f - sin2_theta / sin2_max));
  const float sin_alpha = std::sqrt(std::max(0.f, 1.f - cos_alpha * cos_alpha));
  const float phi = 2.f * kPi * u2;
  V3f t, b;
  orthonormal_basis(w, &t, &b);
  const V3f n = -(sin_alpha * std::cos(phi) * t + sin_alpha * std::sin(phi) * b + cos_alpha * w);
  const V3f q = f.center + r * n;
  const V3f d = q - p;
  const float dist = d.length();
  if (!(dist > 0.f)) return s;
  s.direction = d / dist;
  s.distance = dist;
  s.pdf = 1.f / (2.f * kPi * one_minus_cos_max);
  s.radiance = light.radiance;
  return s;
}

LightSample sample_distant(const Light& light) {
  LightSample s;
  V3f to_light;
  // The light travels along local -Z, so it comes from local +Z.
  light.local_to_world.multDirMatrix(V3f(0, 0, 1), to_light);
  const float len = to_light.length();
  if (!(len > 0.f)) return s;
  s.direction = to_light / len;
  s.distance = kInf;
  s.radiance = light.radiance;
  s.pdf = 1.f;
  s.delta = true;
  return s;
}

// Ray against the light's plane; returns the hit distance if it is in
// (0, tmax) and the ray arrives on the emitting side.
bool hit_plane(const LightFrame& f, const V3f& o, const V3f& dir, float tmax, float* t) {
  const float denom = dir.dot(f.normal);
  if (!(denom < 0.f)) return false;  // parallel, or reaching the back side
  const float th = (f.center - o).dot(f.normal) / denom;
  if (!(th > 0.f) || !(th < tmax)) return false;
  *t = th;
  return true;
}

}  // namespace

LightSample sample_light(const Light& light, const V3f& p, float u1, float u2) {
  switch (light.kind) {
    case LightKind::Rect: return sample_rect(light, p, u1, u2);
    case LightKind::Disk: return sample_disk(light, p, u1, u2);
    case LightKind::Sphere: return sample_sphere(light, p, u1, u2);
    case LightKind::Distant: return sample_distant(light);
  }
  return {};
}

bool intersect_light(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                     C3f* radiance, float* t, float* pdf) {
  const LightFrame f = frame_of(light);
  float th = 0.f;
  float area = 0.f;
  switch (light.kind) {
    case LightKind::Distant:
      return false;  // a delta distribution: no ray hits it
    case LightKind::Rect: {
      float a, b;
      if (!hit_plane(f, origin, dir, tmax, &th)) return false;
      if (!plane_coords(f, origin + th * dir, &a, &b)) return false;
      if (std::fabs(a) > 0.5f * light.width || std::fabs(b) > 0.5f * light.height) return false;
      area = light.width * light.height * f.plane_scale;
      break;
    }
    case LightKind::Disk: {
      float a, b;
      if (!hit_plane(f, origin, dir, tmax, &th)) return false;
      if (!plane_coords(f, origin + th * dir, &a, &b)) return false;
      if (a * a + b * b > light.radius * light.radius) return false;
      area = kPi * light.radius * light.radius * f.plane_scale;
      break;
    }
    case LightKind::Sphere: {
      const float r = light.radius * f.axis_scale;
      const V3f oc = origin - f.center;
      const float dc = oc.length();
      if (!(r > 0.f) || dc <= r) return false;  // seen from inside: emits away
      const float bq = oc.dot(dir);
      const float disc = bq * bq - (oc.dot(oc) - r * r);
      if (disc < 0.f) return false;
      th = -bq - std::sqrt(disc);
      if (!(th > 0.f) || !(th < tmax)) return false;
      *radiance = light.radiance;
      *t = th;
      const float sin2_max = r * r / (dc * dc);
      const float one_minus_cos_max = sin2_max < 0.00068523f
                                          ? sin2_max / 2.f
                                          : 1.f - std::sqrt(std::max(0.f, 1.f - sin2_max));
      *pdf = 1.f / (2.f * kPi * one_minus_cos_max);
      return true;
    }
  }
  *radiance = light.radiance;
  *t = th;
  *pdf = area_to_solid_angle(area, th, dir, f.normal);
  return true;
}

float light_power(const Light& light) {
  const float l = (light.radiance.x + light.radiance.y + light.radiance.z) / 3.f;
  const LightFrame f = frame_of(light);
  switch (light.kind) {
    // A one-sided Lambertian emitter of area A sends pi * A * L watts.
    case LightKind::Rect: return kPi * light.width * light.height * f.plane_scale * l;
    case LightKind::Disk: return kPi * kPi * light.radius * light.radius * f.plane_scale * l;
    case LightKind::Sphere: {
      const float r = light.radius * f.axis_scale;
      return kPi * 4.f * kPi * r * r * l;
    }
    // Unbounded in principle; its irradiance (W/m^2) is what can be
    // compared, and callers scale it by the scene's cross-section.
    case LightKind::Distant: return l;
  }
  return 0.f;
}

}  // namespace pbgi
