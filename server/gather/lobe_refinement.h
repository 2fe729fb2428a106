// The importance-driven adaptive microbuffer of a glossy receiver
// (docs/gather.md, "Glossy receivers").
//
// The GGX specular lobe (server/scene/brdf.h, specular part only) is
// represented by kLobeSamples directions drawn with brdf.h's own sampler
// (visible normals, a fixed stratified pattern), each carrying f cos / pdf:
// binned into microbuffer pixels, they give every pixel the lobe's weight
// over that pixel, integral of f_spec(w, v) cos dw, at any resolution and
// for any roughness (a lobe narrower than a pixel lands whole in it, which
// point evaluation at pixel centers would miss).
//
// Each pixel of the receiver's coarse microbuffer (N per face side) is the
// root of a quadtree: a cell is split into four while its importance is
// more than `importance`, down to cells of the finest cube
// (N 2^L per side, GatherOptions::effective_glossy_resolution()). The
// deepest level reached inside a coarse pixel is that pixel's level.
//
// A cell's importance mixes two shares, each summing to 1 over the lobe:
//   (1 - b) x the lobe's weight in the cell / the lobe's total
//   + b x the lobe's weight x incoming radiance in the cell / the total,
// b = `radiance_weight` (GatherOptions::glossy_radiance_weight). Incoming
// radiance is what the coarse microbuffer resolved in the cell's coarse
// pixel: the lobe's tail is refined where it meets a bright source (a
// small light, a sunlit patch) and left coarse where it sees darkness,
// which matters little to the integral. Under uniform light both shares
// are equal and refinement follows the lobe alone (as b = 0 always does).
//
// Two estimates of the lobe's weight over a pixel. A narrow lobe (GGX
// alpha below kWideLobePixels finest pixels) is binned from its samples:
// it may be narrower than a pixel, which point evaluation would miss. A
// wide lobe is evaluated at every pixel's direction (f_spec there, times
// the pixel's exact cosine weight): its samples are too sparse in the
// tail, where a pixel that holds none would get no weight at all, and a
// bright source there would vanish or, caught by one sample, flare. A wide
// lobe refines a coarse pixel whose importance exceeds `importance`
// straight to the finest level (each of its fine pixels then evaluates the
// lobe at its own direction).
// Unrefined pixels are convolved with the lobe in the coarse buffer
// (coarse_gain); refined ones are gathered again in a fine buffer by a walk
// that only visits nodes whose cone reaches a refined pixel, with a cut
// that follows the finest cell there (cut()), and convolved per fine pixel
// (fine_gain).
//
// Thread-safety: none; one per Gatherer. No allocation per receiver once
// the scratch has grown.
#pragma once

#include "server/gather/cube_layout.h"
#include "server/gather/gather.h"
#include "server/gather/microbuffer.h"

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi {
class Brdf;
}

namespace pbgi::gather {

class LobeRefinement {
 public:
  // Directions representing a lobe (a 16 x 16 stratified pattern).
  static constexpr uint32_t kLobeSamples = 256;
  // A lobe is wide when its alpha spans this many finest pixels.
  static constexpr float kWideLobePixels = 1.f;

  // `coarse`: the receiver microbuffer's layout; `fine`: the finest cube,
  // a power-of-two multiple of it (equal: no refinement, the fixed
  // buffer); `max_solid_angle`: the gather's cut bound.
  LobeRefinement(const CubeLayout& coarse, const CubeLayout& fine, float importance,
                 float radiance_weight, float max_solid_angle);

  // Starts a receiver of unit normal n with an active lobe: samples it,
  // bins the samples and builds the quadtree levels. `light`: the coarse
  // buffer's resolved light per pixel (Microbuffer::resolve), whose
  // radiance (light / the pixel's cosine weight in `coarse`, begun for
  // this receiver) drives the radiance share of the importance.
  void begin(const Imath::V3f& n, const GlossyLobe& lobe, std::span<const PixelLight> light,
             const Microbuffer& coarse);

