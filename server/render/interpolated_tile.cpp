#include "server/render/interpolated_tile.h"

#include "server/scene/camera_rays.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <mutex>
#include <span>
#include <unordered_map>
#include <vector>

namespace pbgi {
namespace {

// A square cell of the lattice: pixels [x0, x0 + size) x [y0, y0 + size)
// (clipped to the image), corners at those pixels' centres.
struct Cell {
  uint32_t x0 = 0, y0 = 0, size = 0;
};

// A sample that may take the value of one corner only (across an edge from
// the others) takes it as a constant in cells up to this side, in pixels;
// wider cells are split. Irradiance along one surface varies slowly on this
// scale, and refining every silhouette down to single pixels would spend
// gathers where nothing changes.
constexpr uint32_t kMaxSingleCornerCell = 4;
// A corner on another surface is next to a sample (a crease between them)
// when their distance is at most this many times what their distance on
// the image means at the sample's depth; farther, the image shows a depth
// step between them.
constexpr float kCreaseSlack = 3.f;
// A corner the sample may take a value from is at most this many times as
// far in the scene as on the image (a surface seen at less than ~15
// degrees from grazing is split further).
constexpr float kMaxStretch = 4.f;

// Random-stream domains of a light silhouette's own camera samples and of
// their shadow rays (edge_pixel_samples()), keyed by the absolute pixel.
constexpr uint64_t kEdgePixelDomain = 0x65646765706978ull;  // "edgepix"
constexpr uint64_t kEdgeLightDomain = 0x656467656c6974ull;  // "edgelit"

// Does a camera sample see a light directly (an emitter, or the dome
// behind the scene)?
bool sees_light(const SurfaceSample& s) {
  return !s.gathers && s.value.beauty.x + s.value.beauty.y + s.value.beauty.z > 0.f;
}

// A lattice point: the receiver at a pixel's centre, and its gather.
struct LatticePoint {
  SurfaceSample sample;
  GatherResult result;
};

class LatticeTile {
 public:
  LatticeTile(const RayScene& rays, const Camera& camera, uint32_t width, uint32_t height, const TileRect& rect,
              const RenderOptions& options, const BatchGatherInput& gather, GatherCounters& counters)
      : rays_(rays), camera_(camera), width_(width), height_(height), rect_(rect), options_(options),
        gather_(gather), counters_(counters), spp_(options.pixel_samples),
        // Radians per pixel across the image (a pinhole's, at its centre).
        pixel_angle_(camera.horizontal_aperture / camera.focal_length / float(width)) {
    // The coarsest cells that overlap the tile, and every pixel they
    // cover: decisions about a cell read all of its samples, also those
    // outside the tile, so that the result does not depend on the split.
    const uint32_t s = options.interpolation.spacing;
    ext_ = TileRect{rect.x0 / s * s, rect.y0 / s * s, std::min((rect.x1 + s - 1) / s * s, width),
                    std::min((rect.y1 + s - 1) / s * s, height)};
  }

  void render(TileAovs& out) {
    trace_camera_samples();
    refine();
    shade(out);
  }

  // Camera samples traced beyond pixel_samples (light silhouettes).
  uint64_t extra_camera_samples() const { return extra_samples_; }

 private:
  size_t ext_index(uint32_t x, uint32_t y) const {
    return static_cast<size_t>(y - ext_.y0) * ext_.width() + (x - ext_.x0);
  }
  bool in_tile(uint32_t x, uint32_t y) const { return x >= rect_.x0 && x < rect_.x1 && y >= rect_.y0 && y < rect_.y1; }
  uint64_t key(uint32_t x, uint32_t y) const { return static_cast<uint64_t>(y) * width_ + x; }
  std::array<uint32_t, 2> corner_xs(const Cell& c) const { return {c.x0, std::min(c.x0 + c.size, width_ - 1)}; }
  std::array<uint32_t, 2> corner_ys(const Cell& c) const { return {c.y0, std::min(c.y0 + c.size, height_ - 1)}; }
  std::array<const LatticePoint*, 4> corners(const Cell& c) const {
    const auto xs = corner_xs(c), ys = corner_ys(c);
    return {&points_[index_.at(key(xs[0], ys[0]))], &points_[index_.at(key(xs[1], ys[0]))],
            &points_[index_.at(key(xs[0], ys[1]))], &points_[index_.at(key(xs[1], ys[1]))]};
  }

