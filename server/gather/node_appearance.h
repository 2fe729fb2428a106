// What a node looks like from a receiver: the fraction of its area it
// shows (projected-area coverage) and the radiance it shows, both from its
// payload (storage/tree/node.h).
//
// Two models:
//  - Narrow normal cone (half angle <= kNarrowConeAngle): the node is
//    nearly flat. A 3-band SH of a clamped cosine rings badly at grazing
//    angles (it shows about 9% coverage edge-on and 6% from behind), so
//    coverage comes from the cone instead: the mean of max(0, cos) over a
//    fan of normals spanning the cone, and radiance is the node's
//    area-weighted mean radiance (ratio of the DC terms), which is what a
//    flat node shows from every side.
//  - Wide cone: coverage = max(0, coverage_sh(w)) and radiance =
//    max(0, radiance_sh(w)) / coverage, clamped at 0 against SH ringing.
// Non-finite payloads yield "invisible".
#pragma once

#include "storage/math/sh.h"
#include "storage/tree/node.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

// cos(0.35 rad): cones up to 20 degrees use the flat model.
inline constexpr float kNarrowConeCos = 0.93937271f;
// Below this coverage the SH ratio is meaningless (ringing): invisible.
inline constexpr float kMinCoverage = 1e-4f;

struct Appearance {
  float coverage = 0.f;          // in [0, 1]
  Imath::C3f radiance{0, 0, 0};  // >= 0
  // Footprint: a flat node looks squashed along its normal by the
  // coverage; a wide-cone node is drawn round (ratio 1).
  Imath::V3f squash{0, 0, 0};
  float ratio = 1.f;
};

// The constants of a narrow normal cone that fan_coverage() needs,
// precomputed once per node (page_views.h).
struct FanCone {
  float cos_beta = 1.f, sin_beta = 0.f;
  float sin_over_beta = 1.f;  // sin(beta) / beta
  float inv_two_beta = 0.f;   // 1 / (2 beta)
};

inline FanCone fan_cone(float cos_beta) {
  FanCone f;
  f.cos_beta = cos_beta;
  f.sin_beta = std::sqrt(std::max(0.f, 1.f - cos_beta * cos_beta));
  // beta = asin(sin_beta) by its series (2e-5 relative error at the
  // narrow-cone limit, 0.35 rad).
  const float s2 = f.sin_beta * f.sin_beta;
  const float beta =
      f.sin_beta * (1.f + s2 * (1.f / 6.f + s2 * (3.f / 40.f + s2 * (5.f / 112.f))));
  if (f.sin_beta >= 1e-4f) {
    f.sin_over_beta = f.sin_beta / beta;
    f.inv_two_beta = 0.5f / beta;
  }
  return f;
}

// Mean of max(0, cos(phi + t)) over t in [-beta, beta], given cos phi and
// the cone: the coverage of a fan of normals seen at angle phi to its axis.
// For beta up to 0.5 rad.
inline float fan_coverage(float cos_phi, const FanCone& f) {
  if (f.sin_beta < 1e-4f) return std::max(0.f, cos_phi);
  const float sin_phi = std::sqrt(std::max(0.f, 1.f - cos_phi * cos_phi));
  const float cos_hi = cos_phi * f.cos_beta - sin_phi * f.sin_beta;  // cos(phi + beta)
  if (cos_hi >= 0.f) return cos_phi * f.sin_over_beta;                // whole fan in front
  const float cos_lo = cos_phi * f.cos_beta + sin_phi * f.sin_beta;   // cos(phi - beta)
  if (cos_lo <= 0.f) return 0.f;                                      // whole fan behind
  const float sin_lo = sin_phi * f.cos_beta - cos_phi * f.sin_beta;   // sin(phi - beta)
  return (1.f - sin_lo) * f.inv_two_beta;
}

inline float fan_coverage(float cos_phi, float cos_beta) {
  return fan_coverage(cos_phi, fan_cone(cos_beta));
}

// `w`: unit direction from the node towards the receiver. Returns false
// when the node shows nothing in that direction.
inline bool node_appearance(const tree::Node& node, const Imath::V3f& w, Appearance& out) {
  if (node.cone_cos >= kNarrowConeCos) {
    const float c0 = node.coverage_sh[0];
    if (!(c0 > 0.f)) return false;
    const float coverage = std::min(1.f, fan_coverage(node.cone_axis.dot(w), node.cone_cos));
    if (!(coverage > 0.f)) return false;
    const float inv = 1.f / c0;
    out.coverage = coverage;
    out.squash = node.cone_axis;
    out.ratio = coverage;
    out.radiance = Imath::C3f(std::max(0.f, node.radiance_sh.r[0] * inv),
                              std::max(0.f, node.radiance_sh.g[0] * inv),
                              std::max(0.f, node.radiance_sh.b[0] * inv));
  } else {
    const sh::Sh9 y = sh::basis(w);
    const float coverage = sh::dot(node.coverage_sh, y);
    if (!(coverage >= kMinCoverage)) return false;  // also rejects NaN
    const float inv = 1.f / coverage;
    out.coverage = std::min(1.f, coverage);
    out.ratio = 1.f;
    out.radiance = Imath::C3f(std::max(0.f, sh::dot(node.radiance_sh.r, y) * inv),
                              std::max(0.f, sh::dot(node.radiance_sh.g, y) * inv),
                              std::max(0.f, sh::dot(node.radiance_sh.b, y) * inv));
  }
  // NaN radiance would poison the whole receiver.
  if (!(std::isfinite(out.radiance.x) && std::isfinite(out.radiance.y) &&
        std::isfinite(out.radiance.z))) {
    return false;
  }
  return true;
}

}  // namespace pbgi::gather
