#include "server/gather/microbuffer.h"

#include "server/gather/far_field.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi::gather {

namespace {
constexpr float kPi = 3.14159265358979f;
// Transmittance below which the rest of a pixel's fragments cannot matter.
constexpr float kOpaque = 1e-6f;
}  // namespace

Microbuffer::Microbuffer(const CubeLayout& layout, float depth_band)
    : layout_(layout),
      band_(depth_band),
      grow_(1.f + depth_band),
      weight_(layout.pixel_count(), 0.f),
      cos_(layout.pixel_count(), 0.f),
      stamp_(layout.pixel_count(), 0),
      head_(layout.pixel_count(), -1),
      hot_(layout.pixel_count(), -1) {
  touched_.reserve(layout.pixel_count());
  fragments_.reserve(4 * layout.pixel_count());
}

void Microbuffer::push(uint32_t k, const Fragment& f) {
  if (!std::isfinite(f.near)) return;
  if (stamp_[k] != generation_) {
    stamp_[k] = generation_;
    head_[k] = -1;
    touched_.push_back(k);
  }
  // Depth intervals overlapping within the band (then they always end in
  // the same cluster of resolve()), of one surface or of surfaces that
  // resolve() adds up.
  int32_t merge = -1, side = -1;
  for (int32_t i = head_[k]; i >= 0; i = fragments_[i].next) {
    const Fragment& g = fragments_[i];
    if ((g.alpha > 0.f) != (f.alpha > 0.f)) continue;
    if (f.far * grow_ < g.near || f.near > g.far * grow_) continue;
    if (f.surface == g.beside || planes_.same(g.surface, f.surface)) {
      merge = i;
      break;
    }
    if (side < 0) side = i;
  }
  // Else the first of another surface it lies beside (not behind).
  if (merge < 0 && side >= 0) {
    const Imath::V3f dir = layout_.direction(k);
    for (int32_t i = side; i >= 0; i = fragments_[i].next) {
      const Fragment& g = fragments_[i];
      if ((g.alpha > 0.f) != (f.alpha > 0.f)) continue;
      if (f.far * grow_ < g.near || f.near > g.far * grow_) continue;
      if (side_by_side(g, f, dir)) {
        merge = i;
        fragments_[i].beside = f.surface;
        break;
      }
    }
  }
  if (merge >= 0) {
    hot_[k] = merge;
    Fragment& g = fragments_[merge];
    if (g.surface == 0) g.surface = f.surface;
    g.near = std::min(g.near, f.near);
    g.far = std::max(g.far, f.far);
    g.alpha += f.alpha;
    g.weight += f.weight;
    g.r += f.r;
    g.g += f.g;
    g.b += f.b;
    g.mask |= f.mask;
    return;
  }
  fragments_.push_back(f);
  fragments_.back().next = head_[k];
  head_[k] = int32_t(fragments_.size() - 1);
  hot_[k] = head_[k];
}

void Microbuffer::begin(const Imath::V3f& n) {
  if (++generation_ == 0) {  // wrapped: old stamps could alias
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    generation_ = 1;
  }
  touched_.clear();
  fragments_.clear();
  planes_.clear();
  normal_ = n;

  const uint32_t count = layout_.pixel_count();
  const float* mx = layout_.mean_dir_x();
  const float* my = layout_.mean_dir_y();
  const float* mz = layout_.mean_dir_z();
  const float* omega = layout_.solid_angles();
  float sum = 0.f;
  for (uint32_t k = 0; k < count; ++k) {
    const float c = n.x * mx[k] + n.y * my[k] + n.z * mz[k];
    cos_[k] = c;
    const float w = c > 0.f ? c * omega[k] : 0.f;
    weight_[k] = w;
    sum += w;
  }
  // The weights miss pi only by what pixels straddling the horizon get
  // wrong (< 1% at N = 4); normalizing makes a uniformly covered hemisphere
  // give exactly pi L and AO 0.
  const float scale = sum > 0.f ? kPi / sum : 0.f;
  for (uint32_t k = 0; k < count; ++k) weight_[k] *= scale;
}

