#include "server/scene/brdf.h"

#include "server/scene/sample_patterns.h"

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

// Largest float below 1: remapped lobe-selection numbers stay in [0, 1).
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

float luminance(const C3f& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
bool black(const C3f& c) { return !(c.x > 0.f || c.y > 0.f || c.z > 0.f); }

C3f schlick_fresnel(const C3f& f0, float cos_d) {
  const float m = std::clamp(1.f - cos_d, 0.f, 1.f);
  const float m5 = (m * m) * (m * m) * m;
  return f0 + (C3f(1.f, 1.f, 1.f) - f0) * m5;
}

// GGX normal distribution for a local half vector (z = normal).
float ggx_d(float cos_h, float alpha) {
  if (!(cos_h > 0.f)) return 0.f;
  const float a2 = alpha * alpha;
  const float k = cos_h * cos_h * (a2 - 1.f) + 1.f;
  return a2 / (kPi * k * k);
}

// Smith Lambda of GGX for a local direction.
float ggx_lambda(float cos_t, float alpha) {
  const float c2 = cos_t * cos_t;
  if (!(c2 > 0.f)) return 0.f;
  const float tan2 = std::max(0.f, 1.f - c2) / c2;
  return 0.5f * (std::sqrt(1.f + alpha * alpha * tan2) - 1.f);
}

// Heitz 2018: a visible normal for local wo (wo.z > 0) from u1, u2.
V3f sample_ggx_vndf(const V3f& wo, float alpha, float u1, float u2) {
  const V3f vh = V3f(alpha * wo.x, alpha * wo.y, wo.z).normalized();
  const float lensq = vh.x * vh.x + vh.y * vh.y;
  const V3f t1 = lensq > 0.f ? V3f(-vh.y, vh.x, 0.f) / std::sqrt(lensq) : V3f(1.f, 0.f, 0.f);
  const V3f t2 = vh.cross(t1);
  const float r = std::sqrt(u1), phi = 2.f * kPi * u2;
  const float p1 = r * std::cos(phi);
  const float s = 0.5f * (1.f + vh.z);
  const float p2 = (1.f - s) * std::sqrt(std::max(0.f, 1.f - p1 * p1)) + s * r * std::sin(phi);
  const V3f nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.f, 1.f - p1 * p1 - p2 * p2)) * vh;
  return V3f(alpha * nh.x, alpha * nh.y, std::max(0.f, nh.z)).normalized();
}

}  // namespace

V3f cosine_hemisphere(const V3f& n, float u1, float u2) {
  const Imath::V2f d = square_to_disk({u1, u2});
  const float z = std::sqrt(std::max(0.f, 1.f - d.x * d.x - d.y * d.y));
  V3f t, b;
  orthonormal_basis(n, &t, &b);
  return (d.x * t + d.y * b + z * n).normalized();
}

BrdfLobes brdf_lobes(const Material& m, const C3f& albedo) {
  BrdfLobes lobes;
  lobes.alpha = std::max(kMinGgxAlpha, m.roughness * m.roughness);
  if (m.use_specular_workflow) {
    lobes.diffuse = albedo;
    lobes.f0 = m.specular_color;
    lobes.specular = !black(m.specular_color);
    return lobes;
  }
  const float metallic = std::clamp(m.metallic, 0.f, 1.f);
  if (!(metallic > 0.f) && m.roughness >= 1.f) {
    lobes.diffuse = albedo;  // matte: Lambert only (see the header)
    return lobes;
  }
  const float r = (m.ior - 1.f) / (m.ior + 1.f);
  const float f0 = std::isfinite(r) ? r * r : 0.f;
  lobes.diffuse = albedo * (1.f - metallic);
  lobes.f0 = C3f(f0, f0, f0) * (1.f - metallic) + albedo * metallic;
  lobes.specular = !black(lobes.f0);
  return lobes;
}

