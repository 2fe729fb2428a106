#include "server/gather/rasterizer.h"

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

namespace {
// CDF at x of a box of half width h convolved with itself: a tent of half
// width 2h centered at 0, given inv = 1 / (2h). Branch-free: with
// t = x / 2h + 1 clamped to [0, 2], s = min(t, 1) and e = max(t - 1, 0),
// the CDF is s^2/2 + e - e^2/2.
inline float tent_cdf(float x, float inv) {
  const float t = std::clamp(x * inv + 1.f, 0.f, 2.f);
  const float s = std::min(t, 1.f), e = std::max(t - 1.f, 0.f);
  return 0.5f * s * s + e - 0.5f * e * e;
}
}  // namespace

Rasterizer::Rasterizer(Microbuffer& buffer) : buffer_(buffer), layout_(buffer.layout()) {
  candidates_.reserve(layout_.pixel_count());
}

void Rasterizer::splat(const Imath::V3f& dir, const Shape& shape, float depth,
                       const Imath::C3f& radiance) {
  const float omega = shape.omega;
  if (!(omega > 0.f) || !(depth > 0.f)) return;
  candidates_.clear();
  covered_ = 0.f;

  // Semi-axes (radians): pi * major * minor = omega, minor = ratio * major,
  // and the major axis no longer than the node itself.
  constexpr float kInvPi = 0.31830989f;
  const float ratio = std::clamp(shape.ratio, 1e-3f, 1.f);
  const float major = std::min(std::sqrt(omega * kInvPi / ratio),
                               std::max(shape.max_radius, std::sqrt(omega * kInvPi)));
  const float minor = omega * kInvPi / major;
  // Tangent frame: e2 along the squash direction, e1 across it.
  Imath::V3f e2 = shape.squash - dir * dir.dot(shape.squash);
  const float e2_len = e2.length();
  if (ratio >= 1.f || !(e2_len > 1e-6f)) {
    e2 = std::abs(dir.x) < 0.9f ? Imath::V3f(1, 0, 0) : Imath::V3f(0, 1, 0);
    e2 = (e2 - dir * dir.dot(e2)).normalized();
  } else {
    e2 /= e2_len;
  }
  const Imath::V3f e1 = dir.cross(e2);

  // 1. Home face: the one the center projects onto (largest component).
  const float ax = std::abs(dir.x), ay = std::abs(dir.y), az = std::abs(dir.z);
  const int k = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
  const int home = 2 * k + (dir[k] < 0.f ? 1 : 0);
  float cu, cv, cw;
  CubeLayout::face_coords(home, dir, cu, cv, cw);
  const float inv_w = 1.f / cw;
  const float u = cu * inv_w, v = cv * inv_w;
  // The ellipse's semi-axis vectors mapped to the face plane: a tangent
  // displacement t moves (u, v) by ((t_u - u t_w) / w, (t_v - v t_w) / w).
  float au, av, aw, bu, bv, bw;
  CubeLayout::face_coords(home, e1, au, av, aw);
  CubeLayout::face_coords(home, e2, bu, bv, bw);
  const float p1u = major * (au - u * aw) * inv_w, p1v = major * (av - v * aw) * inv_w;
  const float p2u = minor * (bu - u * bw) * inv_w, p2v = minor * (bv - v * bw) * inv_w;
  // Rectangle of the ellipse's area with its bounding box's aspect.
  const float box_u = std::sqrt(p1u * p1u + p2u * p2u);
  const float box_v = std::sqrt(p1v * p1v + p2v * p2v);
  const float ellipse_area = 3.14159265f * std::abs(p1u * p2v - p1v * p2u);
  const float box_area = 4.f * box_u * box_v;
  if (!(box_area > 0.f)) return;
  const float shrink = std::sqrt(ellipse_area / box_area);
  const float hu = box_u * shrink, hv = box_v * shrink;
  deposit_tent(home, u, hu, v, hv);

  // 2. Overflow across the home face's edges goes to the neighbouring face
  // sharing that edge. The overflow rectangle R (on the home face's plane,
  // the part of the tent's support beyond the edge) is mapped exactly,
  // corner by corner, onto the neighbour's plane; its bounding box B there
  // gets R's share of the tent spread evenly. Points of R beyond both edges
  // of a corner fall outside the neighbour's face and are clipped there, so
  // each lands on the one face it belongs to.
  const float su0 = u - 2.f * hu, su1 = u + 2.f * hu;
  const float sv0 = v - 2.f * hv, sv1 = v + 2.f * hv;
  const float area = 4.f * hu * hv;  // the tent's total, in plane units
  const int ku = (k + 1) % 3, kv = (k + 2) % 3;
  const float iu = 0.5f / hu, iv = 0.5f / hv;
  if (su1 > 1.f) overflow(home, 2 * ku, 1.f, su1, sv0, sv1, area * (1.f - tent_cdf(1.f - u, iu)));
  if (su0 < -1.f) overflow(home, 2 * ku + 1, su0, -1.f, sv0, sv1, area * tent_cdf(-1.f - u, iu));
  if (sv1 > 1.f) overflow(home, 2 * kv, su0, su1, 1.f, sv1, area * (1.f - tent_cdf(1.f - v, iv)));
  if (sv0 < -1.f) overflow(home, 2 * kv + 1, su0, su1, sv0, -1.f, area * tent_cdf(-1.f - v, iv));

  // 3. Rescale so that the pieces add up to exactly the splat's solid angle.
  if (!(covered_ > 0.f) || candidates_.empty()) return;
  const float* solid = layout_.solid_angles();
  const float scale = omega / covered_;
  // The tent blurs the splat, which lowers its cosine-weighted solid angle
  // near the normal (by 8% for a 0.28 sr splat). When the whole footprint
  // is above the horizon, the weights are rescaled to the exact value for
  // a cap of the splat's solid angle: Omega cos(theta) (1 + cos(rho)) / 2.
  const float cos_center = buffer_.normal().dot(dir);
  const float reach = std::min(1.f, 3.f * major);
  float weight_scale = scale;
  if (cos_center > reach) {
    float weight = 0.f;
    for (const Candidate& c : candidates_) weight += c.fraction * solid[c.pixel] * c.cosine;
    const float rho2 = major * minor;
    const float target = omega * cos_center * (1.f - 0.25f * rho2);  // (1 + cos rho) / 2
    if (weight > 0.f) weight_scale = target / weight;
  }
  for (const Candidate& c : candidates_) {
    buffer_.add_coverage(c.pixel, depth, c.fraction * scale,
                         c.fraction * weight_scale * solid[c.pixel] * c.cosine, radiance);
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
  const float u0 = std::max(-1.f, uc - 2.f * hu), u1 = std::min(1.f, uc + 2.f * hu);
  const float v0 = std::max(-1.f, vc - 2.f * hv), v1 = std::min(1.f, vc + 2.f * hv);
  if (u0 >= u1 || v0 >= v1) return;
  const uint32_t n = layout_.resolution();
  const float pw = layout_.pixel_width();
  const float inv_pw = 1.f / pw;
  // Plane area of the whole tent over one pixel's.
  const float scale = 4.f * hu * hv * inv_pw * inv_pw;
  const float* solid = layout_.solid_angles();
  float nu, nv, nw;
  CubeLayout::face_coords(face, buffer_.normal(), nu, nv, nw);
  const uint32_t i0 = std::min(n - 1, uint32_t((u0 + 1.f) * inv_pw));
  const uint32_t i1 = std::min(n - 1, uint32_t((u1 + 1.f) * inv_pw));
  const uint32_t j0 = std::min(n - 1, uint32_t((v0 + 1.f) * inv_pw));
  const uint32_t j1 = std::min(n - 1, uint32_t((v1 + 1.f) * inv_pw));
  // The tent is separable: its mass over a pixel is the product of the
  // masses of the pixel's column and row.
  const float inv_u = 0.5f / hu, inv_v = 0.5f / hv;
  float mass_u[CubeLayout::kMaxResolution], mid_u[CubeLayout::kMaxResolution];
  for (uint32_t i = i0; i <= i1; ++i) {
    const float lo = -1.f + pw * float(i);
    const float a = std::max(u0, lo), b = std::min(u1, lo + pw);
    mass_u[i] = b > a ? tent_cdf(b - uc, inv_u) - tent_cdf(a - uc, inv_u) : 0.f;
    mid_u[i] = 0.5f * (a + b);
  }
  for (uint32_t j = j0; j <= j1; ++j) {
    const float lo_v = -1.f + pw * float(j);
    const float a_v = std::max(v0, lo_v), b_v = std::min(v1, lo_v + pw);
    if (b_v <= a_v) continue;
    const float mass_v = (tent_cdf(b_v - vc, inv_v) - tent_cdf(a_v - vc, inv_v)) * scale;
    const float mid_v = 0.5f * (a_v + b_v);
    const float row_cos = nv * mid_v + nw, row_len = 1.f + mid_v * mid_v;
    const uint32_t row = layout_.index(face, 0, j);
    for (uint32_t i = i0; i <= i1; ++i) {
      const float fraction = mass_u[i] * mass_v;
      if (!(fraction > 0.f)) continue;
      const uint32_t k = row + i;
      covered_ += fraction * solid[k];
      // Parts below the horizon count in `covered_` (that share of the
      // splat is lost to the receiver) but get no fragment.
      const float m = mid_u[i];
      const float cosine = (nu * m + row_cos) / std::sqrt(row_len + m * m);
      if (cosine > 0.f) candidates_.push_back({k, fraction, cosine});
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
  // The receiver's normal in face coordinates: the cosine at plane point
  // (u, v) is (nu u + nv v + nw) / sqrt(1 + u^2 + v^2).
  float nu, nv, nw;
  CubeLayout::face_coords(face, buffer_.normal(), nu, nv, nw);
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
      covered_ += fraction * solid[k];
      // Parts below the horizon count in `covered_` (that share of the
      // splat is lost to the receiver) but get no fragment.
      const float mid_u = 0.5f * (a_u + b_u);
      const float cosine =
          (nu * mid_u + nv * mid_v + nw) / std::sqrt(1.f + mid_u * mid_u + mid_v * mid_v);
      if (cosine > 0.f) candidates_.push_back({k, fraction, cosine});
    }
  }
}

uint32_t Rasterizer::raycast(const Imath::V3f& offset, const Imath::V3f& normal, float radius,
                             const Imath::C3f& radiance) {
  const float d2 = offset.length2();
  const float r2 = radius * radius;
  const float plane = normal.dot(offset);  // < 0: the receiver is in front
  if (!(plane < 0.f) || !(radius > 0.f)) return 0;
  Imath::V3f axis(0, 0, 1);
  float sin_a = 1.f, cos_a = -1.f;  // whole sphere when the receiver is inside the disk's sphere
  if (d2 > r2 * 1.0001f) {
    const float d = std::sqrt(d2);
    axis = offset / d;
    sin_a = radius / d;
    cos_a = std::sqrt(std::max(0.f, 1.f - sin_a * sin_a));
  }
  const float* dx = layout_.dir_x();
  const float* dy = layout_.dir_y();
  const float* dz = layout_.dir_z();
  uint32_t hits = 0;
  for (int face = 0; face < CubeLayout::kFaces; ++face) {
    PixelRect rect;
    if (!layout_.cone_pixels(face, axis, sin_a, cos_a, rect)) continue;
    for (uint32_t j = rect.j0; j <= rect.j1; ++j) {
      for (uint32_t i = rect.i0; i <= rect.i1; ++i) {
        const uint32_t k = layout_.index(face, i, j);
        if (!buffer_.in_hemisphere(k)) continue;
        const float den = normal.x * dx[k] + normal.y * dy[k] + normal.z * dz[k];
        if (!(den < 0.f)) continue;  // parallel to or leaving the disk's plane
        const float t = plane / den;
        const float hx = dx[k] * t - offset.x, hy = dy[k] * t - offset.y, hz = dz[k] * t - offset.z;
        if (hx * hx + hy * hy + hz * hz <= r2) {
          buffer_.add_hit(k, t, radiance);
          ++hits;
        }
      }
    }
  }
  return hits;
}

}  // namespace pbgi::gather