  // 1. Every camera sample of the extended rect: direct light inside the
  // tile (the pixel's shadow rays spread over its samples), none outside.
  void trace_camera_samples() {
    const size_t pixels = static_cast<size_t>(ext_.width()) * ext_.height();
    samples_.resize(pixels * spp_);
    offsets_.resize(pixels * spp_);
    const uint32_t shadow_rays = std::max(1u, (options_.light_samples + spp_ - 1) / spp_);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(ext_.y0, ext_.y1, 1), [&](const auto& rows) {
      for (uint32_t y = rows.begin(); y != rows.end(); ++y) {
        gather_.check_cancelled();
        for (uint32_t x = ext_.x0; x < ext_.x1; ++x) {
          const uint64_t pixel_id = key(x, y);
          Rng rng(hash_ids(options_.seed, kPixelDomain, pixel_id));
          const size_t i = ext_index(x, y) * spp_;
          const uint32_t light = in_tile(x, y) ? shadow_rays : 0;
          for (uint32_t k = 0; k < spp_; ++k) {
            const Imath::V2f j = pixel_sample_offset(k, spp_, rng);
            offsets_[i + k] = j;
            const Ray ray = camera_ray(camera_, width_, height_, float(x) + j.x, float(y) + j.y);
            samples_[i + k] = trace_sample(rays_, ray, light, hash_ids(options_.seed, kLightDomain, pixel_id, k),
                                          options_.dome_visible);
          }
        }
      }
    });
  }

  // Traces and gathers the corners of `cells` not yet known.
  void add_lattice_points(const std::vector<Cell>& cells) {
    std::vector<uint64_t> fresh;
    for (const Cell& c : cells) {
      for (uint32_t y : corner_ys(c))
        for (uint32_t x : corner_xs(c)) {
          if (index_.emplace(key(x, y), uint32_t(points_.size() + fresh.size())).second) fresh.push_back(key(x, y));
        }
    }
    const size_t first = points_.size();
    points_.resize(first + fresh.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, fresh.size(), 64), [&](const auto& range) {
      for (size_t i = range.begin(); i != range.end(); ++i) {
        const uint32_t x = uint32_t(fresh[i] % width_), y = uint32_t(fresh[i] / width_);
        const Ray ray = camera_ray(camera_, width_, height_, float(x) + 0.5f, float(y) + 0.5f);
        SurfaceSample s = trace_sample(rays_, ray, 0, 0);
        s.receiver.glossy = {};  // lattice points carry diffuse light only
        points_[first + i].sample = s;
      }
    });
    std::vector<Receiver> receivers;
    std::vector<size_t> owner;
    for (size_t i = first; i < points_.size(); ++i) {
      if (!points_[i].sample.gathers) continue;
      receivers.push_back(points_[i].sample.receiver);
      owner.push_back(i);
    }
    std::vector<GatherResult> results(receivers.size());
    gather_receivers(gather_, receivers, results, counters_);
    for (size_t r = 0; r < owner.size(); ++r) points_[owner[r]].result = results[r];
  }

  // How far apart sample k of pixel (x, y) and the lattice point at pixel
  // (cx, cy) are in the scene against on the image (at the sample's depth):
  // about 1 on a surface facing the camera, more on one seen at a grazing
  // angle or across a depth step.
  float stretch(uint32_t x, uint32_t y, uint32_t k, uint32_t cx, uint32_t cy, const SurfaceSample& corner) const {
    const size_t i = ext_index(x, y) * spp_ + k;
    return stretch(samples_[i], offsets_[i], x, y, cx, cy, corner);
  }
  float stretch(const SurfaceSample& s, const Imath::V2f& offset, uint32_t x, uint32_t y, uint32_t cx, uint32_t cy,
                const SurfaceSample& corner) const {
    const float dx = float(x) + offset.x - (float(cx) + 0.5f);
    const float dy = float(y) + offset.y - (float(cy) + 0.5f);
    const float screen = (std::sqrt(dx * dx + dy * dy) + 1.f) * pixel_angle_ * s.depth;
    return (s.receiver.position - corner.receiver.position).length() / screen;
  }

