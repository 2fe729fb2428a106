#include "server/scene/light_sampling.h"

#include "server/scene/dome_light.h"
#include "server/scene/light_shaping.h"
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

// CylinderLight: the lateral surface of radius r around the local X axis,
// x in [-length/2, length/2], emitting outward (the caps do not emit).
// Points are uniform in the local parameters (x, angle), which is uniform
// in world area when the transform scales local Y and Z alike; its world
// area uses the mean of the two scales (a non-uniformly scaled cross
// section is an ellipse, whose perimeter this approximates).
struct CylinderGeometry {
  M44f to_world, normal_to_world, to_local;
  float area = 0.f;
};

CylinderGeometry cylinder_geometry(const Light& light) {
  CylinderGeometry g;
  g.to_world = light.local_to_world;
  g.to_local = light.local_to_world.inverse();
  g.normal_to_world = g.to_local.transposed();
  V3f ax, ay, az;
  light.local_to_world.multDirMatrix(V3f(1, 0, 0), ax);
  light.local_to_world.multDirMatrix(V3f(0, 1, 0), ay);
  light.local_to_world.multDirMatrix(V3f(0, 0, 1), az);
  g.area = 2.f * kPi * light.radius * 0.5f * (ay.length() + az.length()) * light.length * ax.length();
  return g;
}

V3f cylinder_normal(const CylinderGeometry& g, float cos_phi, float sin_phi) {
  V3f n;
  g.normal_to_world.multDirMatrix(V3f(0.f, cos_phi, sin_phi), n);
  return n.normalized();
}

LightSample sample_cylinder(const Light& light, const V3f& p, float u1, float u2) {
  LightSample s;
  if (!(light.radius > 0.f) || !(light.length > 0.f)) return s;
  const CylinderGeometry g = cylinder_geometry(light);
  const float phi = 2.f * kPi * u2;
  const float c = std::cos(phi), sn = std::sin(phi);
  V3f q;
  g.to_world.multVecMatrix(V3f((u1 - 0.5f) * light.length, light.radius * c, light.radius * sn), q);
  const V3f n = cylinder_normal(g, c, sn);
  const V3f d = q - p;
  const float dist = d.length();
  if (!(dist > 0.f)) return s;
  s.direction = d / dist;
  s.distance = dist;
  s.pdf = area_to_solid_angle(g.area, dist, s.direction, n);
  if (s.pdf > 0.f) s.radiance = light.radiance;
  return s;
}

// Nearest hit of the ray with the cylinder's outside before tmax. Rays from
// inside the (infinite) cylinder, or whose first crossing of the surface is
// outside [-length/2, length/2], reach only its inside, which emits away.
bool intersect_cylinder(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                        C3f* radiance, float* t, float* pdf) {
  if (!(light.radius > 0.f) || !(light.length > 0.f)) return false;
  const CylinderGeometry g = cylinder_geometry(light);
  V3f o, d;
  g.to_local.multVecMatrix(origin, o);
  g.to_local.multDirMatrix(dir, d);  // not normalized: t stays the world distance
  const float r2 = light.radius * light.radius;
  const float c = o.y * o.y + o.z * o.z - r2;
  if (!(c > 0.f)) return false;
  const float a = d.y * d.y + d.z * d.z;
  const float b = o.y * d.y + o.z * d.z;
  if (!(a > 0.f) || !(b < 0.f)) return false;  // parallel to the axis, or moving away
  const float disc = b * b - a * c;
  if (disc < 0.f) return false;
  const float th = c / (-b + std::sqrt(disc));  // smaller root, stable form
  if (!(th > 0.f) || !(th < tmax)) return false;
  const V3f hit = o + th * d;
  if (std::fabs(hit.x) > 0.5f * light.length) return false;
  const float inv_r = 1.f / light.radius;
  const V3f n = cylinder_normal(g, hit.y * inv_r, hit.z * inv_r);
  *radiance = light.radiance;
  *t = th;
  *pdf = area_to_solid_angle(g.area, th, dir, n);
  return *pdf > 0.f;
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

// Rect, disk, sphere and cylinder without shaping (defined below).
bool intersect_unshaped(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                        C3f* radiance, float* t, float* pdf);

}  // namespace

LightSample sample_light(const Light& light, const V3f& p, float u1, float u2) {
  LightSample s;
  s.direction = V3f(0.f, 0.f, 0.f);
  switch (light.kind) {
    case LightKind::Rect: s = sample_rect(light, p, u1, u2); break;
    case LightKind::Disk: s = sample_disk(light, p, u1, u2); break;
    case LightKind::Sphere: s = sample_sphere(light, p, u1, u2); break;
    case LightKind::Cylinder: s = sample_cylinder(light, p, u1, u2); break;
    case LightKind::Distant: return sample_distant(light);
    case LightKind::Dome: return sample_dome(light, u1, u2);
  }
  // Shaping scales what leaves the light toward p; the density is unchanged.
  if (light.shaping.enabled && s.pdf > 0.f)
    s.radiance *= shaping_factor(light.shaping, shaping_axis(light), -s.direction);
  return s;
}

bool intersect_light(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                     C3f* radiance, float* t, float* pdf) {
  if (light.kind == LightKind::Dome) {
    if (!std::isinf(tmax)) return false;  // a surface is in the way
    *radiance = dome_radiance(light, dir, pdf);
    *t = kInf;
    return true;
  }
  if (light.shaping.enabled) {
    if (!intersect_unshaped(light, origin, dir, tmax, radiance, t, pdf)) return false;
    *radiance *= shaping_factor(light.shaping, shaping_axis(light), -dir);
    return true;
  }
  return intersect_unshaped(light, origin, dir, tmax, radiance, t, pdf);
}

namespace {

bool intersect_unshaped(const Light& light, const V3f& origin, const V3f& dir, float tmax,
                        C3f* radiance, float* t, float* pdf) {
  const LightFrame f = frame_of(light);
  float th = 0.f;
  float area = 0.f;
  switch (light.kind) {
    case LightKind::Distant:
    case LightKind::Dome:  // handled by intersect_light
      return false;  // a delta distribution: no ray hits it
    case LightKind::Cylinder:
      return intersect_cylinder(light, origin, dir, tmax, radiance, t, pdf);
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

}  // namespace

float light_power(const Light& light) {
  const float l = (light.radiance.x + light.radiance.y + light.radiance.z) / 3.f;
  const LightFrame f = frame_of(light);
  const float planar = shaping_power_fraction(light.shaping, true);
  const float round = shaping_power_fraction(light.shaping, false);
  switch (light.kind) {
    // A one-sided Lambertian emitter of area A sends pi * A * L watts.
    case LightKind::Rect: return kPi * light.width * light.height * f.plane_scale * l * planar;
    case LightKind::Disk: return kPi * kPi * light.radius * light.radius * f.plane_scale * l * planar;
    case LightKind::Sphere: {
      const float r = light.radius * f.axis_scale;
      return kPi * 4.f * kPi * r * r * l * round;
    }
    case LightKind::Cylinder: return kPi * cylinder_geometry(light).area * l * round;
    case LightKind::Dome: return dome_power(light);
    // Unbounded in principle; its irradiance (W/m^2) is what can be
    // compared, and callers scale it by the scene's cross-section.
    case LightKind::Distant: return l;
  }
  return 0.f;
}

}  // namespace pbgi