Brdf::Brdf(const BrdfLobes& lobes, const V3f& n) : lobes_(lobes), n_(n) {
  orthonormal_basis(n_, &t_, &b_);
}

bool Brdf::is_black() const { return black(lobes_.diffuse) && !(lobes_.specular && !black(lobes_.f0)); }

float Brdf::specular_probability(float cos_o) const {
  if (!lobes_.specular || !(cos_o > 0.f)) return 0.f;
  const float s = luminance(schlick_fresnel(lobes_.f0, cos_o));
  const float d = luminance(lobes_.diffuse);
  return s + d > 0.f ? s / (s + d) : 0.f;
}

C3f Brdf::eval_specular(const V3f& wo, const V3f& wi) const {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return C3f(0, 0, 0);
  const V3f h_sum = wo + wi;
  if (!(h_sum.length2() > 0.f)) return C3f(0, 0, 0);
  const V3f h = h_sum.normalized();
  const float a = lobes_.alpha;
  const float g2 = 1.f / (1.f + ggx_lambda(wo.z, a) + ggx_lambda(wi.z, a));
  const float scale = ggx_d(h.z, a) * g2 / (4.f * wo.z * wi.z);
  return schlick_fresnel(lobes_.f0, wi.dot(h)) * scale;
}

float Brdf::pdf_specular(const V3f& wo, const V3f& wi) const {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
  const V3f h_sum = wo + wi;
  if (!(h_sum.length2() > 0.f)) return 0.f;
  const V3f h = h_sum.normalized();
  // D_wo(h) / (4 wo.h) with D_wo(h) = G1(wo) max(0, wo.h) D(h) / wo.z.
  const float g1 = 1.f / (1.f + ggx_lambda(wo.z, lobes_.alpha));
  return g1 * ggx_d(h.z, lobes_.alpha) / (4.f * wo.z);
}

C3f Brdf::eval(const V3f& wo, const V3f& wi) const {
  if (!(wi.dot(n_) > 0.f)) return C3f(0, 0, 0);
  const C3f diffuse = lobes_.diffuse * kInvPi;
  if (is_lambert()) return diffuse;
  return diffuse + eval_specular(to_local(wo), to_local(wi));
}

float Brdf::pdf(const V3f& wo, const V3f& wi) const {
  const float pdf_diffuse = std::max(0.f, wi.dot(n_)) * kInvPi;
  if (is_lambert()) return pdf_diffuse;
  const V3f wo_l = to_local(wo);
  const float p = specular_probability(wo_l.z);
  return p * pdf_specular(wo_l, to_local(wi)) + (1.f - p) * pdf_diffuse;
}

BrdfSample Brdf::sample(const V3f& wo, float u1, float u2) const {
  BrdfSample s;
  if (is_lambert()) {
    s.wi = cosine_hemisphere(n_, u1, u2);
    s.pdf = n_.dot(s.wi) * kInvPi;
    s.weight = lobes_.diffuse;
    return s;
  }
  const V3f wo_l = to_local(wo);
  const float p = specular_probability(wo_l.z);
  if (u1 < p) {
    const float u = std::min(u1 / p, kOneMinusEpsilon);
    const V3f h = sample_ggx_vndf(wo_l, lobes_.alpha, u, u2);
    const V3f wi_l = 2.f * wo_l.dot(h) * h - wo_l;
    if (!(wi_l.z > 0.f)) return s;  // reflected below the surface: no sample
    s.wi = to_world(wi_l).normalized();
  } else {
    const float u = std::min((u1 - p) / (1.f - p), kOneMinusEpsilon);
    s.wi = cosine_hemisphere(n_, u, u2);
  }
  s.pdf = pdf(wo, s.wi);
  if (!(s.pdf > 0.f)) {
    s.pdf = 0.f;
    return s;
  }
  s.weight = eval(wo, s.wi) * (std::max(0.f, s.wi.dot(n_)) / s.pdf);
  return s;
}

}  // namespace pbgi
