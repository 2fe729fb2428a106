// The per-receiver cube microbuffer, kept as an A-buffer: each pixel holds
// the list of fragments (depth interval, coverage alpha, cosine weight,
// weighted radiance) rasterized into it, and visibility is resolved once,
// when the receiver's cut is complete. That makes the result independent of
// traversal order.
//
// Compositing rule (resolve, per pixel):
//  1. Sort the pixel's fragments by depth.
//  2. Cluster them into surfaces: walking front to back, a fragment joins the
//     current cluster when its depth is within a relative band of the
//     cluster's farthest depth so far, z <= z_far * (1 + depth_band); a
//     larger gap starts a new cluster. Pieces of one surface (neighbouring
//     splats and ray-cast surfels) land at nearby depths and are chained.
//  3. Within a cluster, fragments are grouped by surface
//     (fragment_surface.h): the same normal and plane, known for flat nodes
//     and surfels, unknown for wide-cone nodes (those join the nearest
//     surface). A surface's coverage is alpha = (covered samples / 16) +
//     sum of splat alphas. Ray-cast hits of overlapping disks do not add
//     up: a hit means a sample point of the pixel sees the surface, and the
//     hits of a surface cover the union of their samples. Splat coverage of
//     one surface is deliberately not clamped at 1: a splat has exactly its
//     node's solid angle, so where neighbouring splats overlap in one pixel
//     they leave a gap in another, and clamping would turn every overlap
//     into lost energy (a 2-3% darkening that grows with resolution).
//     Surfaces are taken front to back by where the pixel's center ray
//     meets their plane. Surfaces side by side (a floor meeting a wall in a
//     corner: neither lies behind the other's plane) add up as pieces of
//     one surface do. A surface lying behind the plane of one in front of
//     it (the ground just behind a wall's foot, the ground 2 cm below a
//     floor) counts only over what those in front leave of the pixel: its
//     hits lose the samples hit in front, its splats are scaled down to
//     1 - the coverage in front. Before surfaces were told apart, such
//     ground joined the wall's cluster and added its light: most of the
//     light seen inside a closed room on a sunlit ground.
//     To keep lists short, add_*() merges fragments that this rule would
//     add up anyway (same kind, depth within the band, one surface or
//     neither behind the other). Fragments name their surface by an index
//     into the receiver's SurfaceTable (fragment_surface.h): splats of one
//     surface share an index and merge on an integer comparison.
//  4. Clusters composite front to back: each passes max(0, 1 - alpha) of
//     what lies behind it.
// AO counts only the clusters that start nearer than ao_max_distance (if it
// is > 0); the final AO is clamped to [0, 1].
//
// Convolution: visibility is per pixel, but each fragment carries its own
// cosine-weighted solid angle. A splat fragment's is its share of the
// pixel's solid angle times the cosine at the center of the part of the
// pixel it covers, so a small source is weighted by its own direction, not
// by the pixel's (at N = 4 a pixel spans 26 degrees). A ray-cast hit gets
// the pixel's weight, Omega_k * max(0, n . m_k) with m_k the pixel's exact
// mean direction, normalized so that the weights of the hemisphere sum to
// pi. Then E = sum over clusters of transmittance * sum weight * radiance,
// and AO = 1 - sum transmittance * weight / pi.
//
// Factorized PBGI: resolve() can take a cluster's FarBuffer (far_field.h).
// Its resolved content is composited per pixel at the depth where it
// starts: near clusters in front of it attenuate it, and it attenuates
// near clusters behind it by its own transmittance.
//
// Thread-safety: none; one per Gatherer. No allocation per receiver once
// the fragment pool has grown to its working size.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/gather/fragment_surface.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace pbgi::gather {

class FarBuffer;

struct Resolved {
  Imath::C3f irradiance{0, 0, 0};
  float ao = 1.f;
  // With a per-pixel gain: sum over pixels of gain x the pixel's part of
  // the irradiance (the glossy lobe's convolution, lobe_refinement.h).
  Imath::C3f reflected{0, 0, 0};
  // Sum over pixels of the occluded cosine weight (AO's occlusion) times
  // the pixel's direction: what the bent normal leaves out. Zero unless
  // the buffer tracks it (Microbuffer::track_occluded).
  Imath::V3f occluded{0, 0, 0};
};

// One pixel's resolved light: sum of transmittance x cosine-weighted
// solid angle x radiance over what the pixel sees (its share of the
// irradiance).
struct PixelLight {
  uint32_t pixel;
  Imath::C3f light;
};

