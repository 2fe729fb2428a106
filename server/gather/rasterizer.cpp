#include "server/gather/rasterizer.h"

#include "server/gather/far_field.h"
#include "server/gather/ray_depth_caps.h"
#include "server/gather/splat_filter.h"

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

namespace {

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
  float prev = a0 > s0 ? splat_tent_cdf(a0 - c, inv) : 0.f;
  float lo = a0;
  for (uint32_t i = i0; i <= i1; ++i) {
    const float edge = -1.f + pw * float(i + 1);
    const bool last = i == i1;
    const float hi = last ? b1 : edge;
    const float cdf = last ? (b1 < s1 ? splat_tent_cdf(b1 - c, inv) : 1.f) : splat_tent_cdf(edge - c, inv);
    mass[i - i0] = cdf - prev;
    mid[i - i0] = 0.5f * (lo + hi);
    prev = cdf;
    lo = hi;
  }
  return true;
}

}  // namespace

Rasterizer::Rasterizer(Microbuffer& buffer, const RayDepthCaps* caps)
    : buffer_(buffer),
      layout_(buffer.layout()),
      caps_(caps),
      inv_pw_(1.f / layout_.pixel_width()),
      batch_(std::make_unique<SplatBatch>()) {
  candidates_.reserve(layout_.pixel_count());
  kernel_layout_.resolution = layout_.resolution();
  kernel_layout_.pixel_width = layout_.pixel_width();
  kernel_layout_.inv_pixel_width = inv_pw_;
  kernel_layout_.solid_angles = layout_.solid_angles();
}

void Rasterizer::queue(const Imath::V3f& dir, const Shape& shape, float depth,
                       const Imath::C3f& radiance, FarBuffer* far) {
  if (!(shape.omega > 0.f) || !(depth > 0.f)) return;
  SplatBatch& b = *batch_;
  if (b.size == SplatBatch::kCapacity) flush();
  const size_t i = b.size++;
  b.dx[i] = dir.x;
  b.dy[i] = dir.y;
  b.dz[i] = dir.z;
  b.omega[i] = shape.omega;
  b.ratio[i] = shape.ratio;
  b.max_radius[i] = shape.max_radius;
  b.sx[i] = shape.squash.x;
  b.sy[i] = shape.squash.y;
  b.sz[i] = shape.squash.z;
  const float extent = std::clamp(shape.depth_extent, 0.f, 0.9f * depth);
  // A zero `facing` (unknown surface) gives a zero normal: still unknown.
  pending_[i] = {depth - extent,
                 depth + extent,
                 depth * (1.f - std::min(1.f, shape.max_radius)),
                 radiance,
                 far,
                 {shape.facing, depth * shape.facing.dot(dir), shape.plane_tolerance}};
}

void Rasterizer::flush() {
  SplatBatch& b = *batch_;
  if (b.size == 0) return;
  // The kernel's padding lanes (up to a vector past size) read whatever a
  // previous batch left: finite values, results unused.
  run_splat_kernel(kernel_layout_, b);
  for (size_t i = 0; i < b.size; ++i) {
    const Ellipse e{b.major[i], b.minor[i], b.home[i] >> 1, b.home[i],
                    b.u[i],     b.v[i],     b.hu[i],       b.hv[i]};
    if (!(e.hu > 0.f) || !(e.hv > 0.f) || !std::isfinite(e.hu * e.hv)) continue;
    if (pending_[i].far) {
      draw_far(i, e, pending_[i]);
    } else {
      draw(i, e, pending_[i]);
    }
  }
  b.size = 0;
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
  const float su0 = u - splat_support(hu), su1 = u + splat_support(hu);
  const float sv0 = v - splat_support(hv), sv1 = v + splat_support(hv);
  if (su0 < -1.f || su1 > 1.f || sv0 < -1.f || sv1 > 1.f) {
    const float tent_area = 4.f * hu * hv;  // the filter's total, in plane units
    const int ku = (e.k + 1) % 3, kv = (e.k + 2) % 3;
    const float iu = 1.f / hu, iv = 1.f / hv;
    const int home = e.home;
    if (su1 > 1.f)
      overflow(home, 2 * ku, 1.f, su1, sv0, sv1, tent_area * (1.f - splat_tent_cdf(1.f - u, iu)));
    if (su0 < -1.f)
      overflow(home, 2 * ku + 1, su0, -1.f, sv0, sv1, tent_area * splat_tent_cdf(-1.f - u, iu));
    if (sv1 > 1.f)
      overflow(home, 2 * kv, su0, su1, 1.f, sv1, tent_area * (1.f - splat_tent_cdf(1.f - v, iv)));
    if (sv0 < -1.f)
      overflow(home, 2 * kv + 1, su0, su1, sv0, -1.f, tent_area * splat_tent_cdf(-1.f - v, iv));
  }
  return covered_ > 0.f && !candidates_.empty();
}

void Rasterizer::splat(const Imath::V3f& dir, const Shape& shape, float depth,
                       const Imath::C3f& radiance) {
  queue(dir, shape, depth, radiance);
  flush();
}

void Rasterizer::splat_far(FarBuffer& far, const Imath::V3f& dir, const Shape& shape, float depth,
                           const Imath::C3f& radiance) {
  queue(dir, shape, depth, radiance, &far);
  flush();
}

