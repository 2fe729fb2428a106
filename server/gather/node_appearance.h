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

#include "storage/sh/sh.h"
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

// The area-weighted mean normal sum_i A_i n_i / A of a node, from the band-1
// coefficients of its coverage SH (exact: the clamped cosine's band 1 is
// linear in n). When every normal faces w, the node's coverage is exactly
// mean . w, whatever the spread of its normals (the fan model's
// sin(beta)/beta is right only for normals spread along one arc; a
// curved cap's pieces were 1% too bright with it).
// `Node`: tree::Node or any record with its cone and payload fields
// (gather::WideNode, page_views.h).
template <class Node>
inline Imath::V3f mean_normal(const Node& node) {
  constexpr float kBand1 = 2.f * 3.14159265358979f / 3.f * 0.488602512f;
  const sh::Sh9& c = node.coverage_sh;
  const float c0 = c[0] / (3.14159265358979f * 0.282094792f);  // sum of weights (1)
  const Imath::V3f m = c0 > 0.f ? Imath::V3f(c[3], c[1], c[2]) / (kBand1 * c0) : Imath::V3f(0);
  const float len = m.length();
  if (!(len <= 1.001f) || !(len > 0.5f)) {
    // Not a plausible narrow-cone mean: the fan's.
    return node.cone_axis * fan_cone(node.cone_cos).sin_over_beta;
  }
  return m;
}

// Coverage of a narrow-cone node seen from unit w (node to receiver): the
// exact mean . w while the whole cone faces w, else the fan model scaled to
// agree with it at the boundary.
inline float narrow_coverage(const Imath::V3f& w, const Imath::V3f& axis, const Imath::V3f& mean,
                             const FanCone& f) {
  const float cos_phi = axis.dot(w);
  const float sin_phi = std::sqrt(std::max(0.f, 1.f - cos_phi * cos_phi));
  if (cos_phi * f.cos_beta - sin_phi * f.sin_beta >= 0.f) return std::min(1.f, mean.dot(w));
  return std::min(1.f, fan_coverage(cos_phi, f) * axis.dot(mean) / f.sin_over_beta);
}

// A node whose normals form two opposite narrow sheets: both faces of a
// thin wall (or of a two-sided mesh, which the sampler covers with surfels
// on both sides). Seen from w, only the face whose normals point towards w
// shows; the 3-band SH of such a node cannot separate the faces (the lit
// outer face of a wall rings through to the dark inside at ~6% of its
// radiance), so the faces are recovered from the payload instead:
//  - the axis a from the band-2 coverage coefficients, which for normals
//    +-a are s (a a^T - I/3) in matrix form (rank one plus the trace);
//  - the faces' area fractions w+- from band 0 (w+ + w-) and the band-1
//    projection on a (w+ - w-); radiance likewise per face.
// The fit is accepted when a a^T explains the band-2 matrix (mean squared
// normal component along a, lambda, >= kBipolarMinLambda: normals within
// about 25 degrees of +-a) and band 1 has no component across a.
struct Bipolar {
  Imath::V3f axis{0, 0, 1};
  float frac_pos = 0.f, frac_neg = 0.f;  // area fractions of the faces along +a / -a
  Imath::C3f radiance_pos{0, 0, 0}, radiance_neg{0, 0, 0};  // >= 0
  FanCone fan;                                              // spread of each face
};

inline constexpr float kBipolarMinLambda = 0.98f;

