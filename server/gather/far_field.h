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
// pixel to a FarPixel of two layers:
//  - front: the nearest surface cluster, with its depth interval and
//    coverage, so that a receiver's near fragments of the same surface
//    (a wall crossing the near/far distance) merge with it and add their
//    coverage, as fragments of one surface do;
//  - rest: everything behind it, composited front to back from its own
//    start (not attenuated by the front layer: the receiver attenuates it by
//    whatever lies in front, the front layer included).
// Each layer holds transmittance-weighted sums S = sum T omega L,
// O = sum T omega, M = sum T omega m (and O, M over the clusters nearer
// than ao_max_distance, for AO). A receiver with normal n takes from a layer
// in pixel k
//   irradiance  S (n . M) / O   when the pixel lies wholly above its horizon,
//               S w_k / Omega_k otherwise (w_k its cosine weight, as a hit),
//   occlusion   n . M  (resp. O w_k / Omega_k),
// i.e. the radiance-weighted and the solid-angle-weighted mean directions
// of a layer's content in one pixel are taken to be the same.
//
// Thread-safety: none; one per Gatherer. No allocation per cluster once
// the fragment pool has grown.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/gather/fragment_surface.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace pbgi::gather {

// One layer of a pixel's far content (see above).
struct FarLayer {
  float r, g, b;      // S: sum T omega L
  float occ;          // O: sum T omega
  float mx, my, mz;   // M: sum T omega m
  float ao_occ;       // O and M of the clusters nearer than ao_max_distance
  float ao_mx, ao_my, ao_mz;
};

struct FarPixel {
  FarLayer front, rest;
  float front_near, front_far;  // depth interval of the front cluster
  float front_alpha;            // its coverage (unclamped sum)
  float rest_z;                 // where the rest starts (if rest_alpha > 0)
  float rest_alpha;             // 1 - transmittance through the rest
  FragmentSurface front_surface;  // the front cluster's first known surface, if any
};

class FarBuffer {
 public:
  FarBuffer(const CubeLayout& layout, float depth_band);

  const CubeLayout& layout() const { return layout_; }

  // Drops all fragments (a new cluster).
  void begin();
  // Drops all fragments and takes `other`'s (unresolved) ones: a smaller
  // cluster inside `other`'s starts from its far content (the view-tree
  // gather, view_tree_gather.h). Both must share the layout.
  void begin_from(const FarBuffer& other);
  // A splat fragment: covers the fraction `alpha` of pixel k (omega sr) at
  // `depth`, with moment m per unit solid angle and `radiance`.
  void add(uint32_t k, float depth, float alpha, float omega, const Imath::V3f& m,
           const Imath::C3f& radiance) {
    add(k, depth, depth, alpha, omega, m, radiance);
  }
  // The same over the depth interval [near, far] (microbuffer.h).
  // `surface`: the one it lies on, if known (microbuffer.h, rule 3: a
  // surface lying behind another's plane within a cluster counts only over
  // what those in front leave; the planes are those seen from the
  // cluster's active receiver).
  void add(uint32_t k, float near, float far, float alpha, float omega, const Imath::V3f& m, const Imath::C3f& radiance,
           SurfaceId surface = {}) {
    if (!(alpha > 0.f) || !(omega > 0.f) || !std::isfinite(near) || !std::isfinite(far)) return;
    Fragment f{near,        far,         alpha,       omega, radiance.x * omega, radiance.y * omega, radiance.z * omega,
               m.x * omega, m.y * omega, m.z * omega, -1,    surface.index};
    push(k, f);
  }
  // Registers the surface that the fragments added with the returned id
  // lie on, until the next begin() (Microbuffer::add_surface).
  SurfaceId add_surface(const FragmentSurface& s) { return planes_.add(s); }
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
    uint32_t surface;  // in planes_ (0: unknown)
  };
  void push(uint32_t k, const Fragment& f);
  // Whether f may merge into g (same band): resolve() adds them up anyway.
  bool merges(const Fragment& g, const Fragment& f, uint32_t k) const;
  // Scales the fragments sorted_[begin, end) of one cluster of pixel k that
  // lie behind the plane of a surface in front of them to what that
  // leaves of the pixel (microbuffer.h, rule 3).
  void trim_hidden(uint32_t k, size_t begin, size_t end);

  const CubeLayout& layout_;
  float grow_;  // 1 + depth band
  std::vector<uint32_t> stamp_;
  std::vector<int32_t> head_;
  uint32_t generation_ = 0;
  std::vector<uint32_t> touched_;
  std::vector<Fragment> fragments_;
  std::vector<Fragment> sorted_;
  std::vector<FarPixel> resolved_;
  std::vector<float> depth_;  // scratch of trim_hidden()
  SurfaceTable planes_;       // the surfaces of the fragments
};

}  // namespace pbgi::gather