class Microbuffer {
 public:
  Microbuffer(const CubeLayout& layout, float depth_band);

  const CubeLayout& layout() const { return layout_; }
  float depth_band() const { return band_; }

  // Starts a new receiver with unit normal n: drops all fragments and
  // computes every pixel's cosine weight.
  void begin(const Imath::V3f& n);

  // The receiver's unit normal.
  const Imath::V3f& normal() const { return normal_; }
  // Cosine weight of pixel k for the current receiver; 0 outside its
  // hemisphere.
  float weight(uint32_t k) const { return weight_[k]; }
  bool in_hemisphere(uint32_t k) const { return weight_[k] > 0.f; }

  // Adds a splat fragment: it covers the fraction `alpha` of pixel k over
  // the depth interval [near, far] (the extent of the piece of surface
  // along the view: a wall seen at a grazing angle recedes across its
  // splats, and pieces of it whose intervals chain belong to one surface),
  // has the cosine-weighted solid angle `weight` (> 0) and shows `radiance`.
  // `surface`: the one it lies on (add_surface()), if known.
  void add_coverage(uint32_t k, float near, float far, float alpha, float weight, const Imath::C3f& radiance,
                    SurfaceId surface = {}) {
    if (!(alpha > 0.f) || !(weight > 0.f)) return;
    // Fast path: the pixel's fragment that took the last one (added or
    // merged) is a splat of the same surface (the common case: neighbouring
    // splats of one surface), or of one found beside it, by index
    // (SurfaceTable). push() tries the rest.
    if (stamp_[k] == generation_) {
      Fragment& g = fragments_[hot_[k]];
      if (g.alpha > 0.f && far * grow_ >= g.near && near <= g.far * grow_ &&
          (surface.index == g.surface || surface.index == g.beside)) {
        g.near = std::min(g.near, near);
        g.far = std::max(g.far, far);
        g.alpha += alpha;
        g.weight += weight;
        g.r += radiance.x * weight;
        g.g += radiance.y * weight;
        g.b += radiance.z * weight;
        return;
      }
    }
    push(k, {near, far, alpha, weight, radiance.x * weight, radiance.y * weight, radiance.z * weight, 0u, -1,
             surface.index, 0u});
  }
  void add_coverage(uint32_t k, float near, float far, float alpha, float weight, const Imath::C3f& radiance,
                    const FragmentSurface& surface) {
    add_coverage(k, near, far, alpha, weight, radiance, add_surface(surface));
  }
  void add_coverage(uint32_t k, float depth, float alpha, float weight,
                    const Imath::C3f& radiance) {
    add_coverage(k, depth, depth, alpha, weight, radiance);
  }
  // Ray-cast hits are taken at kHitSamples (4 x 4) points of a pixel; a
  // hit fragment carries the mask of the points that meet its surface.
  static constexpr uint32_t kHitSamples = 16;
  static constexpr uint32_t kAllSamples = (1u << kHitSamples) - 1;

  // Adds a ray-cast hit: the sample points `mask` of pixel k meet a surface
  // at `depth` showing `radiance` (the default: the whole pixel).
  void add_hit(uint32_t k, float depth, const Imath::C3f& radiance,
               uint32_t mask = kAllSamples) {
    add_hit(k, depth, depth, radiance, mask);
  }
  // The same with the depth interval of the samples' hits.
  void add_hit(uint32_t k, float near, float far, const Imath::C3f& radiance, uint32_t mask, SurfaceId surface = {}) {
    const float w = weight_[k];
    if (!(w > 0.f) || !(mask & kAllSamples)) return;
    push(k, {near, far, -1.f, w, radiance.x * w, radiance.y * w, radiance.z * w, mask, -1, surface.index, 0u});
  }

  // Registers the surface (fragment_surface.h) that the fragments added
  // with the returned id lie on, until the next begin(). Unknown: id 0.
  SurfaceId add_surface(const FragmentSurface& s) { return planes_.add(s); }

  // Resolves visibility (rule above) and convolves with the cosine lobe,
  // with the resolved far content of `far` if given. With `gain` (one
  // colour per pixel, e.g. the BRDF towards a view at the pixel's
  // direction), also sums each pixel's cosine-weighted light (near and
  // far) times its gain into `reflected`. With `light`, appends every
  // pixel's cosine-weighted light (replacing what it held): what a
  // glossy lobe needs to decide where to refine before convolving.
  Resolved resolve(float ao_max_distance, const FarBuffer* far = nullptr,
                   const Imath::C3f* gain = nullptr, std::vector<PixelLight>* light = nullptr);