void Rasterizer::draw(size_t i, const Ellipse& e, const Pending& p) {
  const SplatBatch& b = *batch_;
  const Imath::V3f dir(b.dx[i], b.dy[i], b.dz[i]);
  const float omega = b.omega[i];
  // The tent blurs the splat, which lowers its cosine-weighted solid angle
  // near the normal (by 8% for a 0.28 sr splat). When the whole footprint
  // is above the horizon, the weights are rescaled to the exact value for
  // a cap of the splat's solid angle: Omega cos(theta) (1 + cos(rho)) / 2.
  const float cos_center = buffer_.normal().dot(dir);
  const float reach = std::min(1.f, 3.f * e.major);
  const bool above = cos_center > reach;
  const float rho2 = e.major * e.minor;
  const float target = omega * cos_center * (1.f - 0.25f * rho2);  // (1 + cos rho) / 2
  const SurfaceId surface = buffer_.add_surface(p.surface);
  // Common case: wholly above the horizon and inside one face (the
  // kernel's masses). The cosine varies by a few percent over a splat;
  // weights are spread in proportion of solid angle, and their total is
  // exact.
  const float* solid = layout_.solid_angles();
  // Depth caps (ray_depth_caps.h): a fragment is hidden when even the
  // nearest point of the splat's bounding sphere lies beyond the pixel's
  // cap.
  const RayDepthCaps* caps = caps_ && caps_->active() ? caps_ : nullptr;
  if (above && b.inside[i]) {
    const float covered = b.covered[i];
    if (!(covered > 0.f)) return;
    // Coverage adds up to the splat's solid angle, weights to the target.
    const uint32_t n = layout_.resolution();
    const uint32_t base = layout_.index(e.home, 0, 0);
    const uint32_t i0 = uint32_t(b.i0[i]), j0 = uint32_t(b.j0[i]);
    const uint32_t ni = uint32_t(b.ni[i]), nj = uint32_t(b.nj[i]);
    const float scale = omega / covered, wscale = target / covered;
    for (uint32_t r = 0; r < nj; ++r) {
      const uint32_t row = base + (j0 + r) * n + i0;
      const float a_v = b.mv[r][i] * scale, w_v = b.mv[r][i] * wscale;
      for (uint32_t c = 0; c < ni; ++c) {
        const uint32_t k = row + c;
        const float m = b.mu[c][i];
        if (caps && caps->hides(k, p.front)) continue;
        buffer_.add_coverage(k, p.z0, p.z1, m * a_v, m * w_v * solid[k], p.radiance, surface);
      }
    }
    return;
  }
  if (!footprint(e, true)) return;
  // Rescale so that the pieces add up to exactly the splat's solid angle.
  const float scale = omega / covered_;
  const float weight_scale = above && weighted_ > 0.f ? target / weighted_ : scale;
  for (const Candidate& c : candidates_) {
    if (caps && caps->hides(c.pixel, p.front)) continue;
    buffer_.add_coverage(c.pixel, p.z0, p.z1, c.fraction * scale, c.fraction * weight_scale * solid[c.pixel] * c.cosine,
                         p.radiance, surface);
  }
}

void Rasterizer::draw_far(size_t i, const Ellipse& e, const Pending& p) {
  const SplatBatch& b = *batch_;
  const Imath::V3f dir(b.dx[i], b.dy[i], b.dz[i]);
  const float omega = b.omega[i];
  FarBuffer& far = *p.far;
  const float* solid = layout_.solid_angles();
  // Every piece carries the splat's exact first moment per unit solid
  // angle, (1 + cos rho)/2 dir, so that a receiver of normal n weights it
  // with the cap's exact cosine integral (see far_field.h).
  const float rho2 = e.major * e.minor;
  const Imath::V3f moment = dir * (1.f - 0.25f * rho2);
  const SurfaceId surface = far.add_surface(p.surface);
  if (b.inside[i]) {
    const float covered = b.covered[i];
    if (!(covered > 0.f)) return;
    const uint32_t n = layout_.resolution();
    const uint32_t base = layout_.index(e.home, 0, 0);
    const uint32_t i0 = uint32_t(b.i0[i]), j0 = uint32_t(b.j0[i]);
    const uint32_t ni = uint32_t(b.ni[i]), nj = uint32_t(b.nj[i]);
    const float scale = omega / covered;
    for (uint32_t r = 0; r < nj; ++r) {
      const uint32_t row = base + (j0 + r) * n + i0;
      const float a_v = b.mv[r][i] * scale;
      for (uint32_t c = 0; c < ni; ++c) {
        const uint32_t k = row + c;
        const float alpha = b.mu[c][i] * a_v;
        far.add(k, p.z0, p.z1, alpha, alpha * solid[k], moment, p.radiance, surface);
      }
    }
    return;
  }
  if (!footprint(e, false)) return;
  const float scale = omega / covered_;
  for (const Candidate& c : candidates_) {
    const float alpha = c.fraction * scale;
    far.add(c.pixel, p.z0, p.z1, alpha, alpha * solid[c.pixel], moment, p.radiance, surface);
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
  if (!tent_masses(uc, uc - splat_support(hu), uc + splat_support(hu), 1.f / hu, pw, n, i0, i1, mass_u,
                   mid_u) ||
      !tent_masses(vc, vc - splat_support(hv), vc + splat_support(hv), 1.f / hv, pw, n, j0, j1, mass_v,
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
                             const Imath::C3f& radiance, float plane_tolerance) {
  flush();  // queued splats come first, as if drawn when queued
  const float d2 = offset.length2();
  const float r2 = radius * radius;
  const float plane = normal.dot(offset);  // < 0: the receiver is in front
  if (!(plane < 0.f) || !(radius > 0.f)) return 0;
  const SurfaceId surface = buffer_.add_surface({normal, plane, plane_tolerance});
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
        if (mask && !(caps_ && caps_->active() && caps_->hides(k, z0))) {
          buffer_.add_hit(k, z0, z1, radiance, mask, surface);
          ++hits;
        }
      }
    }
  }
  (void)n;
  return hits;
}

}  // namespace pbgi::gather
