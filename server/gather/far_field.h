// The shared microbuffer of a receiver cluster (factorized PBGI, see
// docs/gather.md): far nodes of the cluster's cut, drawn once from the
// cluster's active receiver, resolved once, then composited behind each
// receiver's own near fragments.
//
// Unlike a receiver's Microbuffer it knows no normal: a fragment carries
// its solid angle omega (steradians of its pixel it covers), its radiance
// and the first moment per unit solid angle m of the splat it comes from
// ((1 + cos rho)/2 times the splat's direction, so that n . m omega is the
// exact cosine-weighted solid angle of a cap above the horizon of normal n).
//
// resolve() applies the compositing rule of microbuffer.h (sort, cluster by
// depth band, front to back with unclamped splat coverage) and reduces each
// pixel to a FarPixel: transmittance-weighted sums S = sum T omega L,
// O = sum T omega, M = sum T omega m (and the same restricted to clusters
// nearer than ao_max_distance for AO), the depth where far content starts
// and the transmittance through all of it. A receiver with normal n then
// takes from pixel k
//   irradiance  S (n . M) / O   when the pixel lies wholly above its horizon,
//               S w_k / Omega_k otherwise (w_k its cosine weight, as a hit),
//   occlusion   n . M  (resp. O w_k / Omega_k),
// i.e. the radiance-weighted and the solid-angle-weighted mean directions
// of the pixel's far content are taken to be the same.
//
// Thread-safety: none; one per Gatherer. No allocation per cluster once
// the fragment pool has grown.
#pragma once

#include "server/gather/cube_layout.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace pbgi::gather {

struct FarPixel {
  float r, g, b;            // S: sum T omega L
  float occ;                // O: sum T omega
  float mx, my, mz;         // M: sum T omega m
  float ao_occ;             // O and M of the clusters nearer than ao_max_distance
  float ao_mx, ao_my, ao_mz;
  float z;                  // depth where the far content starts
  float transmit;           // through all of it
};

class FarBuffer {
 public:
  FarBuffer(const CubeLayout& layout, float depth_band);

  const CubeLayout& layout() const { return layout_; }

  // Drops all fragments (a new cluster).
  void begin();
  // A splat fragment: covers the fraction `alpha` of pixel k (omega sr) at
  // `depth`, with moment m per unit solid angle and `radiance`.
  void add(uint32_t k, float depth, float alpha, float omega, const Imath::V3f& m,
           const Imath::C3f& radiance) {
    if (!(alpha > 0.f) || !(omega > 0.f) || !std::isfinite(depth)) return;
    Fragment f{depth, depth, alpha, omega, radiance.x * omega, radiance.y * omega,
               radiance.z * omega, m.x * omega, m.y * omega, m.z * omega, -1};
    push(k, f);
  }
  // Resolves every touched pixel into pixels()/pixel().
  void resolve(float ao_max_distance);

  // After resolve(): the pixels holding far content, and their content.
  const std::vector<uint32_t>& pixels() const { return touched_; }
  const FarPixel& pixel(uint32_t k) const { return resolved_[k]; }
  // Whether pixel k holds far content (valid between begin() calls).
  bool has(uint32_t k) const { return stamp_[k] == generation_; }
  size_t fragment_count() const { return fragments_.size(); }

 private:
  struct Fragment {
    float near, far;
    float alpha, omega;
    float r, g, b;     // omega L
    float mx, my, mz;  // omega m
    int32_t next;
  };
  void push(uint32_t k, const Fragment& f);

  const CubeLayout& layout_;
  float grow_;  // 1 + depth band
  std::vector<uint32_t> stamp_;
  std::vector<int32_t> head_;
  uint32_t generation_ = 0;
  std::vector<uint32_t> touched_;
  std::vector<Fragment> fragments_;
  std::vector<Fragment> sorted_;
  std::vector<FarPixel> resolved_;
};

}  // namespace pbgi::gather
