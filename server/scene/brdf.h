// The surface BRDF of a Material, UsdPreviewSurface-like: a Lambert diffuse
// lobe plus a GGX microfacet specular lobe (Walter et al. 2007, "Microfacet
// Models for Refraction through Rough Surfaces"), with the height-correlated
// Smith masking-shadowing term (Heitz 2014, "Understanding the Masking-
// Shadowing Function in Microfacet-Based BRDFs") and Schlick's Fresnel.
//
//   f(wo, wi) = diffuse / pi + D(h) G2(wo, wi) F(wi.h) / (4 |n.wo| |n.wi|)
//
// Lobe parameters, from the UsdPreviewSurface specification:
//  * metallic workflow (default): diffuse = albedo (1 - metallic),
//    F0 = lerp(((ior - 1) / (ior + 1))^2, albedo, metallic);
//  * specular workflow (useSpecularWorkflow = 1): diffuse = albedo,
//    F0 = specularColor;
//  * alpha = roughness^2, clamped to kMinAlpha so that a "perfect mirror"
//    stays a (very narrow) finite lobe the sampler and the pdf agree on.
// The specular lobe is dropped, leaving pure Lambert f = albedo / pi, when
// a metallic-workflow material is fully rough and not metallic (roughness
// >= 1, metallic <= 0), or a specular-workflow one has a black
// specularColor. The first rule is an approximation (a roughness-1
// dielectric reflects ~4% through a lobe close to diffuse) that keeps every
// matte scene rendering exactly as it did when all surfaces were Lambertian,
// and matching the PBGI gather, which is diffuse.
//
// Sampling (one sample, mixture of the lobes): the specular lobe is chosen
// with a probability that depends on wo only (Fresnel at wo against the
// diffuse reflectance), the half vector from the distribution of visible
// normals (Heitz 2018, "Sampling the GGX Distribution of Visible Normals"),
// the diffuse direction cosine-weighted. pdf() is the pdf of that mixture,
// so sample() and pdf() agree and the path tracer can MIS against lights.
//
// A Lambert-only Brdf samples, evaluates and weighs exactly (bit for bit) as
// the diffuse path tracer did: cosine_hemisphere with the same two numbers.
//
// Directions are world-space unit vectors pointing away from the surface;
// `n` is the shading normal facing the side wo is on. Thread-safety: a Brdf
// is an immutable value.
#pragma once

#include "server/scene/scene.h"

namespace pbgi {

// Smallest GGX alpha (= roughness^2): roughness 0.0316.
inline constexpr float kMinGgxAlpha = 1e-3f;

// Cosine-weighted direction around unit n (Malley's method over the
// concentric disk map, which keeps the spacing of u).
V3f cosine_hemisphere(const V3f& n, float u1, float u2);

// The lobe parameters a Material resolves to (see above); `albedo` is its
// diffuse colour at the shading point (textures applied).
struct BrdfLobes {
  C3f diffuse{0, 0, 0};  // Lambert reflectance
  C3f f0{0, 0, 0};       // specular reflectance at normal incidence
  float alpha = 1.f;     // GGX alpha
  bool specular = false; // whether the GGX lobe exists
};
BrdfLobes brdf_lobes(const Material& m, const C3f& albedo);

struct BrdfSample {
  V3f wi{0, 0, 0};
  C3f weight{0, 0, 0};  // f(wo, wi) |n.wi| / pdf
  float pdf = 0.f;      // solid angle; 0 = no sample
};

class Brdf {
 public:
  Brdf(const BrdfLobes& lobes, const V3f& n);

  bool is_lambert() const { return !lobes_.specular; }
  // True if the surface reflects nothing (no sampling or NEE is worth it).
  bool is_black() const;
  const BrdfLobes& lobes() const { return lobes_; }

  // f(wo, wi), without the cosine; 0 if wi (or, for the specular lobe, wo)
  // is below the shading hemisphere.
  C3f eval(const V3f& wo, const V3f& wi) const;
  // Solid-angle pdf of sample(wo, ...) returning wi.
  float pdf(const V3f& wo, const V3f& wi) const;
  // A direction from uniform numbers u1, u2 in [0, 1) (u1 also picks the
  // lobe, remapped, so a Lambert-only Brdf consumes the same two numbers as
  // cosine_hemisphere).
  BrdfSample sample(const V3f& wo, float u1, float u2) const;

 private:
  // Probability of sampling the specular lobe for this wo.
  float specular_probability(float cos_o) const;
  C3f eval_specular(const V3f& wo_local, const V3f& wi_local) const;
  float pdf_specular(const V3f& wo_local, const V3f& wi_local) const;
  V3f to_local(const V3f& w) const { return {w.dot(t_), w.dot(b_), w.dot(n_)}; }
  V3f to_world(const V3f& w) const { return w.x * t_ + w.y * b_ + w.z * n_; }

  BrdfLobes lobes_;
  V3f n_, t_, b_;
};

}  // namespace pbgi