namespace {

// What one far layer of pixel k sends to a receiver (far_field.h): its
// cosine-weighted light and occlusion.
struct FarShare {
  float r, g, b, occ;
};

inline FarShare far_share(const FarLayer& f, const Imath::V3f& n, float cos_k, float margin_k,
                          float weight_k, float omega_k) {
  if (cos_k > margin_k) {
    // Wholly above the horizon: exact cosines of the splats' moments.
    const float nm = std::max(0.f, n.x * f.mx + n.y * f.my + n.z * f.mz);
    const float s = f.occ > 0.f ? nm / f.occ : 0.f;
    return {f.r * s, f.g * s, f.b * s, std::max(0.f, n.x * f.ao_mx + n.y * f.ao_my + n.z * f.ao_mz)};
  }
  // Straddling the horizon: the pixel's weight, as for a ray-cast hit.
  const float s = weight_k / omega_k;
  return {f.r * s, f.g * s, f.b * s, f.ao_occ * s};
}

}  // namespace

Resolved Microbuffer::resolve(float ao_max_distance, const FarBuffer* far,
                              const Imath::C3f* gain, std::vector<PixelLight>* light) {
  if (light) light->clear();
  double er = 0, eg = 0, eb = 0, occlusion = 0;
  double occluded[3] = {0, 0, 0};  // occlusion x direction
  // Only for bent normals: off, it costs one predictable branch per pixel.
  auto add_direction = [this](double* sum, float amount, uint32_t k) {
    if (!track_occluded_) return;
    const Imath::V3f d = layout_.direction(k);
    sum[0] += double(amount) * d.x;
    sum[1] += double(amount) * d.y;
    sum[2] += double(amount) * d.z;
  };
  double gr = 0, gg = 0, gb = 0;  // reflected (with gain)
  const float* margin = layout_.horizon_margins();
  const float* omega = layout_.solid_angles();
  if (far) {
    // Far pixels with no near fragment: the front layer, then the rest
    // through it.
    for (const uint32_t k : far->pixels()) {
      if (stamp_[k] == generation_ || !(weight_[k] > 0.f)) continue;
      const FarPixel& fp = far->pixel(k);
      const FarShare f = far_share(fp.front, normal_, cos_[k], margin[k], weight_[k], omega[k]);
      er += f.r;
      eg += f.g;
      eb += f.b;
      float occ = f.occ;
      const float t = std::max(0.f, 1.f - fp.front_alpha);
      const bool rest = fp.rest_alpha > 0.f && t > kOpaque;
      FarShare r{0.f, 0.f, 0.f, 0.f};
      if (rest) {
        r = far_share(fp.rest, normal_, cos_[k], margin[k], weight_[k], omega[k]);
        er += t * r.r;
        eg += t * r.g;
        eb += t * r.b;
        if (!(ao_max_distance > 0.f) || fp.rest_z < ao_max_distance) occ += t * r.occ;
      }
      occlusion += occ;
      add_direction(occluded, occ, k);
      if (gain) {
        gr += double(gain[k].x * (f.r + t * r.r));
        gg += double(gain[k].y * (f.g + t * r.g));
        gb += double(gain[k].z * (f.b + t * r.b));
      }
      if (light) light->push_back({k, Imath::C3f(f.r + t * r.r, f.g + t * r.g, f.b + t * r.b)});
    }
  }
  for (const uint32_t k : touched_) {
    sorted_.clear();
    // Whether the pixel holds fragments of more than one known surface
    // index: if not, no cluster needs the test of rule 3.
    uint32_t first_surface = 0;
    bool mixed = false;
    for (int32_t f = head_[k]; f >= 0; f = fragments_[f].next) {
      const Fragment& x = fragments_[f];
      sorted_.push_back(x);
      if (x.surface != 0 && x.surface != first_surface) {
        mixed = mixed || first_surface != 0;
        first_surface = x.surface;
      }
    }
    // The far layers of this pixel join its fragments as two more surfaces
    // (the front one merges with near pieces of the same surface).
    if (far && far->has(k) && weight_[k] > 0.f) {
      const FarPixel& fp = far->pixel(k);
      const FarShare f = far_share(fp.front, normal_, cos_[k], margin[k], weight_[k], omega[k]);
      if (fp.front_alpha > 0.f) {
        const uint32_t front = planes_.add(fp.front_surface).index;
        sorted_.push_back({fp.front_near, fp.front_far, fp.front_alpha, f.occ, f.r, f.g, f.b, 0u, -1, front, 0u});
        mixed = mixed || (front != 0 && first_surface != 0 && front != first_surface);
      }
      if (fp.rest_alpha > 0.f) {
        const FarShare r = far_share(fp.rest, normal_, cos_[k], margin[k], weight_[k], omega[k]);
        sorted_.push_back({fp.rest_z, fp.rest_z, fp.rest_alpha, r.occ, r.r, r.g, r.b, 0u, -1, 0u, 0u});
      }
    }
    // Lists are short (a few surfaces): insertion sort beats std::sort.
    for (size_t i = 1; i < sorted_.size(); ++i) {
      const Fragment x = sorted_[i];
      size_t j = i;
      for (; j > 0 && sorted_[j - 1].near > x.near; --j) sorted_[j] = sorted_[j - 1];
      sorted_[j] = x;
    }

    float transmit = 1.f, r = 0.f, g = 0.f, b = 0.f, ao_cover = 0.f;
    bool ao_open = true;  // clusters still nearer than ao_max_distance
    size_t i = 0;
    while (i < sorted_.size() && transmit > kOpaque) {
      const float start = sorted_[i].near;
      const size_t begin = i;
      float far_z = start, a = 0.f, w = 0.f, cr = 0.f, cg = 0.f, cb = 0.f;
      float hits = 0.f, hw = 0.f, hr = 0.f, hg = 0.f, hb = 0.f;
      uint32_t mask = 0;
      // Whether the cluster holds more than one surface (then rule 3's
      // test decides, and these sums are not used).
      bool one_surface = true;
      uint32_t surface = 0;  // the cluster's first known surface
      do {
        const Fragment& f = sorted_[i];
        if (f.alpha < 0.f) {
          hits -= f.alpha;
          mask |= f.mask;
          hw += f.weight;
          hr += f.r;
          hg += f.g;
          hb += f.b;
        } else {
          a += f.alpha;
          w += f.weight;
          cr += f.r;
          cg += f.g;
          cb += f.b;
        }
        if (mixed && f.surface != 0 && f.surface != surface) {
          if (surface == 0) {
            surface = f.surface;
          } else if (one_surface && !planes_.same(surface, f.surface)) {
            one_surface = false;
          }
        }
        far_z = std::max(far_z, f.far);
        ++i;
      } while (i < sorted_.size() && sorted_[i].near <= far_z * grow_);
      if (!one_surface) {
        resolve_surfaces(k, begin, i, cr, cg, cb, w, a);
      } else if (hits > 0.f) {
        // The hits' radiance averaged, over the part of the pixel they cover.
        const float cover = float(__builtin_popcount(mask)) * (1.f / kHitSamples);
        const float inv = cover / hits;
        a += cover;
        w += hw * inv;
        cr += hr * inv;
        cg += hg * inv;
        cb += hb * inv;
      }
      r += transmit * cr;
      g += transmit * cg;
      b += transmit * cb;
      if (ao_open && ao_max_distance > 0.f && !(start < ao_max_distance)) ao_open = false;
      if (ao_open) ao_cover += transmit * w;
      transmit *= std::max(0.f, 1.f - a);
    }
    er += r;
    eg += g;
    eb += b;
    occlusion += ao_cover;
    add_direction(occluded, ao_cover, k);
    if (gain) {
      gr += double(r * gain[k].x);
      gg += double(g * gain[k].y);
      gb += double(b * gain[k].z);
    }
    if (light) light->push_back({k, Imath::C3f(r, g, b)});
  }
  Resolved out;
  out.reflected = Imath::C3f(float(gr), float(gg), float(gb));
  out.irradiance = Imath::C3f(float(er), float(eg), float(eb));
  out.ao = std::clamp(1.f - float(occlusion / kPi), 0.f, 1.f);
  out.occluded = Imath::V3f(float(occluded[0]), float(occluded[1]), float(occluded[2]));
  return out;
}

