#include "server/gather/far_field.h"

#include "common/errors.h"

#include <algorithm>
#include <string>

namespace pbgi::gather {

namespace {
constexpr float kOpaque = 1e-6f;  // transmittance below which nothing behind matters
}  // namespace

FarBuffer::FarBuffer(const CubeLayout& layout, float depth_band)
    : layout_(layout),
      grow_(1.f + depth_band),
      stamp_(layout.pixel_count(), 0),
      head_(layout.pixel_count(), -1),
      resolved_(layout.pixel_count()) {
  touched_.reserve(layout.pixel_count());
  fragments_.reserve(4 * layout.pixel_count());
}

void FarBuffer::begin() {
  if (++generation_ == 0) {
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    generation_ = 1;
  }
  touched_.clear();
  fragments_.clear();
  planes_.clear();
}

void FarBuffer::begin_from(const FarBuffer& other) {
  if (&other.layout_ != &layout_) {
    throw InvalidArgument("FarBuffer::begin_from: the buffers' cube layouts differ (" +
                          std::to_string(other.layout_.resolution()) + " vs " +
                          std::to_string(layout_.resolution()) + " pixels per side)");
  }
  begin();
  // Fragment indices (the per-pixel lists' links) stay valid in the copy.
  // Their planes were measured from the other cluster's point: they are
  // forgotten (the copies add up with what they meet, as wide nodes do).
  fragments_ = other.fragments_;
  for (Fragment& f : fragments_) f.surface = 0;
  touched_ = other.touched_;
  for (const uint32_t k : touched_) {
    stamp_[k] = generation_;
    head_[k] = other.head_[k];
  }
}

void FarBuffer::push(uint32_t k, const Fragment& f) {
  if (stamp_[k] != generation_) {
    stamp_[k] = generation_;
    head_[k] = -1;
    touched_.push_back(k);
  }
  // Merge into a fragment of the same surface (depth within the band), or
  // else of a surface it lies beside (resolve() adds them up anyway).
  int32_t merge = -1, side = -1;
  for (int32_t i = head_[k]; i >= 0; i = fragments_[i].next) {
    const Fragment& g = fragments_[i];
    if (f.far * grow_ < g.near || f.near > g.far * grow_) continue;
    if (planes_.same(g.surface, f.surface)) {
      merge = i;
      break;
    }
    if (side < 0) side = i;
  }
  for (int32_t i = side; merge < 0 && i >= 0; i = fragments_[i].next) {
    const Fragment& g = fragments_[i];
    if (f.far * grow_ < g.near || f.near > g.far * grow_) continue;
    if (merges(g, f, k)) merge = i;
  }
  if (merge >= 0) {
    Fragment& g = fragments_[merge];
    if (g.surface == 0) g.surface = f.surface;
    g.near = std::min(g.near, f.near);
    g.far = std::max(g.far, f.far);
    g.alpha += f.alpha;
    g.omega += f.omega;
    g.r += f.r;
    g.g += f.g;
    g.b += f.b;
    g.mx += f.mx;
    g.my += f.my;
    g.mz += f.mz;
    return;
  }
  fragments_.push_back(f);
  fragments_.back().next = head_[k];
  head_[k] = int32_t(fragments_.size() - 1);
}

bool FarBuffer::merges(const Fragment& g, const Fragment& f, uint32_t k) const {
  if (planes_.same(g.surface, f.surface)) return true;
  const Imath::V3f dir = layout_.direction(k);
  const FragmentSurface& sg = planes_[g.surface];
  const FragmentSurface& sf = planes_[f.surface];
  return !lies_behind(sg, dir * surface_depth(sf, dir, f.near, f.far, grow_)) &&
         !lies_behind(sf, dir * surface_depth(sg, dir, g.near, g.far, grow_));
}

void FarBuffer::trim_hidden(uint32_t k, size_t begin, size_t end) {
  const Imath::V3f dir = layout_.direction(k);
  // Front to back by where the pixel's center ray meets each fragment's
  // surface (a cluster holds a handful: insertion sort of the range).
  depth_.clear();
  for (size_t j = begin; j < end; ++j) {
    const Fragment& f = sorted_[j];
    depth_.push_back(surface_depth(planes_[f.surface], dir, f.near, f.far, grow_));
  }
  for (size_t i = 1; i < depth_.size(); ++i) {
    const Fragment x = sorted_[begin + i];
    const float dx = depth_[i];
    size_t j = i;
    for (; j > 0 && depth_[j - 1] > dx; --j) {
      sorted_[begin + j] = sorted_[begin + j - 1];
      depth_[j] = depth_[j - 1];
    }
    sorted_[begin + j] = x;
    depth_[j] = dx;
  }
  float covered = 0.f;
  for (size_t i = 0; i < depth_.size(); ++i) {
    Fragment& f = sorted_[begin + i];
    float scale = 1.f;
    if (f.surface != 0) {
      const Imath::V3f x = dir * depth_[i];
      for (size_t j = 0; j < i; ++j) {
        if (lies_behind(planes_[sorted_[begin + j].surface], x)) {
          scale = std::clamp((1.f - covered) / f.alpha, 0.f, 1.f);
          break;
        }
      }
    }
    covered += f.alpha * scale;
    if (scale == 1.f) continue;
    f.alpha *= scale;
    f.omega *= scale;
    f.r *= scale;
    f.g *= scale;
    f.b *= scale;
    f.mx *= scale;
    f.my *= scale;
    f.mz *= scale;
  }
}

void FarBuffer::resolve(float ao_max_distance) {
  for (const uint32_t k : touched_) {
    sorted_.clear();
    for (int32_t f = head_[k]; f >= 0; f = fragments_[f].next) sorted_.push_back(fragments_[f]);
    for (size_t i = 1; i < sorted_.size(); ++i) {
      const Fragment x = sorted_[i];
      size_t j = i;
      for (; j > 0 && sorted_[j - 1].near > x.near; --j) sorted_[j] = sorted_[j - 1];
      sorted_[j] = x;
    }
    FarPixel p{};
    float transmit = 1.f;  // from the start of the current layer
    bool ao_open = true;
    bool front = true;
    size_t i = 0;
    while (i < sorted_.size() && transmit > kOpaque) {
      const float start = sorted_[i].near;
      // The cluster's extent; surfaces hidden behind others within it are
      // trimmed first.
      size_t end = i;
      uint32_t first = 0;  // the cluster's first known surface
      bool one_surface = true;
      for (float z = start; end < sorted_.size() && sorted_[end].near <= z * grow_; ++end) {
        z = std::max(z, sorted_[end].far);
        const uint32_t s = sorted_[end].surface;
        if (s == 0 || s == first) continue;
        if (first == 0) {
          first = s;
        } else if (one_surface && !planes_.same(first, s)) {
          one_surface = false;
        }
      }
      if (!one_surface) trim_hidden(k, i, end);
      float far = start, a = 0.f, w = 0.f, r = 0.f, g = 0.f, b = 0.f, mx = 0.f, my = 0.f,
            mz = 0.f;
      do {
        const Fragment& f = sorted_[i];
        a += f.alpha;
        w += f.omega;
        r += f.r;
        g += f.g;
        b += f.b;
        mx += f.mx;
        my += f.my;
        mz += f.mz;
        far = std::max(far, f.far);
        ++i;
        // Exactly the cluster found above: trim_hidden() reordered it by
        // where the ray meets its surfaces, and re-testing the near depths
        // in that order could stop early and trim the rest a second time.
      } while (i < end);
      FarLayer& layer = front ? p.front : p.rest;
      layer.r += transmit * r;
      layer.g += transmit * g;
      layer.b += transmit * b;
      layer.occ += transmit * w;
      layer.mx += transmit * mx;
      layer.my += transmit * my;
      layer.mz += transmit * mz;
      if (ao_open && ao_max_distance > 0.f && !(start < ao_max_distance)) ao_open = false;
      if (ao_open) {
        layer.ao_occ += transmit * w;
        layer.ao_mx += transmit * mx;
        layer.ao_my += transmit * my;
        layer.ao_mz += transmit * mz;
      }
      if (front) {
        // The rest is composited from its own start.
        p.front_near = start;
        p.front_far = far;
        p.front_alpha = a;
        p.front_surface = planes_[first];
        p.rest_z = i < sorted_.size() ? sorted_[i].near : far;
        front = false;
      } else {
        transmit *= std::max(0.f, 1.f - a);
      }
    }
    p.rest_alpha = front ? 0.f : 1.f - transmit;
    if (p.rest.occ <= 0.f) p.rest_alpha = 0.f;
    resolved_[k] = p;
  }
}

}  // namespace pbgi::gather
