// UsdLuxShapingAPI's cone and focus, as the UsdLux schema specifies them
// (usdLux/schema.usda, ShapingAPI):
//
//   theta_off    = acos(axis . emission_dir)    axis = the light's local -Z
//   theta_cutoff = radians(coneAngle)
//   theta_start  = lerp(coneSoftness, theta_cutoff, 0) = theta_cutoff (1 - s)
//   L *= 1 - smoothstep(theta_off; theta_start, theta_cutoff)  (0 beyond the cutoff)
//   focusFactor  = |emission_dir . axis|^focus               (focus > 0 only)
//   L *= lerp(focusFactor, focusTint, white)
//
// with softness clamped to [0, 1]. A cone of 180 degrees or more cuts
// nothing. IES profiles are not modelled (ingest warns).
#pragma once

#include "server/scene/scene.h"

#include <algorithm>
#include <cmath>

namespace pbgi {

// The light's shaping axis in world space: its local -Z, unit.
inline V3f shaping_axis(const Light& light) {
  V3f axis;
  light.local_to_world.multDirMatrix(V3f(0.f, 0.f, -1.f), axis);
  const float len = axis.length();
  return len > 0.f ? axis / len : V3f(0.f, 0.f, -1.f);
}

// Factor on the radiance leaving the light along unit `emission_dir` (from
// the light toward the receiver); (1, 1, 1) for unshaped lights.
inline C3f shaping_factor(const LightShaping& shaping, const V3f& axis, const V3f& emission_dir) {
  if (!shaping.enabled) return C3f(1.f, 1.f, 1.f);
  const float cos_off = std::clamp(axis.dot(emission_dir), -1.f, 1.f);
  float scalar = 1.f;
  const float cutoff_deg = shaping.cone_angle_degrees;
  if (cutoff_deg < 180.f) {
    const float cutoff = std::max(0.f, cutoff_deg) * 3.14159265358979f / 180.f;
    const float off = std::acos(cos_off);
    if (off > cutoff) return C3f(0.f, 0.f, 0.f);
    const float softness = std::clamp(shaping.cone_softness, 0.f, 1.f);
    const float start = cutoff * (1.f - softness);
    if (off > start && cutoff > start) {
      const float x = (off - start) / (cutoff - start);
      scalar = 1.f - x * x * (3.f - 2.f * x);
    }
  }
  C3f color(scalar, scalar, scalar);
  if (shaping.focus > 0.f) {
    const float f = std::pow(std::fabs(cos_off), shaping.focus);
    color *= shaping.focus_tint + (C3f(1.f, 1.f, 1.f) - shaping.focus_tint) * f;
  }
  return color;
}

// Fraction of an unshaped emitter's power that the cone lets through
// (hard cutoff; softness and focus ignored): for a one-sided planar
// Lambertian emitter facing the axis sin^2(cutoff), for a sphere or
// cylinder emitting in all directions (1 - cos(cutoff)) / 2. Used only to
// weigh lights against each other.
inline float shaping_power_fraction(const LightShaping& shaping, bool planar) {
  if (!shaping.enabled || !(shaping.cone_angle_degrees < 180.f)) return 1.f;
  const float cutoff = std::max(0.f, shaping.cone_angle_degrees) * 3.14159265358979f / 180.f;
  if (planar) return cutoff >= 1.5707963f ? 1.f : std::sin(cutoff) * std::sin(cutoff);
  return 0.5f * (1.f - std::cos(cutoff));
}

}  // namespace pbgi
