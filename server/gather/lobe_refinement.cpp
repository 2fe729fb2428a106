#include "server/gather/lobe_refinement.h"

#include "server/scene/brdf.h"

#include <algorithm>
#include <cmath>

namespace pbgi::gather {

namespace {

constexpr float kPiF = 3.14159265358979f;
constexpr uint32_t kSampleSide = 16;  // kLobeSamples = 16 x 16
static_assert(kSampleSide * kSampleSide == LobeRefinement::kLobeSamples);

// A splat's footprint reaches beyond its disk: the tent is twice the
// equal-area rectangle's width (rasterizer.h). The fine walk keeps a node
// whose cone, widened by this factor plus a fine pixel, reaches a refined
// pixel, so that no light spilling into refined pixels is missed.
constexpr float kFootprintWidening = 2.f;

uint32_t log2_ratio(uint32_t fine, uint32_t coarse) {
  uint32_t l = 0;
  while ((coarse << l) < fine) ++l;
  return l;
}

inline float mean(const Imath::C3f& c) { return (c.x + c.y + c.z) * (1.f / 3.f); }

}  // namespace

LobeRefinement::LobeRefinement(const CubeLayout& coarse, const CubeLayout& fine, float importance,
                               float max_solid_angle)
    : coarse_(coarse),
      fine_(fine),
      levels_(log2_ratio(fine.resolution(), coarse.resolution())),
      importance_(importance),
      level_(coarse.pixel_count(), 0),
      coarse_mass_(coarse.pixel_count(), Imath::C3f(0, 0, 0)),
      coarse_gain_(coarse.pixel_count(), Imath::C3f(0, 0, 0)),
      fine_gain_(levels_ > 0 ? fine.pixel_count() : 0, Imath::C3f(0, 0, 0)) {
  // A cell of level l is a pixel of the cube of N 2^l per side: the walk
  // cuts at that cube's mean pixel solid angle (as the diffuse cut does at
  // level 0, cut_walker.h), within the gather's bound.
  for (uint32_t l = 0; l <= levels_; ++l) {
    const float side = float(coarse.resolution() << l);
    level_cut_.push_back(std::min(max_solid_angle, 4.f * kPiF / (6.f * side * side)));
  }
  samples_.reserve(kLobeSamples);
  scratch_.reserve(kLobeSamples);
  // A pixel's center-to-corner angle is largest at a face's center,
  // atan(pixel width / sqrt 2).
  pixel_half_diagonal_ = std::atan(coarse.pixel_width() * 0.70710678f);
}

uint32_t LobeRefinement::coarse_of(uint32_t fine) const {
  // Derived from the fine pixel (not looked up again) so that a fine pixel
  // always lies in its coarse pixel, whatever the rounding.
  const uint32_t nf = fine_.resolution();
  const uint32_t i = fine % nf, j = (fine / nf) % nf, face = fine / (nf * nf);
  return coarse_.index(int(face), i >> levels_, j >> levels_);
}

uint64_t LobeRefinement::cell_key(uint32_t fine, uint32_t level) const {
  // Fine index = (face N' + j) N' + i with N' = N 2^L.
  const uint32_t nf = fine_.resolution();
  const uint32_t i = fine % nf, j = (fine / nf) % nf, face = fine / (nf * nf);
  const uint32_t shift = levels_ - level;
  return (uint64_t(face) << 40) | (uint64_t(j >> shift) << 20) | uint64_t(i >> shift);
}

void LobeRefinement::begin(const Imath::V3f& n, const GlossyLobe& lobe) {
  // 1. The lobe as weighted directions, from brdf.h's sampler (specular
  //    lobe only: no diffuse, so every sample is a GGX one).
  BrdfLobes lobes;
  lobes.f0 = lobe.specular;
  lobes.alpha = std::max(kMinGgxAlpha, lobe.roughness * lobe.roughness);  // brdf.h's rule
  lobes.specular = true;
  const Brdf brdf(lobes, n);
  for (const Sample& s : samples_) {
    coarse_mass_[s.coarse] = Imath::C3f(0, 0, 0);
    coarse_gain_[s.coarse] = Imath::C3f(0, 0, 0);
  }
  for (const uint32_t k : refined_list_) level_[k] = 0;
  refined_list_.clear();
  samples_.clear();
  total_ = Imath::C3f(0, 0, 0);
  constexpr float kInvSamples = 1.f / float(kLobeSamples);
  for (uint32_t a = 0; a < kSampleSide; ++a) {
    for (uint32_t b = 0; b < kSampleSide; ++b) {
      const BrdfSample s = brdf.sample(lobe.view, (float(a) + 0.5f) / kSampleSide,
                                       (float(b) + 0.5f) / kSampleSide);
      if (!(s.pdf > 0.f)) continue;
      const Imath::C3f w = s.weight * kInvSamples;
      if (!(mean(w) > 0.f) || !std::isfinite(mean(w))) continue;
      const uint32_t fine = fine_.pixel_of(s.wi);
      const uint32_t coarse = coarse_of(fine);
      samples_.push_back({fine, coarse, w});
      coarse_mass_[coarse] += w;
      total_ += w;
    }
  }

  // 2. The quadtree: a cell holding more than `importance` of the lobe is
  //    split; a coarse pixel's level is the deepest split inside it, + 1.
  refined_count_ = 0;
  max_level_ = 0;
  const float threshold = importance_ * mean(total_);
  if (levels_ == 0 || !(threshold > 0.f)) return;
  for (uint32_t level = 0; level < levels_; ++level) {
    scratch_.clear();
    for (const Sample& s : samples_) {
      scratch_.push_back({cell_key(s.fine, level), mean(s.weight), s.coarse});
    }
    std::sort(scratch_.begin(), scratch_.end(),
              [](const Cell& a, const Cell& b) { return a.key < b.key; });
    for (size_t i = 0; i < scratch_.size();) {
      size_t j = i;
      float mass = 0.f;
      for (; j < scratch_.size() && scratch_[j].key == scratch_[i].key; ++j) mass += scratch_[j].mass;
      if (mass > threshold) {
        const uint32_t k = scratch_[i].coarse;
        if (level_[k] == 0) refined_list_.push_back(k);
        level_[k] = uint8_t(std::max<uint32_t>(level_[k], level + 1));
        max_level_ = std::max(max_level_, level + 1);
      }
      i = j;
    }
  }
  refined_count_ = uint32_t(refined_list_.size());

  // 3. A cone around the refined pixels, for cut()'s quick rejection.
  Imath::V3f axis(0, 0, 0);
  for (const uint32_t k : refined_list_) axis += coarse_.direction(k);
  region_axis_ = axis.length() > 1e-6f ? axis.normalized() : n;
  float widest = 0.f;
  for (const uint32_t k : refined_list_) {
    const float c = std::clamp(region_axis_.dot(coarse_.direction(k)), -1.f, 1.f);
    widest = std::max(widest, std::acos(c) + pixel_half_diagonal_);
  }
  region_angle_ = widest;
}

const Imath::C3f* LobeRefinement::coarse_gain(const Microbuffer& coarse) {
  // Only pixels holding samples can be non-zero; the rest were zeroed when
  // they last held some.
  for (const Sample& s : samples_) {
    const uint32_t k = s.coarse;
    const float w = coarse.weight(k);
    coarse_gain_[k] = level_[k] == 0 && w > 0.f ? coarse_mass_[k] / w : Imath::C3f(0, 0, 0);
  }
  return coarse_gain_.data();
}

const Imath::C3f* LobeRefinement::fine_gain(const Microbuffer& fine) {
  for (const uint32_t k : fine_touched_) fine_gain_[k] = Imath::C3f(0, 0, 0);
  fine_touched_.clear();
  for (const Sample& s : samples_) {
    if (level_[s.coarse] == 0) continue;
    if (fine_gain_[s.fine] == Imath::C3f(0, 0, 0)) fine_touched_.push_back(s.fine);
    fine_gain_[s.fine] += s.weight;  // mass for now
  }
  for (const uint32_t k : fine_touched_) {
    const float w = fine.weight(k);
    fine_gain_[k] = w > 0.f ? fine_gain_[k] / w : Imath::C3f(0, 0, 0);
  }
  return fine_gain_.data();
}

float LobeRefinement::cut(const Imath::V3f& v, float d2, float r) const {
  if (refined_count_ == 0) return -1.f;
  const float finest = level_cut_[max_level_];
  if (!(d2 > r * r)) return finest;  // around the receiver: descend
  const float d = std::sqrt(d2);
  const Imath::V3f dir = v / d;
  const float gamma = std::asin(std::min(1.f, r / d));
  const float reach = kFootprintWidening * gamma + fine_.pixel_width();
  const float to_region = std::acos(std::clamp(dir.dot(region_axis_), -1.f, 1.f));
  if (to_region > reach + region_angle_) return -1.f;
  // cone_pixels() finds pixels whose centers lie in a cone: widened by a
  // pixel's center-to-corner angle, every pixel the cone overlaps.
  const float overlap = reach + pixel_half_diagonal_;
  if (overlap >= 0.5f * kPiF) return finest;
  // The deepest level of the coarse pixels the widened cone reaches.
  const float sin_a = std::sin(overlap), cos_a = std::cos(overlap);
  uint32_t level = 0;
  for (int face = 0; face < CubeLayout::kFaces && level < max_level_; ++face) {
    PixelRect rect;
    if (!coarse_.cone_pixels(face, dir, sin_a, cos_a, rect)) continue;
    for (uint32_t j = rect.j0; j <= rect.j1; ++j) {
      for (uint32_t i = rect.i0; i <= rect.i1; ++i) {
        level = std::max<uint32_t>(level, level_[coarse_.index(face, i, j)]);
      }
    }
  }
  return level > 0 ? level_cut_[level] : -1.f;
}

}  // namespace pbgi::gather