void Microbuffer::resolve_surfaces(uint32_t k, size_t begin, size_t end, float& r, float& g, float& b, float& weight,
                                   float& alpha) {
  const Imath::V3f dir = layout_.direction(k);
  // Known surfaces first, each at the depth where the pixel's center ray
  // meets it; fragments of unknown surfaces (wide-cone nodes) then join the
  // nearest one (they add up, as before surfaces were known).
  surfaces_.clear();
  for (int pass = 0; pass < 2; ++pass) {
    for (size_t j = begin; j < end; ++j) {
      const Fragment& f = sorted_[j];
      if ((f.surface != 0) != (pass == 0)) continue;
      Surface* s = nullptr;
      if (pass == 0) {
        for (Surface& t : surfaces_) {
          if (planes_.same(t.surface, f.surface)) {
            s = &t;
            break;
          }
        }
        if (!s) {
          float far_z = f.far;
          for (size_t m = j + 1; m < end; ++m) {
            if (planes_.same(f.surface, sorted_[m].surface)) far_z = std::max(far_z, sorted_[m].far);
          }
          surfaces_.push_back({surface_depth(planes_[f.surface], dir, f.near, far_z, grow_), 0.f, 0.f, 0.f, 0.f, 0.f,
                               0.f, 0.f, 0.f, 0.f, 0.f, 0u, f.surface});
          s = &surfaces_.back();
        }
      } else {
        s = &surfaces_.front();
        for (Surface& t : surfaces_)
          if (t.depth < s->depth) s = &t;
      }
      if (f.alpha < 0.f) {
        s->hits -= f.alpha;
        s->mask |= f.mask;
        s->hw += f.weight;
        s->hr += f.r;
        s->hg += f.g;
        s->hb += f.b;
      } else {
        s->alpha += f.alpha;
        s->w += f.weight;
        s->r += f.r;
        s->g += f.g;
        s->b += f.b;
      }
    }
  }
  // Front to back (a handful of surfaces: insertion sort).
  for (size_t i = 1; i < surfaces_.size(); ++i) {
    const Surface x = surfaces_[i];
    size_t j = i;
    for (; j > 0 && surfaces_[j - 1].depth > x.depth; --j) surfaces_[j] = surfaces_[j - 1];
    surfaces_[j] = x;
  }
  uint32_t seen = 0;  // samples hit by surfaces in front
  float covered = 0.f;
  r = g = b = weight = 0.f;
  for (size_t i = 0; i < surfaces_.size(); ++i) {
    const Surface& s = surfaces_[i];
    float cover = 0.f;
    if (s.hits > 0.f) {
      // The hits' radiance averaged, over the part of the pixel they cover
      // and no surface in front of them does.
      const uint32_t mask = s.mask & ~seen;
      seen |= s.mask;
      cover = float(__builtin_popcount(mask)) * (1.f / kHitSamples);
      const float inv = cover / s.hits;
      weight += s.hw * inv;
      r += s.hr * inv;
      g += s.hg * inv;
      b += s.hb * inv;
    }
    // Splats count whole (pieces of one surface, or surfaces side by side:
    // coverage not clamped, rule 3) unless they lie behind the plane of a
    // surface in front; then only over what is left of the pixel.
    float scale = 1.f;
    if (i > 0 && s.alpha > 0.f) {
      const Imath::V3f x = dir * s.depth;
      for (size_t j = 0; j < i; ++j) {
        if (lies_behind(planes_[surfaces_[j].surface], x)) {
          scale = std::clamp((1.f - covered - cover) / s.alpha, 0.f, 1.f);
          break;
        }
      }
    }
    weight += s.w * scale;
    r += s.r * scale;
    g += s.g * scale;
    b += s.b * scale;
    covered += cover + s.alpha * scale;
  }
  alpha = covered;
}

