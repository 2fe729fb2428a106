#include "server/gather/rasterizer.h"

#include "server/gather/far_field.h"

#include <algorithm>
#include <cmath>

#ifndef PBGI_SPLAT_SMOOTH
#define PBGI_SPLAT_SMOOTH 1.f
#endif

namespace pbgi::gather {

namespace {

constexpr float kInvPi = 0.31830989f;

// The splat's filter over its equal-area rectangle of half widths h: the
// rectangle (a box of half width h) convolved with a box of half width
// c h, a trapezoid of support +-(1 + c) h. c = 1 gives a tent, c = 0 the
// box itself.
constexpr float kSmooth = PBGI_SPLAT_SMOOTH;
inline float support(float h) { return (1.f + kSmooth) * h; }
// CDF at x of the filter centered at 0, given inv = 1 / h: a ramp
// (x + A + B)^2 / 8AB up to -(A - B), linear 1/2 + x/2A across the flat
// top, symmetric above (A = h, B = c h).
inline float inner_cdf(float x, float inv) {
  const float t = x * inv;  // in units of h, inside the support
  if constexpr (kSmooth <= 0.f) return 0.5f + 0.5f * t;
  constexpr float k = kSmooth > 0.f ? 1.f / (8.f * kSmooth) : 0.f;
  if (t < kSmooth - 1.f) return k * (t + 1.f + kSmooth) * (t + 1.f + kSmooth);
  if (t > 1.f - kSmooth) return 1.f - k * (1.f + kSmooth - t) * (1.f + kSmooth - t);
  return 0.5f + 0.5f * t;
}
inline float tent_cdf(float x, float inv) {
  const float t = x * inv;
  if (t <= -1.f - kSmooth) return 0.f;
  if (t >= 1.f + kSmooth) return 1.f;
  return inner_cdf(x, inv);
}

// Components of a vector in the frame of cube face axis k (0..2): w along
// the axis (before its sign), u and v across (see cube_layout.h).
inline void axis_coords(int k, const Imath::V3f& d, float& u, float& v, float& w) {
  switch (k) {
    case 0: u = d.y; v = d.z; w = d.x; return;
    case 1: u = d.z; v = d.x; w = d.y; return;
    default: u = d.x; v = d.y; w = d.z; return;
  }
}

// Tent masses of the columns [i0, i1] over the support [s0, s1] (clipped to
// the face) of a tent centered at c, and the centers of their covered parts.
// Returns false when the clipped support is empty.
inline bool tent_masses(float c, float s0, float s1, float inv, float pw, uint32_t n,
                        uint32_t& i0, uint32_t& i1, float* mass, float* mid) {
  const float a0 = std::max(-1.f, s0), b1 = std::min(1.f, s1);
  if (!(a0 < b1)) return false;
  const float inv_pw = 1.f / pw;
  i0 = std::min(n - 1, uint32_t((a0 + 1.f) * inv_pw));
  i1 = std::min(n - 1, uint32_t((b1 + 1.f) * inv_pw));
  // The CDF is 0 at s0 and 1 at s1: only clipped ends and inner column
  // edges need evaluating.
  float prev = a0 > s0 ? tent_cdf(a0 - c, inv) : 0.f;
  float lo = a0;
  for (uint32_t i = i0; i <= i1; ++i) {
    const float edge = -1.f + pw * float(i + 1);
    const bool last = i == i1;
    const float hi = last ? b1 : edge;
    const float cdf = last ? (b1 < s1 ? tent_cdf(b1 - c, inv) : 1.f) : tent_cdf(edge - c, inv);
    mass[i - i0] = cdf - prev;
    mid[i - i0] = 0.5f * (lo + hi);
    prev = cdf;
    lo = hi;
  }
  return true;
}

}  // namespace

Rasterizer::Rasterizer(Microbuffer& buffer)
    : buffer_(buffer), layout_(buffer.layout()), inv_pw_(1.f / layout_.pixel_width()) {
  candidates_.reserve(layout_.pixel_count());
}

void Rasterizer::ellipse(const Imath::V3f& dir, const Shape& shape, Ellipse& e) const {
  const float omega = shape.omega;
  // Semi-axes (radians): pi * major * minor = omega, minor = ratio * major,
  // and the major axis no longer than the node itself.
  const float ratio = std::clamp(shape.ratio, 1e-3f, 1.f);
  const float a2 = omega * kInvPi;  // major * minor
  const float round_r = std::sqrt(a2);
  e.major = ratio >= 1.f ? round_r
                         : std::min(round_r / std::sqrt(ratio), std::max(shape.max_radius, round_r));
  e.minor = a2 / e.major;

  // 1. Home face: the one the center projects onto (largest component).
  const float ax = std::abs(dir.x), ay = std::abs(dir.y), az = std::abs(dir.z);
  const int k = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
  float cu, cv, cw;
  axis_coords(k, dir, cu, cv, cw);
  e.k = k;
  e.home = 2 * k + (cw < 0.f ? 1 : 0);
  const float inv_w = 1.f / std::abs(cw);  // face coordinates: w is |cw|, u and v as they are
  const float u = cu * inv_w, v = cv * inv_w;
  e.u = u;
  e.v = v;

  // 2. The ellipse mapped to the face plane (linearized at its center). The
  // gnomonic projection scales solid angle by q^(3/2), q = 1 + u^2 + v^2, so
  // the ellipse's plane area is omega q^(3/2). Its bounding box: the
  // tangent-plane gradient of u is (e_u - u e_w)/w, of squared length
  // (1 + u^2) q, and the ellipse's extent along it is
  // sqrt(major^2 |grad u|^2 - (major^2 - minor^2) (grad u . e2)^2) with e2
  // the minor axis (along the squash direction).
  const float q = 1.f + u * u + v * v;
  const float M2 = e.major * e.major;
  float bu2 = M2 * (1.f + u * u) * q, bv2 = M2 * (1.f + v * v) * q;
  if (e.major > e.minor) {
    const Imath::V3f e2 = shape.squash - dir * dir.dot(shape.squash);
    const float len2 = e2.length2();
    float gu2, gv2;
    if (len2 > 1e-12f) {
      float su, sv, sw;
      axis_coords(k, e2, su, sv, sw);
      if (e.home & 1) sw = -sw;
      const float s = inv_w / std::sqrt(len2);
      const float gu = (su - u * sw) * s, gv = (sv - v * sw) * s;
      gu2 = gu * gu;
      gv2 = gv * gv;
    } else {
      // No squash direction (seen face-on): any orientation; take the mean.
      gu2 = 0.5f * (1.f + u * u) * q;
      gv2 = 0.5f * (1.f + v * v) * q;
    }
    const float d2 = M2 - e.minor * e.minor;
    bu2 = std::max(bu2 - d2 * gu2, 1e-3f * bu2);
    bv2 = std::max(bv2 - d2 * gv2, 1e-3f * bv2);
  }
  // The axis-aligned rectangle of the ellipse's area and its box's aspect,
  // half sizes hu, hv; the splat is that rectangle convolved with itself.
  const float area = omega * q * std::sqrt(q);
  e.hu = 0.5f * std::sqrt(area * std::sqrt(bu2 / bv2));
  e.hv = 0.25f * area / e.hu;
}

bool Rasterizer::footprint(const Ellipse& e, bool clip_horizon) {
  candidates_.clear();
  covered_ = 0.f;
  weighted_ = 0.f;
  clip_ = clip_horizon;
  const float u = e.u, v = e.v, hu = e.hu, hv = e.hv;
  deposit_tent(e.home, u, hu, v, hv);

  // 3. Overflow across the home face's edges goes to the neighbouring face
  // sharing that edge. The overflow rectangle R (on the home face's plane,
  // the part of the tent's support beyond the edge) is mapped exactly,
  // corner by corner, onto the neighbour's plane; its bounding box B there
  // gets R's share of the tent spread evenly. Points of R beyond both edges
  // of a corner fall outside the neighbour's face and are clipped there, so
  // each lands on the one face it belongs to.
  const float su0 = u - support(hu), su1 = u + support(hu);
  const float sv0 = v - support(hv), sv1 = v + support(hv);
  if (su0 < -1.f || su1 > 1.f || sv0 < -1.f || sv1 > 1.f) {
    const float tent_area = 4.f * hu * hv;  // the filter's total, in plane units
    const int ku = (e.k + 1) % 3, kv = (e.k + 2) % 3;
    const float iu = 1.f / hu, iv = 1.f / hv;
    const int home = e.home;
    if (su1 > 1.f)
      overflow(home, 2 * ku, 1.f, su1, sv0, sv1, tent_area * (1.f - tent_cdf(1.f - u, iu)));
    if (su0 < -1.f)
      overflow(home, 2 * ku + 1, su0, -1.f, sv0, sv1, tent_area * tent_cdf(-1.f - u, iu));
    if (sv1 > 1.f)
      overflow(home, 2 * kv, su0, su1, 1.f, sv1, tent_area * (1.f - tent_cdf(1.f - v, iv)));
    if (sv0 < -1.f)
      overflow(home, 2 * kv + 1, su0, su1, sv0, -1.f, tent_area * tent_cdf(-1.f - v, iv));
  }
  return covered_ > 0.f && !candidates_.empty();
}

bool Rasterizer::inside_masses(const Ellipse& e, Inside& in) const {
  // The tent's support [u - 2hu, u + 2hu] x [v - 2hv, v + 2hv] lies inside
  // the home face: no clipping, no overflow; the CDF is 0 and 1 at the
  // support's ends, so only inner column edges need evaluating.
  const float su0 = e.u - support(e.hu), su1 = e.u + support(e.hu);
  const float sv0 = e.v - support(e.hv), sv1 = e.v + support(e.hv);
  if (!(su0 > -1.f && su1 < 1.f && sv0 > -1.f && sv1 < 1.f)) return false;
  const uint32_t n = layout_.resolution();
  in.i0 = uint32_t((su0 + 1.f) * inv_pw_);
  in.i1 = std::min(n - 1, uint32_t((su1 + 1.f) * inv_pw_));
  in.j0 = uint32_t((sv0 + 1.f) * inv_pw_);
  in.j1 = std::min(n - 1, uint32_t((sv1 + 1.f) * inv_pw_));
  if (in.i1 - in.i0 >= Inside::kMaxSide || in.j1 - in.j0 >= Inside::kMaxSide) return false;
  const float pw = layout_.pixel_width();
  const auto masses = [pw](float c, float inv, uint32_t a, uint32_t b, float* m) {
    float prev = 0.f;
    for (uint32_t i = a; i < b; ++i) {
      // Inner edges lie inside the support.
      const float cdf = inner_cdf(-1.f + pw * float(i + 1) - c, inv);
      m[i - a] = cdf - prev;
      prev = cdf;
    }
    m[b - a] = 1.f - prev;
  };
  masses(e.u, 1.f / e.hu, in.i0, in.i1, in.mu);
  masses(e.v, 1.f / e.hv, in.j0, in.j1, in.mv);
  const float* solid = layout_.solid_angles();
  in.base = layout_.index(e.home, 0, 0);
  float covered = 0.f;
  for (uint32_t j = in.j0; j <= in.j1; ++j) {
    const uint32_t row = in.base + j * n;
    float row_sum = 0.f;
    for (uint32_t i = in.i0; i <= in.i1; ++i) row_sum += in.mu[i - in.i0] * solid[row + i];
    covered += in.mv[j - in.j0] * row_sum;
  }
  in.covered = covered;
  return true;
}

void Rasterizer::splat(const Imath::V3f& dir, const Shape& shape, float depth,
                       const Imath::C3f& radiance) {
  const float omega = shape.omega;
  if (!(omega > 0.f) || !(depth > 0.f)) return;
  const float extent = std::clamp(shape.depth_extent, 0.f, 0.9f * depth);
  Ellipse e;
  ellipse(dir, shape, e);
  if (!(e.hu > 0.f) || !(e.hv > 0.f) || !std::isfinite(e.hu * e.hv)) return;
  const float z0 = depth - extent, z1 = depth + extent;
  // The tent blurs the splat, which lowers its cosine-weighted solid angle
  // near the normal (by 8% for a 0.28 sr splat). When the whole footprint
  // is above the horizon, the weights are rescaled to the exact value for
  // a cap of the splat's solid angle: Omega cos(theta) (1 + cos(rho)) / 2.
  const float cos_center = buffer_.normal().dot(dir);
  const float reach = std::min(1.f, 3.f * e.major);
  const bool above = cos_center > reach;
  const float rho2 = e.major * e.minor;
  const float target = omega * cos_center * (1.f - 0.25f * rho2);  // (1 + cos rho) / 2
  // Common case: wholly above the horizon and inside one face. The cosine
  // varies by a few percent over a splat; weights are spread in proportion
  // of solid angle, and their total is exact.
  Inside in;
  if (above && inside_masses(e, in)) {
    if (!(in.covered > 0.f)) return;
    // Coverage adds up to the splat's solid angle, weights to the target.
    const uint32_t n = layout_.resolution();
    const float* solid = layout_.solid_angles();
    const float scale = omega / in.covered, wscale = target / in.covered;
    for (uint32_t j = in.j0; j <= in.j1; ++j) {
      const uint32_t row = in.base + j * n;
      const float a_v = in.mv[j - in.j0] * scale, w_v = in.mv[j - in.j0] * wscale;
      for (uint32_t i = in.i0; i <= in.i1; ++i) {
        const uint32_t k = row + i;
        const float m = in.mu[i - in.i0];
        buffer_.add_coverage(k, z0, z1, m * a_v, m * w_v * solid[k], radiance);
      }
    }
    return;
  }
  if (!footprint(e, true)) return;
  // Rescale so that the pieces add up to exactly the splat's solid angle.
  const float* solid = layout_.solid_angles();
  const float scale = omega / covered_;
  const float weight_scale = above && weighted_ > 0.f ? target / weighted_ : scale;
  for (const Candidate& c : candidates_) {
    buffer_.add_coverage(c.pixel, z0, z1, c.fraction * scale,
                         c.fraction * weight_scale * solid[c.pixel] * c.cosine, radiance);
  }
}

void Rasterizer::splat_far(FarBuffer& far, const Imath::V3f& dir, const Shape& shape, float depth,
                           const Imath::C3f& radiance) {
  const float omega = shape.omega;
  if (!(omega > 0.f) || !(depth > 0.f)) return;
  Ellipse e;
  ellipse(dir, shape, e);
  if (!(e.hu > 0.f) || !(e.hv > 0.f) || !std::isfinite(e.hu * e.hv)) return;
  const float extent = std::clamp(shape.depth_extent, 0.f, 0.9f * depth);
  const float z0 = depth - extent, z1 = depth + extent;
  const float* solid = layout_.solid_angles();
  // Every piece carries the splat's exact first moment per unit solid
  // angle, (1 + cos rho)/2 dir, so that a receiver of normal n weights it
  // with the cap's exact cosine integral (see far_field.h).
  const float rho2 = e.major * e.minor;
  const Imath::V3f moment = dir * (1.f - 0.25f * rho2);
  Inside in;
  if (inside_masses(e, in)) {
    if (!(in.covered > 0.f)) return;
    const uint32_t n = layout_.resolution();
    const float scale = omega / in.covered;
    for (uint32_t j = in.j0; j <= in.j1; ++j) {
      const uint32_t row = in.base + j * n;
      const float a_v = in.mv[j - in.j0] * scale;
      for (uint32_t i = in.i0; i <= in.i1; ++i) {
        const uint32_t k = row + i;
        const float alpha = in.mu[i - in.i0] * a_v;
        far.add(k, z0, z1, alpha, alpha * solid[k], moment, radiance);
      }
    }
    return;
  }
  if (!footprint(e, false)) return;
  const float scale = omega / covered_;
  for (const Candidate& c : candidates_) {
    const float alpha = c.fraction * scale;
    far.add(c.pixel, z0, z1, alpha, alpha * solid[c.pixel], moment, radiance);
  }
}

void Rasterizer::overflow(int home, int face, float u0, float u1, float v0, float v1, float mass) {
  if (!(mass > 0.f)) return;
  const int k = home >> 1;
  const float s = (home & 1) ? -1.f : 1.f;
  float bu0 = 1e30f, bu1 = -1e30f, bv0 = 1e30f, bv1 = -1e30f;
  for (int c = 0; c < 4; ++c) {
    Imath::V3f d;
    d[k] = s;
    d[(k + 1) % 3] = (c & 1) ? u1 : u0;
    d[(k + 2) % 3] = (c & 2) ? v1 : v0;
    float nu, nv, nw;
    CubeLayout::face_coords(face, d, nu, nv, nw);
    if (!(nw > 0.f)) return;  // beyond 90 degrees: not a splat this gather makes
    const float iu = nu / nw, iv = nv / nw;
    bu0 = std::min(bu0, iu);
    bu1 = std::max(bu1, iu);
    bv0 = std::min(bv0, iv);
    bv1 = std::max(bv1, iv);
  }
  // `mass` is in home-plane area; it carries over to B in proportion of the
  // two rectangles' solid angles (area times the Jacobian at the center;
  // the final rescaling absorbs the second-order error).
  const auto solid = [](float a0, float a1, float b0, float b1) {
    const float a = 0.5f * (a0 + a1), b = 0.5f * (b0 + b1);
    const float q = 1.f + a * a + b * b;
    return (a1 - a0) * (b1 - b0) / (q * std::sqrt(q));
  };
  const float r_area = (u1 - u0) * (v1 - v0);
  const float to = solid(bu0, bu1, bv0, bv1);
  if (!(to > 0.f) || !(r_area > 0.f)) return;
  deposit(face, bu0, bu1, bv0, bv1, mass / r_area * solid(u0, u1, v0, v1) / to);
}

void Rasterizer::deposit_tent(int face, float uc, float hu, float vc, float hv) {
  const uint32_t n = layout_.resolution();
  const float pw = layout_.pixel_width();
  // The tent is separable: its mass over a pixel is the product of the
  // masses of the pixel's column and row.
  uint32_t i0, i1, j0, j1;
  float mass_u[CubeLayout::kMaxResolution], mid_u[CubeLayout::kMaxResolution];
  float mass_v[CubeLayout::kMaxResolution], mid_v[CubeLayout::kMaxResolution];
  if (!tent_masses(uc, uc - support(hu), uc + support(hu), 1.f / hu, pw, n, i0, i1, mass_u,
                   mid_u) ||
      !tent_masses(vc, vc - support(hv), vc + support(hv), 1.f / hv, pw, n, j0, j1, mass_v,
                   mid_v)) {
    return;
  }
  // Plane area of the whole tent over one pixel's.
  const float inv_pw = 1.f / pw;
  const float scale = 4.f * hu * hv * inv_pw * inv_pw;
  const float* solid = layout_.solid_angles();
  // The receiver's normal in face coordinates: the cosine at plane point
  // (u, v) is (nu u + nv v + nw) / sqrt(1 + u^2 + v^2).
  float nu = 0.f, nv = 0.f, nw = 1.f;
  if (clip_) CubeLayout::face_coords(face, buffer_.normal(), nu, nv, nw);
  for (uint32_t j = j0; j <= j1; ++j) {
    const float mv = mass_v[j - j0] * scale;
    if (!(mv > 0.f)) continue;
    const float m_v = mid_v[j - j0];
    const float row_cos = nv * m_v + nw, row_len = 1.f + m_v * m_v;
    const uint32_t row = layout_.index(face, 0, j);
    for (uint32_t i = i0; i <= i1; ++i) {
      const float fraction = mass_u[i - i0] * mv;
      if (!(fraction > 0.f)) continue;
      const uint32_t k = row + i;
      const float f_solid = fraction * solid[k];
      covered_ += f_solid;
      if (!clip_) {
        candidates_.push_back({k, fraction, 1.f});
        continue;
      }
      // Parts below the horizon count in `covered_` (that share of the
      // splat is lost to the receiver) but get no fragment.
      const float m = mid_u[i - i0];
      const float cosine = (nu * m + row_cos) / std::sqrt(row_len + m * m);
      if (cosine > 0.f) {
        candidates_.push_back({k, fraction, cosine});
        weighted_ += f_solid * cosine;
      }
    }
  }
}

void Rasterizer::deposit(int face, float u0, float u1, float v0, float v1, float density) {
  u0 = std::max(-1.f, u0);
  u1 = std::min(1.f, u1);
  v0 = std::max(-1.f, v0);
  v1 = std::min(1.f, v1);
  if (u0 >= u1 || v0 >= v1) return;
  const uint32_t n = layout_.resolution();
  const float pw = layout_.pixel_width();
  const float inv_pw = 1.f / pw;
  const float scale = density * inv_pw * inv_pw;
  const float* solid = layout_.solid_angles();
  float nu = 0.f, nv = 0.f, nw = 1.f;
  if (clip_) CubeLayout::face_coords(face, buffer_.normal(), nu, nv, nw);
  const uint32_t i0 = std::min(n - 1, uint32_t((u0 + 1.f) * inv_pw));
  const uint32_t i1 = std::min(n - 1, uint32_t((u1 + 1.f) * inv_pw));
  const uint32_t j0 = std::min(n - 1, uint32_t((v0 + 1.f) * inv_pw));
  const uint32_t j1 = std::min(n - 1, uint32_t((v1 + 1.f) * inv_pw));
  for (uint32_t j = j0; j <= j1; ++j) {
    const float lo_v = -1.f + pw * float(j);
    const float a_v = std::max(v0, lo_v), b_v = std::min(v1, lo_v + pw);
    if (b_v <= a_v) continue;
    const float mid_v = 0.5f * (a_v + b_v);
    const uint32_t row = layout_.index(face, 0, j);
    for (uint32_t i = i0; i <= i1; ++i) {
      const float lo_u = -1.f + pw * float(i);
      const float a_u = std::max(u0, lo_u), b_u = std::min(u1, lo_u + pw);
      if (b_u <= a_u) continue;
      const uint32_t k = row + i;
      const float fraction = (b_u - a_u) * (b_v - a_v) * scale;
      const float f_solid = fraction * solid[k];
      covered_ += f_solid;
      if (!clip_) {
        candidates_.push_back({k, fraction, 1.f});
        continue;
      }
      const float mid_u = 0.5f * (a_u + b_u);
      const float cosine =
          (nu * mid_u + nv * mid_v + nw) / std::sqrt(1.f + mid_u * mid_u + mid_v * mid_v);
      if (cosine > 0.f) {
        candidates_.push_back({k, fraction, cosine});
        weighted_ += f_solid * cosine;
      }
    }
  }
}

uint32_t Rasterizer::raycast(const Imath::V3f& offset, const Imath::V3f& normal, float radius,
                             const Imath::C3f& radiance) {
  const float d2 = offset.length2();
  const float r2 = radius * radius;
  const float plane = normal.dot(offset);  // < 0: the receiver is in front
  if (!(plane < 0.f) || !(radius > 0.f)) return 0;
  const uint32_t n = layout_.resolution();
  const float pw = layout_.pixel_width();
  // Candidate pixels: those whose area (not only center) may meet the
  // disk's bounding cone, widened by a pixel's angular half diagonal (at
  // most pw / sqrt(2) radians, at the face center).
  Imath::V3f axis(0, 0, 1);
  float sin_a = 1.f, cos_a = -1.f;  // whole sphere when the receiver is inside the disk's sphere
  if (d2 > r2 * 1.0001f) {
    const float d = std::sqrt(d2);
    axis = offset / d;
    const float a = std::asin(std::min(1.f, radius / d)) + 0.75f * pw;
    if (a < 3.14159265f) {
      sin_a = std::sin(a);
      cos_a = std::cos(a);
    }
  }
  // Sample points: a 4 x 4 grid per pixel. A pixel straddling the edge of
  // a surface covered by disks gets the fraction of it they cover (a single
  // center sample lost the near part of a pixel whose center sees a far,
  // splatted part of the same wall: 7% at 1 cm from an emitting wall).
  constexpr uint32_t kGrid = 4;
  static_assert(kGrid * kGrid == Microbuffer::kHitSamples);
  const float step = pw / float(kGrid);
  uint32_t hits = 0;
  for (int face = 0; face < CubeLayout::kFaces; ++face) {
    PixelRect rect;
    if (!layout_.cone_pixels(face, axis, sin_a, cos_a, rect)) continue;
    // The disk in face coordinates: w along the face axis, u, v across.
    float ou, ov, ow, nu, nv, nw;
    CubeLayout::face_coords(face, offset, ou, ov, ow);
    CubeLayout::face_coords(face, normal, nu, nv, nw);
    for (uint32_t j = rect.j0; j <= rect.j1; ++j) {
      for (uint32_t i = rect.i0; i <= rect.i1; ++i) {
        const uint32_t k = layout_.index(face, i, j);
        if (!buffer_.in_hemisphere(k)) continue;
        uint32_t mask = 0;
        float z0 = 1e30f, z1 = 0.f;
        const float u0 = -1.f + pw * float(i) + 0.5f * step;
        const float v0 = -1.f + pw * float(j) + 0.5f * step;
        for (uint32_t b = 0; b < kGrid; ++b) {
          const float v = v0 + step * float(b);
          for (uint32_t a = 0; a < kGrid; ++a) {
            const float u = u0 + step * float(a);
            // Ray (u, v, 1) (unnormalized) against the disk's plane.
            const float den = nu * u + nv * v + nw;
            if (!(den < 0.f)) continue;  // parallel to or leaving the plane
            const float t = plane / den;
            const float hu = u * t - ou, hv = v * t - ov, hw = t - ow;
            if (hu * hu + hv * hv + hw * hw <= r2) {
              mask |= 1u << (b * kGrid + a);
              const float z = t * std::sqrt(1.f + u * u + v * v);
              z0 = std::min(z0, z);
              z1 = std::max(z1, z);
            }
          }
        }
        if (mask) {
          buffer_.add_hit(k, z0, z1, radiance, mask);
          ++hits;
        }
      }
    }
  }
  (void)n;
  return hits;
}

}  // namespace pbgi::gather
