#include "storage/tree/bounding_sphere.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi::tree {

namespace {
// Rounds a radius computed in double up to a float that still encloses,
// with a few ulps of slack for the float arithmetic of whoever tests it.
float round_up_radius(double r) {
  const float f = static_cast<float>(r * (1.0 + 4.0 * std::numeric_limits<float>::epsilon()));
  return std::nextafter(f, std::numeric_limits<float>::infinity());
}
Imath::V3d to_d(const Imath::V3f& v) { return {v.x, v.y, v.z}; }
}  // namespace

double farthest_disk_distance(const Imath::V3d& p, const Surfel& s) {
  // Split p->center into its part along the normal (h) and across it (w):
  // the farthest disk point lies across, at distance w + r in-plane.
  const Imath::V3d v = to_d(s.position) - p;
  const Imath::V3d n = to_d(s.normal);
  const double h = v.dot(n);
  const double w = std::sqrt(std::max(0.0, v.length2() - h * h));
  const double across = w + s.radius;
  return std::sqrt(h * h + across * across);
}

Sphere sphere_of_disks(std::span<const Surfel> surfels) {
  Imath::V3d lo(std::numeric_limits<double>::infinity());
  Imath::V3d hi(-std::numeric_limits<double>::infinity());
  for (const Surfel& s : surfels) {
    // A disk of radius r with normal n spans r*sqrt(1 - n_k^2) along axis k.
    for (int k = 0; k < 3; ++k) {
      const double e = s.radius * std::sqrt(std::max(0.0, 1.0 - double(s.normal[k]) * s.normal[k]));
      lo[k] = std::min(lo[k], s.position[k] - e);
      hi[k] = std::max(hi[k], s.position[k] + e);
    }
  }
  Sphere out;
  const Imath::V3d c = 0.5 * (lo + hi);
  out.center = Imath::V3f(float(c.x), float(c.y), float(c.z));
  const Imath::V3d cf = to_d(out.center);
  double r = 0;
  for (const Surfel& s : surfels) r = std::max(r, farthest_disk_distance(cf, s));
  out.radius = round_up_radius(r);
  return out;
}

Sphere merge_spheres(const Sphere& a, const Sphere& b) {
  const Imath::V3d ca = to_d(a.center), cb = to_d(b.center);
  const double d = (cb - ca).length();
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  const double r = 0.5 * (d + a.radius + b.radius);
  const Imath::V3d c = ca + (cb - ca) * ((r - a.radius) / d);
  Sphere out;
  out.center = Imath::V3f(float(c.x), float(c.y), float(c.z));
  // Re-measure from the float center so rounding of the center is covered.
  const Imath::V3d cf = to_d(out.center);
  out.radius = round_up_radius(std::max((cf - ca).length() + a.radius, (cf - cb).length() + b.radius));
  return out;
}

}  // namespace pbgi::tree