  // Per coarse pixel: the lobe's weight over the pixel divided by the
  // pixel's cosine weight in `coarse` (begun for this receiver), so that
  // Microbuffer::resolve's reflected sum is the lobe's convolution; 0 for
  // refined pixels (gathered in the fine buffer).
  const Imath::C3f* coarse_gain(const Microbuffer& coarse);
  // The same per fine pixel inside refined coarse pixels (0 elsewhere),
  // against `fine` (begun for this receiver).
  const Imath::C3f* fine_gain(const Microbuffer& fine);

  // Whether the lobe begun is evaluated per pixel (wide) or binned.
  bool wide() const { return wide_; }
  // Whether any coarse pixel is refined (then the fine walk is needed).
  bool refined() const { return refined_count_ > 0; }
  uint32_t refined_pixels() const { return refined_count_; }
  // Sum of the lobe's weights: its directional albedo (per channel).
  const Imath::C3f& albedo() const { return total_; }

  // The fine walk's cut for a node of bounding radius r at offset v
  // (d2 = |v|^2) from the receiver: the solid angle of the finest cell of
  // the refined pixels its (widened) cone reaches, bounded by
  // max_solid_angle; < 0 when it reaches none (then nothing below it
  // matters to the fine buffer). A node around the receiver gets the
  // finest cut.
  float cut(const Imath::V3f& v, float d2, float r) const;

 private:
  struct Sample {
    uint32_t fine;    // fine pixel index
    uint32_t coarse;  // coarse pixel index
    Imath::C3f weight;
  };
  // begin()'s quadtree for a wide lobe (evaluated per pixel) and for a
  // narrow one (binned from its samples).
  void begin_wide(const Brdf& brdf, const Imath::V3f& n, const Imath::V3f& view, const Microbuffer& coarse);
  void begin_binned();
  // The coarse pixel holding a fine one.
  uint32_t coarse_of(uint32_t fine) const;
  // The quadtree cell of a fine pixel at `level` (0 = coarse pixel).
  uint64_t cell_key(uint32_t fine, uint32_t level) const;

  const CubeLayout& coarse_;
  const CubeLayout& fine_;
  const uint32_t levels_;  // L: fine = coarse x 2^L
  const float importance_;
  const float radiance_weight_;
  float wide_alpha_;  // alphas at or above it are wide lobes
  bool wide_ = false;
  std::vector<uint32_t> hemisphere_;  // coarse pixels with a wide-lobe gain
  Imath::C3f scale_{1, 1, 1};         // evaluated lobe -> its sampled albedo
  std::vector<float> level_cut_;  // per level: cut solid angle
  float pixel_half_diagonal_;     // largest center-to-corner angle of a coarse pixel

  std::vector<Sample> samples_;
  std::vector<float> share_;     // per sample: its importance (sums to 1)
  std::vector<float> radiance_;  // per coarse pixel: mean incoming radiance, reset through light pixels
  std::vector<uint32_t> lit_;    // coarse pixels whose radiance_ is set
  Imath::C3f total_{0, 0, 0};
  std::vector<uint8_t> level_;        // per coarse pixel
  std::vector<Imath::C3f> coarse_mass_;
  std::vector<Imath::C3f> coarse_gain_;
  std::vector<Imath::C3f> fine_gain_;  // reset through fine_touched_
  // A wide lobe's f_spec at each finest pixel of hemisphere_'s coarse
  // pixels (evaluated once by begin(); fine_gain() scales it).
  std::vector<Imath::C3f> fine_f_;
  std::vector<uint32_t> fine_touched_;
  std::vector<uint32_t> refined_list_;
  uint32_t refined_count_ = 0;
  uint32_t max_level_ = 0;
  // A cone holding every refined coarse pixel: quick rejection in cut().
  Imath::V3f region_axis_{0, 0, 1};
  float region_angle_ = 0.f;
  struct Cell {
    uint64_t key;
    float mass;
    uint32_t coarse;
  };
  std::vector<Cell> scratch_;
};

}  // namespace pbgi::gather