  // Must `cell` be split (gather_lattice.h)? Each surface sample's mask of
  // the corners it may take values from decides: none; a corner it may not
  // take from that lies on a surface next to it (a crease, where irradiance
  // changes fast; a corner beyond a depth step, behind or in front, does
  // not count); a single corner in a cell wider than kMaxSingleCornerCell;
  // or corners that disagree.
  bool must_split(const Cell& cell) const {
    const auto c = corners(cell);
    const auto xs = corner_xs(cell), ys = corner_ys(cell);
    bool mask_seen[16] = {};
    const uint32_t x1 = std::min(cell.x0 + cell.size, width_), y1 = std::min(cell.y0 + cell.size, height_);
    for (uint32_t y = cell.y0; y < y1; ++y) {
      for (uint32_t x = cell.x0; x < x1; ++x) {
        const size_t i = ext_index(x, y) * spp_;
        for (uint32_t k = 0; k < spp_; ++k) {
          const SurfaceSample& s = samples_[i + k];
          if (!s.gathers || s.receiver.glossy.active()) continue;  // nothing to interpolate
          unsigned mask = 0;
          for (unsigned q = 0; q < 4; ++q) {
            const SurfaceSample& corner = c[q]->sample;
            if (!corner.gathers) continue;
            const float stretch = this->stretch(x, y, k, xs[q & 1], ys[q >> 1], corner);
            if (may_interpolate(s, corner)) {
              // A grazing surface: the cell spans much more of the scene
              // than of the image, and irradiance along it need not be
              // linear; split down to where it is.
              if (stretch > kMaxStretch && cell.size > 1) return true;
              mask |= 1u << q;
            } else if (stretch <= kCreaseSlack) {
              return true;  // a crease next to the sample
            }
          }
          mask_seen[mask] = true;
        }
      }
    }
    if (mask_seen[0]) return true;
    for (unsigned mask = 1; mask < 16; ++mask) {
      if (!mask_seen[mask]) continue;
      if (std::popcount(mask) == 1) {
        if (cell.size > kMaxSingleCornerCell) return true;
        continue;
      }
      std::array<const GatherResult*, 4> group{};
      size_t m = 0;
      for (unsigned q = 0; q < 4; ++q)
        if (mask & (1u << q)) group[m++] = &c[q]->result;
      if (corners_disagree(std::span<const GatherResult* const>(group.data(), m), options_.interpolation.tolerance))
        return true;
    }
    return false;
  }