  // Whether resolve() fills Resolved::occluded (for bent_normal()).
  void track_occluded(bool on) { track_occluded_ = on; }
  // The cosine-weighted mean unoccluded direction of the current receiver
  // after `r` = resolve(): sum over the hemisphere's pixels of weight x
  // direction, less r.occluded, normalized; the normal when nothing is
  // open. Occlusion counts as AO does (ao_max_distance).
  Imath::V3f bent_normal(const Resolved& r) const;
  // Ward's harmonic mean distance (irradiance caching, Ward 1988) of what
  // the current receiver's buffer holds: over the pixels wholly above its
  // horizon that hold a fragment, cosine-weighted, of the depth of each
  // one's nearest fragment; infinity when nothing was seen. Empty pixels
  // are left out rather than counted as infinitely far: a lone occluder in
  // an open hemisphere must still shrink the result to its distance. It
  // bounds how far the receiver's irradiance may be carried to a neighbour
  // (server/gather/irradiance_cache.h). Pixels straddling the horizon are
  // left out: they hold the receiver's own surface. Fog fragments
  // (volume_fragments.h) count as surfaces.
  float harmonic_mean_distance() const;
  size_t fragment_count() const { return fragments_.size(); }
  size_t touched_pixel_count() const { return touched_.size(); }

 private:
  // A fragment, or several merged ones of one kind and surface.
  struct Fragment {
    float near, far;  // depth interval
    float alpha;      // splat coverage (> 0), or minus the number of ray-cast hits
    float weight;     // cosine-weighted solid angle
    float r, g, b;    // radiance times weight
    uint32_t mask = 0;  // hits: the pixel's sample points they cover (union)
    int32_t next = -1;
    uint32_t surface = 0;  // in planes_ (0: unknown)
    // The last other surface merged into it as lying beside it (push()):
    // the next fragment of that surface merges without the planes' test.
    uint32_t beside = 0;
  };
  // Whether fragments a and b of two different surfaces in the pixel of
  // unit direction `dir` (same kind, within the band) may merge: resolve()
  // adds them up anyway when neither lies behind the other's plane (a
  // floor and a wall meeting in a corner).
  bool side_by_side(const Fragment& a, const Fragment& b, const Imath::V3f& dir) const {
    const FragmentSurface& sa = planes_[a.surface];
    const FragmentSurface& sb = planes_[b.surface];
    return !lies_behind(sa, dir * surface_depth(sb, dir, b.near, b.far, grow_)) &&
           !lies_behind(sb, dir * surface_depth(sa, dir, a.near, a.far, grow_));
  }

  void push(uint32_t k, const Fragment& f);
  // Resolves one depth cluster of pixel k, sorted_[begin, end), whose
  // fragments lie on more than one surface (rule 3): its light, cosine
  // weight and coverage.
  void resolve_surfaces(uint32_t k, size_t begin, size_t end, float& r, float& g, float& b, float& weight,
                        float& alpha);

  const CubeLayout& layout_;
  float band_;
  float grow_;  // 1 + band_
  bool track_occluded_ = false;
  Imath::V3f normal_{0, 0, 1};
  std::vector<float> weight_;
  std::vector<float> cos_;  // n . mean direction, unnormalized
  // A pixel's list is valid only when its stamp equals the generation, so
  // starting a receiver does not touch every pixel.
  std::vector<uint32_t> stamp_;
  std::vector<int32_t> head_;
  // The fragment of each pixel that took the last fragment added to it
  // (valid with the stamp). Where surfaces one behind the other keep two
  // fragments in a pixel, their splats alternate: the list's head would
  // then miss the fast path half of the time.
  std::vector<int32_t> hot_;
  uint32_t generation_ = 0;
  std::vector<uint32_t> touched_;
  std::vector<Fragment> fragments_;
  std::vector<Fragment> sorted_;  // scratch of resolve()
  SurfaceTable planes_;           // the surfaces of the receiver's fragments
  // Scratch of resolve_surfaces(): one entry per surface of a cluster.
  struct Surface {
    float depth;
    float alpha, w, r, g, b;     // splats
    float hits, hw, hr, hg, hb;  // ray-cast hits
    uint32_t mask;
    uint32_t surface;  // in planes_
  };
  std::vector<Surface> surfaces_;
};

}  // namespace pbgi::gather