Imath::V3f Microbuffer::bent_normal(const Resolved& r) const {
  double open[3] = {0, 0, 0};
  for (uint32_t k = 0; k < layout_.pixel_count(); ++k) {
    if (!(weight_[k] > 0.f)) continue;
    const Imath::V3f d = layout_.direction(k);
    open[0] += double(weight_[k]) * d.x;
    open[1] += double(weight_[k]) * d.y;
    open[2] += double(weight_[k]) * d.z;
  }
  const Imath::V3f v(float(open[0] - r.occluded.x), float(open[1] - r.occluded.y),
                     float(open[2] - r.occluded.z));
  const float len = v.length();
  // Nothing open (or only rounding left): the normal, as for AO 0.
  return len > 1e-4f ? v / len : normal_;
}

float Microbuffer::harmonic_mean_distance() const {
  const float* margin = layout_.horizon_margins();
  double weight = 0, inverse = 0;
  for (const uint32_t k : touched_) {
    if (!(cos_[k] > margin[k])) continue;
    weight += weight_[k];
    float nearest = std::numeric_limits<float>::infinity();
    for (int32_t f = head_[k]; f >= 0; f = fragments_[f].next) nearest = std::min(nearest, fragments_[f].near);
    inverse += double(weight_[k]) / std::max(double(nearest), 1e-12);
  }
  return inverse > 0.0 ? float(weight / inverse) : std::numeric_limits<float>::infinity();
}

}  // namespace pbgi::gather
