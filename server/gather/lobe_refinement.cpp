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

// A pixel straddling the horizon has a cosine weight (its part above) but
// its center may lie below, where f is 0: its part above is what the
// weight stands for, so f is taken just above the horizon instead.
Imath::V3f above_horizon(const Imath::V3f& d, const Imath::V3f& n) {
  constexpr float kLift = 0.02f;  // ~1 degree
  const float c = n.dot(d);
  return c >= kLift ? d : (d + n * (kLift - c)).normalized();
}
}  // namespace

LobeRefinement::LobeRefinement(const CubeLayout& coarse, const CubeLayout& fine, float importance,
                               float radiance_weight, float max_solid_angle)
    : coarse_(coarse),
      fine_(fine),
      levels_(log2_ratio(fine.resolution(), coarse.resolution())),
      importance_(importance),
      radiance_weight_(radiance_weight),
      radiance_(coarse.pixel_count(), 0.f),
      level_(coarse.pixel_count(), 0),
      coarse_mass_(coarse.pixel_count(), Imath::C3f(0, 0, 0)),
      coarse_gain_(coarse.pixel_count(), Imath::C3f(0, 0, 0)),
      fine_gain_(levels_ > 0 ? fine.pixel_count() : 0, Imath::C3f(0, 0, 0)),
      fine_f_(levels_ > 0 ? fine.pixel_count() : 0, Imath::C3f(0, 0, 0)) {
  // A cell of level l is a pixel of the cube of N 2^l per side: the walk
  // cuts at that cube's mean pixel solid angle (as the diffuse cut does at
  // level 0, cut_walker.h), within the gather's bound.
  for (uint32_t l = 0; l <= levels_; ++l) {
    const float side = float(coarse.resolution() << l);
    level_cut_.push_back(std::min(max_solid_angle, 4.f * kPiF / (6.f * side * side)));
  }
  samples_.reserve(kLobeSamples);
  share_.reserve(kLobeSamples);
  scratch_.reserve(kLobeSamples);
  // A pixel's center-to-corner angle is largest at a face's center,
  // atan(pixel width / sqrt 2).
  pixel_half_diagonal_ = std::atan(coarse.pixel_width() * 0.70710678f);
  // A finest pixel spans at most atan(its width) radians.
  wide_alpha_ = kWideLobePixels * std::atan(fine.pixel_width());
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

void LobeRefinement::begin(const Imath::V3f& n, const GlossyLobe& lobe, std::span<const PixelLight> light,
                           const Microbuffer& coarse) {
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
  for (const uint32_t k : hemisphere_) coarse_gain_[k] = Imath::C3f(0, 0, 0);
  hemisphere_.clear();
  wide_ = levels_ > 0 && lobes.alpha >= wide_alpha_;
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

  // 2. Each sample's importance (header): its share of the lobe, mixed
  //    with its share of the lobe x incoming radiance.
  refined_count_ = 0;
  max_level_ = 0;
  if (levels_ == 0 || !(mean(total_) > 0.f)) return;
  for (const uint32_t k : lit_) radiance_[k] = 0.f;
  lit_.clear();
  if (radiance_weight_ > 0.f) {
    for (const PixelLight& p : light) {
      const float w = coarse.weight(p.pixel);
      const float l = mean(p.light);
      if (!(w > 0.f) || !(l > 0.f) || !std::isfinite(l)) continue;
      radiance_[p.pixel] = l / w;
      lit_.push_back(p.pixel);
    }
  }
  if (wide_) {
    begin_wide(brdf, n, lobe.view, coarse);
  } else {
    begin_binned();
  }
  refined_count_ = uint32_t(refined_list_.size());

  // 4. A cone around the refined pixels, for cut()'s quick rejection.
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

void LobeRefinement::begin_wide(const Brdf& brdf, const Imath::V3f& n, const Imath::V3f& view,
                                const Microbuffer& coarse) {
  // Every coarse pixel of the hemisphere: f_spec averaged over the pixel
  // (over its finest pixels, weighted by their cosine x solid angle: a
  // coarse pixel spans 11 degrees at N = 8, over which a lobe's tail
  // changes several-fold), and its share of the lobe (f x the pixel's
  // cosine weight) and of lobe x radiance.
  double lobe_total = 0.0, lit_total = 0.0;
  const uint32_t nc = coarse_.resolution(), side = 1u << levels_;
  for (uint32_t k = 0; k < coarse_.pixel_count(); ++k) {
    const float w = coarse.weight(k);
    if (!(w > 0.f)) continue;
    const uint32_t i = k % nc, j = (k / nc) % nc, face = k / (nc * nc);
    Imath::C3f sum(0, 0, 0);
    float sum_w = 0.f;
    for (uint32_t dj = 0; dj < side; ++dj) {
      for (uint32_t di = 0; di < side; ++di) {
        const uint32_t fp = fine_.index(int(face), i * side + di, j * side + dj);
        const Imath::V3f d = fine_.direction(fp);
        // Kept for fine_gain() also where the center is below the horizon:
        // the fine buffer may still weigh the part of the pixel above it.
        fine_f_[fp] = brdf.eval(view, above_horizon(d, n));
        const float c = n.dot(d);
        if (!(c > 0.f)) continue;
        const float fw = c * fine_.solid_angle(fp);
        sum += fine_f_[fp] * fw;
        sum_w += fw;
      }
    }
    if (!(sum_w > 0.f)) continue;
    const Imath::C3f f = sum / sum_w;
    const float m = mean(f) * w;
    if (!(m > 0.f) || !std::isfinite(m)) continue;
    coarse_gain_[k] = f;
    hemisphere_.push_back(k);
    lobe_total += m;
    lit_total += double(m) * radiance_[k];
  }
  if (!(lobe_total > 0.0)) return;
  // The pixels' weights near the horizon are the microbuffer's
  // approximations (microbuffer.h), and a lobe at a grazing view lies
  // there: the evaluated lobe is scaled to the directional albedo its
  // stratified samples integrate (within ~1%), so only its distribution
  // comes from evaluation.
  Imath::C3f evaluated(0, 0, 0);
  for (const uint32_t k : hemisphere_) evaluated += coarse_gain_[k] * coarse.weight(k);
  for (int c = 0; c < 3; ++c) scale_[c] = evaluated[c] > 0.f ? total_[c] / evaluated[c] : 0.f;
  for (const uint32_t k : hemisphere_) coarse_gain_[k] *= scale_;
  const double b = lit_total > 0.0 && std::isfinite(lit_total) ? radiance_weight_ : 0.0;
  for (const uint32_t k : hemisphere_) {
    const double m = double(mean(coarse_gain_[k])) * coarse.weight(k);
    const double share = (1.0 - b) * m / lobe_total + (b > 0.0 ? b * m * radiance_[k] / lit_total : 0.0);
    if (share > importance_) {
      level_[k] = uint8_t(levels_);
      refined_list_.push_back(k);
      coarse_gain_[k] = Imath::C3f(0, 0, 0);  // gathered in the fine buffer
    }
  }
  max_level_ = refined_list_.empty() ? 0 : levels_;
}

void LobeRefinement::begin_binned() {
  double lit_total = 0.0;
  for (const Sample& s : samples_) lit_total += double(mean(s.weight)) * radiance_[s.coarse];
  const float b = lit_total > 0.0 && std::isfinite(lit_total) ? radiance_weight_ : 0.f;
  const float lobe_scale = (1.f - b) / mean(total_);
  const float lit_scale = b > 0.f ? float(double(b) / lit_total) : 0.f;
  share_.clear();
  for (const Sample& s : samples_) {
    share_.push_back(mean(s.weight) * (lobe_scale + lit_scale * radiance_[s.coarse]));
  }

  // 3. The quadtree: a cell whose importance is more than `importance` is
  //    split; a coarse pixel's level is the deepest split inside it, + 1.
  const float threshold = importance_;
  for (uint32_t level = 0; level < levels_; ++level) {
    scratch_.clear();
    for (size_t i = 0; i < samples_.size(); ++i) {
      const Sample& s = samples_[i];
      scratch_.push_back({cell_key(s.fine, level), share_[i], s.coarse});
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
}

const Imath::C3f* LobeRefinement::coarse_gain(const Microbuffer& coarse) {
  if (wide_) return coarse_gain_.data();  // evaluated by begin()
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
  if (wide_) {
    // f_spec at each fine pixel of the refined coarse pixels.
    const uint32_t nc = coarse_.resolution(), side = 1u << levels_;
    for (const uint32_t k : refined_list_) {
      const uint32_t i = k % nc, j = (k / nc) % nc, face = k / (nc * nc);
      for (uint32_t dj = 0; dj < side; ++dj) {
        for (uint32_t di = 0; di < side; ++di) {
          const uint32_t f = fine_.index(int(face), i * side + di, j * side + dj);
          if (!(fine.weight(f) > 0.f)) continue;
          fine_gain_[f] = fine_f_[f] * scale_;
          fine_touched_.push_back(f);
        }
      }
    }
    return fine_gain_.data();
  }
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