inline bool fit_bipolar(const tree::Node& node, Bipolar& out) {
  constexpr float kY0 = 0.282094792f, kY1 = 0.488602512f;
  constexpr float kY2a = 1.092548431f, kY2b = 0.315391565f, kY2c = 0.546274215f;
  constexpr float kPiF = 3.14159265358979f;
  const sh::Sh9& c = node.coverage_sh;
  const float sum = c[0] / (kPiF * kY0);  // w+ + w-
  if (!(sum > 1e-6f) || !std::isfinite(sum)) return false;
  // Band 2 of w+- CC(+-a) is (sum pi/4) Y2(a): recover P = a a^T.
  const float s = sum * (kPiF / 4.f);
  float P[3][3];
  P[0][1] = P[1][0] = c[4] / (s * kY2a);
  P[1][2] = P[2][1] = c[5] / (s * kY2a);
  P[0][2] = P[2][0] = c[7] / (s * kY2a);
  P[2][2] = (1.f + c[6] / (s * kY2b)) / 3.f;
  const float diff = c[8] / (s * kY2c);
  P[0][0] = 0.5f * (1.f - P[2][2] + diff);
  P[1][1] = 0.5f * (1.f - P[2][2] - diff);
  int col = 0;
  if (P[1][1] > P[col][col]) col = 1;
  if (P[2][2] > P[col][col]) col = 2;
  Imath::V3f a(P[0][col], P[1][col], P[2][col]);
  for (int it = 0; it < 3; ++it) {  // power iteration sharpens the axis
    const float len = a.length();
    if (!(len > 1e-12f)) return false;
    a /= len;
    a = Imath::V3f(P[0][0] * a.x + P[0][1] * a.y + P[0][2] * a.z,
                   P[1][0] * a.x + P[1][1] * a.y + P[1][2] * a.z,
                   P[2][0] * a.x + P[2][1] * a.y + P[2][2] * a.z);
  }
  const float len = a.length();
  if (!(len > 1e-12f)) return false;
  a /= len;
  const Imath::V3f Pa(P[0][0] * a.x + P[0][1] * a.y + P[0][2] * a.z,
                      P[1][0] * a.x + P[1][1] * a.y + P[1][2] * a.z,
                      P[2][0] * a.x + P[2][1] * a.y + P[2][2] * a.z);
  const float lambda = a.dot(Pa);
  if (!(lambda >= kBipolarMinLambda) || !(lambda <= 1.1f)) return false;
  // Band 1 (x, y, z order: c[3], c[1], c[2]) must lie along a.
  const float b1 = 2.f * kPiF / 3.f * kY1;
  const Imath::V3f c1(c[3], c[1], c[2]);
  const float along = c1.dot(a);
  if ((c1 - a * along).length() > 0.1f * b1 * sum) return false;
  const float d = along / b1;  // w+ - w-
  out.axis = a;
  out.frac_pos = std::max(0.f, 0.5f * (sum + d));
  out.frac_neg = std::max(0.f, 0.5f * (sum - d));
  const auto face = [&](const sh::Sh9& r, float& pos, float& neg) {
    const float t = r[0] / (kPiF * kY0);
    const float u = Imath::V3f(r[3], r[1], r[2]).dot(a) / b1;
    const float lp = std::max(0.f, 0.5f * (t + u)), ln = std::max(0.f, 0.5f * (t - u));
    pos = out.frac_pos > 1e-6f ? lp / out.frac_pos : 0.f;
    neg = out.frac_neg > 1e-6f ? ln / out.frac_neg : 0.f;
  };
  face(node.radiance_sh.r, out.radiance_pos.x, out.radiance_neg.x);
  face(node.radiance_sh.g, out.radiance_pos.y, out.radiance_neg.y);
  face(node.radiance_sh.b, out.radiance_pos.z, out.radiance_neg.z);
  for (const Imath::C3f& L : {out.radiance_pos, out.radiance_neg}) {
    if (!(std::isfinite(L.x) && std::isfinite(L.y) && std::isfinite(L.z))) return false;
  }
  // Spread of each face: lambda = E[(n.a)^2] ~ 1 - beta^2 / 2 for normals
  // spread evenly over a cap of half angle beta.
  const float beta = std::min(0.5f, std::sqrt(std::max(0.f, 2.f * (1.f - lambda))));
  out.fan = fan_cone(std::cos(beta));
  return true;
}

// What a bipolar node shows from unit direction w (node to receiver): the
// face turned towards w, at its own coverage.
inline bool bipolar_appearance(const Bipolar& b, const Imath::V3f& w, float& coverage,
                               Imath::C3f& radiance) {
  const float cw = b.axis.dot(w);
  const float cp = b.frac_pos * fan_coverage(cw, b.fan);
  const float cn = b.frac_neg * fan_coverage(-cw, b.fan);
  coverage = std::min(1.f, cp + cn);
  if (!(cp + cn > kMinCoverage)) return false;
  radiance = (b.radiance_pos * cp + b.radiance_neg * cn) / (cp + cn);
  return true;
}

// `w`: unit direction from the node towards the receiver. Returns false
// when the node shows nothing in that direction.
// `Node` as for mean_normal().
template <class Node>
inline bool node_appearance(const Node& node, const Imath::V3f& w, Appearance& out) {
  if (node.cone_cos >= kNarrowConeCos) {
    const float c0 = node.coverage_sh[0];
    if (!(c0 > 0.f)) return false;
    const float coverage =
        narrow_coverage(w, node.cone_axis, mean_normal(node), fan_cone(node.cone_cos));
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
    float coverage = sh::dot(node.coverage_sh, y);
    // No normal of the cone can show more than its nearest one to w,
    // cos(phi - beta): beyond 90 degrees the SH's ringing (several % of
    // the node's radiance seen from behind) is all it would show.
    if (node.cone_cos > -1.f) {
      const float cos_phi = node.cone_axis.dot(w);
      const float sin_phi = std::sqrt(std::max(0.f, 1.f - cos_phi * cos_phi));
      const float sin_beta = std::sqrt(std::max(0.f, 1.f - node.cone_cos * node.cone_cos));
      coverage = std::min(coverage, cos_phi * node.cone_cos + sin_phi * sin_beta);
    }
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