  // 2. Coarse to fine: gather the active cells' corners, split the cells
  // that need it (keeping the children that overlap the tile).
  void refine() {
    leaf_.assign(static_cast<size_t>(rect_.width()) * rect_.height(), Cell{});
    std::vector<Cell> active;
    const uint32_t s0 = options_.interpolation.spacing;
    for (uint32_t y = ext_.y0; y < ext_.y1; y += s0)
      for (uint32_t x = ext_.x0; x < ext_.x1; x += s0) active.push_back({x, y, s0});
    while (!active.empty()) {
      add_lattice_points(active);
      std::vector<char> split(active.size(), 0);
      tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size(), 16), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i)
          split[i] = active[i].size > 1 && must_split(active[i]) ? 1 : 0;
      });
      std::vector<Cell> next;
      for (size_t i = 0; i < active.size(); ++i) {
        const Cell& c = active[i];
        if (!split[i]) {
          mark_leaf(c);
          continue;
        }
        const uint32_t h = c.size / 2;
        for (uint32_t dy = 0; dy < 2; ++dy)
          for (uint32_t dx = 0; dx < 2; ++dx) {
            const Cell child{c.x0 + dx * h, c.y0 + dy * h, h};
            // Children outside the image or the tile hold none of its pixels.
            if (child.x0 >= std::min(rect_.x1, width_) || child.y0 >= std::min(rect_.y1, height_)) continue;
            if (child.x0 + h <= rect_.x0 || child.y0 + h <= rect_.y0) continue;
            next.push_back(child);
          }
      }
      active = std::move(next);
    }
  }

  void mark_leaf(const Cell& c) {
    const uint32_t x0 = std::max(c.x0, rect_.x0), y0 = std::max(c.y0, rect_.y0);
    const uint32_t x1 = std::min(c.x0 + c.size, rect_.x1), y1 = std::min(c.y0 + c.size, rect_.y1);
    for (uint32_t y = y0; y < y1; ++y)
      for (uint32_t x = x0; x < x1; ++x) leaf_[static_cast<size_t>(y - rect_.y0) * rect_.width() + (x - rect_.x0)] = c;
  }

  // The interpolated gather of sample k of pixel (x, y), or false if no
  // corner of its cell may lend it a value.
  bool interpolate(uint32_t x, uint32_t y, uint32_t k, GatherResult* out) const {
    const size_t i = ext_index(x, y) * spp_ + k;
    return interpolate(samples_[i], offsets_[i], x, y, out);
  }
  // The same for any sample `s` at `offset` in tile pixel (x, y).
  bool interpolate(const SurfaceSample& s, const Imath::V2f& offset, uint32_t x, uint32_t y,
                   GatherResult* out) const {
    const Cell& cell = leaf_[static_cast<size_t>(y - rect_.y0) * rect_.width() + (x - rect_.x0)];
    const auto c = corners(cell);
    const auto xs = corner_xs(cell), ys = corner_ys(cell);
    // Bilinear weights between the corners' pixel centres.
    const auto fraction = [](float p, uint32_t a, uint32_t b) {
      return b > a ? std::clamp((p - (float(a) + 0.5f)) / float(b - a), 0.f, 1.f) : 0.f;
    };
    const float fx = fraction(float(x) + offset.x, xs[0], xs[1]);
    const float fy = fraction(float(y) + offset.y, ys[0], ys[1]);
    const std::array<float, 4> bilinear{(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
    std::array<float, 4> w{};
    bool any = false;
    for (int q = 0; q < 4; ++q) {
      // Not across an edge, nor along a grazing surface even within a pixel
      // (its footprint spans too much of the scene to be linear).
      if (!may_interpolate(s, c[q]->sample) ||
          stretch(s, offset, x, y, xs[q & 1], ys[q >> 1], c[q]->sample) > kMaxStretch)
        continue;
      // A small floor: a sample on a compatible corner's far side still
      // takes its value rather than none.
      w[q] = bilinear[q] + 1e-4f;
      any = true;
    }
    if (!any) return false;
    const std::array<const GatherResult*, 4> results{&c[0]->result, &c[1]->result, &c[2]->result, &c[3]->result};
    *out = mix_results(results, w);
    return true;
  }

  // 3. Each camera sample of the tile: interpolated, or gathered itself
  // (a glossy lobe, or no corner to take a value from), then shaded.
  void shade(TileAovs& out) {
    const size_t tile_pixels = static_cast<size_t>(rect_.width()) * rect_.height();
    std::vector<GatherResult> results(tile_pixels * spp_);
    std::vector<char> own(tile_pixels * spp_, 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(rect_.y0, rect_.y1, 1), [&](const auto& rows) {
      for (uint32_t y = rows.begin(); y != rows.end(); ++y)
        for (uint32_t x = rect_.x0; x < rect_.x1; ++x) {
          const size_t t = (static_cast<size_t>(y - rect_.y0) * rect_.width() + (x - rect_.x0)) * spp_;
          for (uint32_t k = 0; k < spp_; ++k) {
            const SurfaceSample& s = samples_[ext_index(x, y) * spp_ + k];
            if (!s.gathers) continue;
            if (s.receiver.glossy.active() || !interpolate(x, y, k, &results[t + k])) own[t + k] = 1;
          }
        }
    });
    std::vector<Receiver> receivers;
    std::vector<size_t> owner;
    for (size_t t = 0; t < own.size(); ++t) {
      if (!own[t]) continue;
      const size_t p = t / spp_;
      const uint32_t x = rect_.x0 + uint32_t(p % rect_.width()), y = rect_.y0 + uint32_t(p / rect_.width());
      receivers.push_back(samples_[ext_index(x, y) * spp_ + t % spp_].receiver);
      owner.push_back(t);
    }
    std::vector<GatherResult> gathered(receivers.size());
    gather_receivers(gather_, receivers, gathered, counters_);
    for (size_t r = 0; r < owner.size(); ++r) results[owner[r]] = gathered[r];

    std::vector<EdgePixel> edges = edge_pixel_samples(results);

    const float inv_spp = 1.f / float(spp_);
    size_t next_edge = 0;
    for (uint32_t y = rect_.y0; y < rect_.y1; ++y)
      for (uint32_t x = rect_.x0; x < rect_.x1; ++x) {
        const size_t p = static_cast<size_t>(y - rect_.y0) * rect_.width() + (x - rect_.x0);
        PixelValue sum;
        if (next_edge < edges.size() && edges[next_edge].pixel == p) {
          const EdgePixel& e = edges[next_edge++];
          for (size_t k = 0; k < e.samples.size(); ++k) sum.add(finish_sample(e.samples[k], e.results[k]));
          out.store(p, sum, 1.f / float(e.samples.size()));
          continue;
        }
        for (uint32_t k = 0; k < spp_; ++k)
          sum.add(finish_sample(samples_[ext_index(x, y) * spp_ + k], results[p * spp_ + k]));
        out.store(p, sum, inv_spp);
      }
  }

  // 4. Light silhouettes. A pixel where a light seen directly (an emitter,
  // the sky) meets anything else holds the image's largest contrast: its
  // few camera samples leave most of the beauty error there (on the
  // Cornell box at 4 samples, 99.9% of it in the 1.3% of pixels around the
  // light). Such a pixel, or its neighbour (a silhouette that its own
  // samples missed), is rendered from options_.edge_samples stratified
  // camera samples of its own instead; they cost camera and shadow rays
  // (the pixel's light_samples spread over them) and take their indirect
  // light from the lattice, else from a compatible camera sample of the
  // pixel, else from a gather of their own.
  struct EdgePixel {
    size_t pixel = 0;  // row-major index in the tile
    uint32_t x = 0, y = 0;
    std::vector<SurfaceSample> samples;
    std::vector<Imath::V2f> offsets;
    std::vector<GatherResult> results;
  };

  // What the camera samples of pixel (x, y) see: bit 0 a light, bit 1
  // anything else. Pixels outside the traced rect trace the same camera
  // rays again (without shadow rays), so the answer does not depend on
  // the tile split.
  unsigned sight(uint32_t x, uint32_t y) const {
    unsigned m = 0;
    if (x >= ext_.x0 && x < ext_.x1 && y >= ext_.y0 && y < ext_.y1) {
      const size_t i = ext_index(x, y) * spp_;
      for (uint32_t k = 0; k < spp_; ++k) m |= sees_light(samples_[i + k]) ? 1u : 2u;
      return m;
    }
    Rng rng(hash_ids(options_.seed, kPixelDomain, key(x, y)));
    for (uint32_t k = 0; k < spp_; ++k) {
      const Imath::V2f j = pixel_sample_offset(k, spp_, rng);
      const Ray ray = camera_ray(camera_, width_, height_, float(x) + j.x, float(y) + j.y);
      m |= sees_light(trace_sample(rays_, ray, 0, 0, options_.dome_visible)) ? 1u : 2u;
    }
    return m;
  }

  std::vector<EdgePixel> edge_pixel_samples(const std::vector<GatherResult>& results) {
    const uint32_t n = options_.edge_samples;
    if (n <= spp_) return {};
    // Sight of the tile's pixels and a one-pixel ring around them.
    const uint32_t sx0 = rect_.x0 > 0 ? rect_.x0 - 1 : 0, sy0 = rect_.y0 > 0 ? rect_.y0 - 1 : 0;
    const uint32_t sx1 = std::min(rect_.x1 + 1, width_), sy1 = std::min(rect_.y1 + 1, height_);
    const uint32_t sw = sx1 - sx0;
    std::vector<unsigned> seen(static_cast<size_t>(sw) * (sy1 - sy0));
    tbb::parallel_for(tbb::blocked_range<uint32_t>(sy0, sy1, 1), [&](const auto& rows) {
      for (uint32_t y = rows.begin(); y != rows.end(); ++y)
        for (uint32_t x = sx0; x < sx1; ++x) seen[static_cast<size_t>(y - sy0) * sw + (x - sx0)] = sight(x, y);
    });
    std::vector<EdgePixel> edges;
    for (uint32_t y = rect_.y0; y < rect_.y1; ++y)
      for (uint32_t x = rect_.x0; x < rect_.x1; ++x) {
        unsigned m = 0;
        for (uint32_t yy = std::max(y, sy0 + 1) - 1; yy <= std::min(y + 1, sy1 - 1); ++yy)
          for (uint32_t xx = std::max(x, sx0 + 1) - 1; xx <= std::min(x + 1, sx1 - 1); ++xx)
            m |= seen[static_cast<size_t>(yy - sy0) * sw + (xx - sx0)];
        if (m != 3u) continue;
        EdgePixel e;
        e.pixel = static_cast<size_t>(y - rect_.y0) * rect_.width() + (x - rect_.x0);
        e.x = x;
        e.y = y;
        edges.push_back(std::move(e));
      }
    if (edges.empty()) return edges;

    const uint32_t shadow_rays = std::max(1u, (options_.light_samples + n - 1) / n);
    std::vector<Receiver> receivers;
    std::vector<std::pair<size_t, uint32_t>> owner;  // (edge, sample) of each receiver
    std::mutex owner_mutex;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, edges.size(), 4), [&](const auto& range) {
      for (size_t ei = range.begin(); ei != range.end(); ++ei) {
        gather_.check_cancelled();
        EdgePixel& e = edges[ei];
        const uint64_t pixel_id = key(e.x, e.y);
        Rng rng(hash_ids(options_.seed, kEdgePixelDomain, pixel_id));
        e.samples.resize(n);
        e.offsets.resize(n);
        e.results.resize(n);
        const size_t first = ext_index(e.x, e.y) * spp_;
        for (uint32_t k = 0; k < n; ++k) {
          const Imath::V2f j = stratified_sample(k, n, rng);
          e.offsets[k] = j;
          const Ray ray = camera_ray(camera_, width_, height_, float(e.x) + j.x, float(e.y) + j.y);
          const SurfaceSample& s = e.samples[k] =
              trace_sample(rays_, ray, shadow_rays, hash_ids(options_.seed, kEdgeLightDomain, pixel_id, k),
                           options_.dome_visible);
          if (!s.gathers) continue;
          if (!s.receiver.glossy.active() && interpolate(s, j, e.x, e.y, &e.results[k])) continue;
          // A camera sample of the pixel on the same surface lends its
          // value (glossy ones too: their view is the pixel's).
          bool lent = false;
          for (uint32_t o = 0; o < spp_ && !lent; ++o) {
            const SurfaceSample& other = samples_[first + o];
            if (!other.gathers || other.receiver.glossy.active() != s.receiver.glossy.active() ||
                !may_interpolate(s, other))
              continue;
            e.results[k] = results[e.pixel * spp_ + o];
            lent = true;
          }
          if (lent) continue;
          std::lock_guard<std::mutex> lock(owner_mutex);
          receivers.push_back(s.receiver);
          owner.emplace_back(ei, k);
        }
      }
    });
    // Gathers in a fixed order (the receivers' order does not change a
    // PBGI gather; FPBGI's batches follow it).
    std::vector<size_t> order(owner.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return owner[a] < owner[b]; });
    std::vector<Receiver> sorted(order.size());
    for (size_t i = 0; i < order.size(); ++i) sorted[i] = receivers[order[i]];
    std::vector<GatherResult> gathered(sorted.size());
    gather_receivers(gather_, sorted, gathered, counters_);
    for (size_t i = 0; i < order.size(); ++i) {
      const auto [ei, k] = owner[order[i]];
      edges[ei].results[k] = gathered[i];
    }
    extra_samples_ += static_cast<uint64_t>(edges.size()) * n;
    return edges;
  }

  const RayScene& rays_;
  const Camera& camera_;
  const uint32_t width_, height_;
  const TileRect rect_;
  const RenderOptions& options_;
  const BatchGatherInput& gather_;
  GatherCounters& counters_;
  const uint32_t spp_;
  const float pixel_angle_;
  TileRect ext_;
  std::vector<SurfaceSample> samples_;  // ext_ pixels x spp, row-major
  std::vector<Imath::V2f> offsets_;     // each sample's offset in its pixel
  std::unordered_map<uint64_t, uint32_t> index_;  // pixel key -> points_
  std::vector<LatticePoint> points_;
  std::vector<Cell> leaf_;  // per tile pixel: its smallest cell
  uint64_t extra_samples_ = 0;
};

}  // namespace

void render_tile_interpolated(const RayScene& rays, const Camera& camera, uint32_t image_width,
                              uint32_t image_height, const TileRect& rect, const RenderOptions& options,
                              const BatchGatherInput& gather, TileAovs& out, GatherCounters& counters) {
  LatticeTile tile(rays, camera, image_width, image_height, rect, options, gather, counters);
  tile.render(out);
  out.camera_samples += tile.extra_camera_samples();
}

}  // namespace pbgi
