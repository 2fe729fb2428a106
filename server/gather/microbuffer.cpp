#include "server/gather/microbuffer.h"

#include "server/gather/far_field.h"

#include <algorithm>
#include <cmath>

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
      head_(layout.pixel_count(), -1) {
  touched_.reserve(layout.pixel_count());
  fragments_.reserve(4 * layout.pixel_count());
}

void Microbuffer::begin(const Imath::V3f& n) {
  if (++generation_ == 0) {  // wrapped: old stamps could alias
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    generation_ = 1;
  }
  touched_.clear();
  fragments_.clear();
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

// What the far content of pixel k sends to a receiver (far_field.h).
struct FarShare {
  float r, g, b, occ;
};

inline FarShare far_share(const FarPixel& f, const Imath::V3f& n, float cos_k, float margin_k,
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

Resolved Microbuffer::resolve(float ao_max_distance, const FarBuffer* far) {
  double er = 0, eg = 0, eb = 0, occlusion = 0;
  const float* margin = layout_.horizon_margins();
  const float* omega = layout_.solid_angles();
  if (far) {
    // Far pixels with no near fragment: nothing in front of them.
    for (const uint32_t k : far->pixels()) {
      if (stamp_[k] == generation_ || !(weight_[k] > 0.f)) continue;
      const FarShare s = far_share(far->pixel(k), normal_, cos_[k], margin[k], weight_[k], omega[k]);
      er += s.r;
      eg += s.g;
      eb += s.b;
      occlusion += s.occ;
    }
  }
  for (const uint32_t k : touched_) {
    sorted_.clear();
    for (int32_t f = head_[k]; f >= 0; f = fragments_[f].next) sorted_.push_back(fragments_[f]);
    // Lists are short (a few surfaces): insertion sort beats std::sort.
    for (size_t i = 1; i < sorted_.size(); ++i) {
      const Fragment x = sorted_[i];
      size_t j = i;
      for (; j > 0 && sorted_[j - 1].near > x.near; --j) sorted_[j] = sorted_[j - 1];
      sorted_[j] = x;
    }
    // The far content of this pixel, composited where it starts.
    const bool has_far = far && far->has(k) && weight_[k] > 0.f;
    const FarPixel* fp = has_far ? &far->pixel(k) : nullptr;
    bool far_pending = has_far;

    float transmit = 1.f, r = 0.f, g = 0.f, b = 0.f, ao_cover = 0.f;
    bool ao_open = true;  // clusters still nearer than ao_max_distance
    const auto add_far = [&] {
      const FarShare s = far_share(*fp, normal_, cos_[k], margin[k], weight_[k], omega[k]);
      r += transmit * s.r;
      g += transmit * s.g;
      b += transmit * s.b;
      if (ao_open) ao_cover += transmit * s.occ;
      transmit *= fp->transmit;
      far_pending = false;
    };
    size_t i = 0;
    while (i < sorted_.size() && transmit > kOpaque) {
      const float start = sorted_[i].near;
      if (far_pending && fp->z <= start) add_far();
      float far_z = start, a = 0.f, w = 0.f, cr = 0.f, cg = 0.f, cb = 0.f;
      float hits = 0.f, hw = 0.f, hr = 0.f, hg = 0.f, hb = 0.f;
      do {
        const Fragment& f = sorted_[i];
        if (f.alpha < 0.f) {
          hits -= f.alpha;
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
        far_z = std::max(far_z, f.far);
        ++i;
      } while (i < sorted_.size() && sorted_[i].near <= far_z * grow_);
      if (hits > 0.f) {
        const float inv = 1.f / hits;
        a += 1.f;
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
    if (far_pending && transmit > kOpaque) add_far();
    er += r;
    eg += g;
    eb += b;
    occlusion += ao_cover;
  }
  Resolved out;
  out.irradiance = Imath::C3f(float(er), float(eg), float(eb));
  out.ao = std::clamp(1.f - float(occlusion / kPi), 0.f, 1.f);
  return out;
}

}  // namespace pbgi::gather
