#include "server/render/gather_lattice.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>

namespace pbgi {
namespace {

// Normals of a sample and a corner it takes a value from differ by at most
// acos(0.95) = 18 degrees: beyond, irradiance cannot be assumed linear
// (Ward's sqrt(1 - n.n') term at 0.22).
constexpr float kMinNormalCos = 0.95f;
// A sample lies within this slope of the corner's tangent plane: a depth
// step (a box in front of a wall, a step of the same mesh) breaks it.
constexpr float kMaxPlaneSlope = 0.05f;

float luminance(const C3f& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

}  // namespace

bool may_interpolate(const SurfaceSample& s, const SurfaceSample& corner) {
  if (!s.gathers || !corner.gathers || s.mesh != corner.mesh) return false;
  const Receiver& a = s.receiver;
  const Receiver& c = corner.receiver;
  if (a.normal.dot(c.normal) < kMinNormalCos) return false;
  const V3f d = a.position - c.position;
  const float along = std::fabs(d.dot(c.normal));
  // The tiny absolute term keeps coincident points (the corner's own pixel)
  // compatible whatever the rounding of their offsets.
  return along <= kMaxPlaneSlope * d.length() + 1e-6f * std::max(corner.depth, 1.f);
}

bool corners_disagree(std::span<const GatherResult* const> corners, float tolerance) {
  if (corners.size() < 2) return false;
  float lum[4], mean_lum = 0.f, mean_ao = 0.f;
  const float share = 1.f / float(corners.size());
  for (size_t i = 0; i < corners.size(); ++i) {
    lum[i] = luminance(corners[i]->irradiance);
    mean_lum += share * lum[i];
    mean_ao += share * corners[i]->ao;
  }
  for (size_t i = 0; i < corners.size(); ++i) {
    if (std::fabs(lum[i] - mean_lum) > tolerance * mean_lum) return true;
    if (std::fabs(corners[i]->ao - mean_ao) > tolerance) return true;
  }
  return false;
}

}  // namespace pbgi
