// Poisson-disk sampling of the scene's surfaces, streamed.
//
// Target: no two surfels closer than r = kRadiusFactor (0.75) x the local spacing
// h (options.spacing, or a SpacingField that follows a camera), measured in
// 3D across triangle and mesh edges, and the surface covered as densely as
// that allows (a maximal sampling gives about one surfel per h^2).
//
// Method (dart throwing on a dense candidate set, in spatial tiles):
//  1. The scene's bounding cube is split as an octree until a cell holds at
//     most kMaxTileSamples expected surfels and, with a camera, the spacing
//     varies by at most 2x inside it. Cells are visited depth first, in
//     Morton order.
//  2. In a leaf cell (a tile), each triangle clipped to the cell (a piece)
//     gets candidates on a jittered lattice of step kLatticeFactor x r laid
//     in the triangle's plane (at least one: the piece's centroid). The
//     candidates of the tile are visited in a random order (a hash of their
//     identity) and accepted unless an accepted surfel lies closer than
//     min(r, r') with a normal within 120 degrees (the two faces of a thin
//     wall are sampled independently). A spatial hash of cells of size 2r
//     finds those neighbours in 8 cells.
//  3. Area: each piece's exact area is split evenly over its candidates;
//     once the tile's darts are thrown, each rejected candidate gives its
//     share to the nearest surfel within its radius. Shares sum to the
//     scene's area exactly (see below for copies), and each surfel stands for the area closest to
//     it (radius = sqrt(area / pi)).
//     Coincident coplanar surfaces (a duplicated wall, a common modelling
//     error) are one surface: the renderers see one of the copies, so the
//     surfels must stand for its area once. A candidate covered by k pieces
//     of the tile lying in the same plane (within kCoplanarTolerance x r)
//     with the same facing (coincident_surfaces.h) carries 1/k of its
//     share; the copies' darts are rejected by each other's surfels (same
//     normal, closer than r), so the area of the union is sampled at the
//     usual density and counted once. Shares then sum to the area of the
//     union of coincident copies, not to the sum of their areas.
//     The two faces of a thin wall (opposite normals) are not duplicates.
//  4. Streaming: surfels accepted near a cell's faces stay "live" for the
//     neighbouring cells' checks and shares. When an octree cell is done,
//     every live surfel inside it that is farther than its r from the
//     cell's faces can no longer be touched (all later candidates lie
//     outside the cell) and is emitted. Memory is one tile's candidates and
//     the surfels along the faces of the cells on the current octree path.
//
//  5. Instances (native or point-instanced prototypes) go down the octree
//     whole, as one item with their world bounds and area, while their
//     bounds lie strictly inside a cell (touching no face); they are
//     expanded into their triangles (scene triangle ids, transformed on the
//     fly) only at the cell they straddle or at the tile they end in. So
//     the octree holds the world soup's triangles, the instances, and the
//     expanded triangles of the instances near the current path -- not one
//     id per triangle with instances expanded (before: 4 bytes per expanded
//     triangle at the root plus its copies down the tree). A tile's list
//     is kept in ascending id order and holds the triangles it would hold
//     with everything expanded, so the surfels are those of the flattened
//     scene; an instance's estimate is its area over h^2 at its bounds'
//     centre (exact for an absolute spacing up to rounding, approximate
//     with a camera: only the octree's split decisions and the progress
//     use it).
//
// Everything derives from hashes of (seed, triangle, lattice cell), and the
// order of tiles and candidates is fixed: the result does not depend on
// threads or batch sizes.
#include "common/errors.h"
#include "server/scene/rng.h"
#include "server/scene/sample_patterns.h"
#include "server/scene/surface_colors.h"
#include "server/scene/surface_opacity.h"
#include "server/surfels/coincident_surfaces.h"
#include "server/surfels/progress_meter.h"
#include "server/surfels/spacing_field.h"
#include "server/surfels/surfel_material.h"
#include "server/surfels/surfel_samplers.h"
#include "server/surfels/triangle_ranges.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pbgi {
namespace {

// Minimum distance as a fraction of the spacing: with the candidate lattice
// below, the accepted density is then close to 1 / spacing^2.
constexpr float kRadiusFactor = 0.75f;
// Candidate lattice step as a fraction of the minimum distance.
constexpr float kLatticeFactor = 0.5f;
// Expected surfels per tile: bounds the candidates held (~10x as many).
constexpr double kMaxTileSamples = 32768;
constexpr int kMaxDepth = 24;
// Neighbours whose normals differ by more than 120 degrees never conflict.
constexpr float kMinNormalDot = -0.5f;
// Surfels handed to the sink at once.
constexpr size_t kChunk = 16384;

// Coincident coplanar pieces: planes closer than this fraction of r
// (coincident_surfaces.h).
constexpr float kCoplanarTolerance = 0.01f;

constexpr uint64_t kJitterDomain = 0x6a6974746572ull;    // "jitter"
constexpr uint64_t kPriorityDomain = 0x7072696f72ull;    // "prior"

// A convex polygon: a triangle clipped by a box has at most 9 vertices.
struct Polygon {
  V3f v[10];
  int n = 0;
};

// Keeps the part of `p` with (x[axis] - bound) * sign <= 0.
void clip(Polygon& p, int axis, float bound, float sign) {
  Polygon out;
  for (int i = 0; i < p.n; ++i) {
    const V3f& a = p.v[i];
    const V3f& b = p.v[(i + 1) % p.n];
    const float da = (a[axis] - bound) * sign, db = (b[axis] - bound) * sign;
    if (da <= 0.f) out.v[out.n++] = a;
    if ((da < 0.f && db > 0.f) || (da > 0.f && db < 0.f)) {
      const float t = da / (da - db);
      V3f x = a + (b - a) * t;
      x[axis] = bound;  // exactly on the plane
      out.v[out.n++] = x;
    }
    if (out.n >= 9) break;  // cannot happen for a triangle and 6 planes
  }
  p = out;
}

Polygon clip_to_box(const V3f& a, const V3f& b, const V3f& c, const Box3f& box) {
  Polygon p;
  p.v[0] = a;
  p.v[1] = b;
  p.v[2] = c;
  p.n = 3;
  for (int k = 0; k < 3 && p.n > 0; ++k) {
    clip(p, k, box.min[k], -1.f);
    if (p.n > 0) clip(p, k, box.max[k], 1.f);
  }
  return p;
}

double polygon_area(const Polygon& p) {
  if (p.n < 3) return 0.0;
  Imath::V3d sum(0);
  const Imath::V3d o(p.v[0].x, p.v[0].y, p.v[0].z);
  for (int i = 1; i + 1 < p.n; ++i) {
    const Imath::V3d a = Imath::V3d(p.v[i].x, p.v[i].y, p.v[i].z) - o;
    const Imath::V3d b = Imath::V3d(p.v[i + 1].x, p.v[i + 1].y, p.v[i + 1].z) - o;
    sum += a.cross(b);
  }
  return 0.5 * sum.length();
}

V3f polygon_mean(const Polygon& p) {
  V3f m(0.f);
  for (int i = 0; i < p.n; ++i) m += p.v[i];
  return m / float(p.n);
}

bool in_box_half_open(const V3f& p, const Box3f& b) {
  return p.x >= b.min.x && p.x < b.max.x && p.y >= b.min.y && p.y < b.max.y && p.z >= b.min.z && p.z < b.max.z;
}

bool strictly_inside(const Box3f& inner, const Box3f& outer) {
  for (int k = 0; k < 3; ++k)
    if (!(inner.min[k] > outer.min[k] && inner.max[k] < outer.max[k])) return false;
  return true;
}

float distance_to_faces(const V3f& p, const Box3f& b) {
  float d = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 3; ++k) d = std::min({d, p[k] - b.min[k], b.max[k] - p[k]});
  return d;
}

float distance_to_box(const V3f& p, const Box3f& b) {
  float d2 = 0.f;
  for (int k = 0; k < 3; ++k) {
    const float e = std::max({b.min[k] - p[k], 0.f, p[k] - b.max[k]});
    d2 += e * e;
  }
  return std::sqrt(d2);
}

// A triangle's frame for its candidate lattice: origin p0, unit e1 along
// p0->p1, e2 = n x e1; (u1, 0), (u2, v2) are p1, p2 in that frame.
struct TriangleFrame {
  V3f p0, e1, e2, n;
  float u1 = 0, u2 = 0, v2 = 0;

  bool barycentrics(float u, float v, float& b1, float& b2) const {
    b2 = v / v2;
    b1 = (u - u2 * b2) / u1;
    return b1 >= 0.f && b2 >= 0.f && b1 + b2 <= 1.f;
  }
};

struct Candidate {
  V3f p;
  uint32_t tri;
  float b1, b2;
  double weight;
  uint64_t priority;
};

// An instance as one octree item: its world bounds and its surface
// (double-sided meshes twice), for estimates without its triangles.
struct WholeInstance {
  Box3f bounds;
  double area = 0.0;
};

// The octree's items in one cell: triangle ids (ascending) and instances
// not yet expanded (indices into Scene::instances, ascending).
struct CellItems {
  std::vector<uint32_t> tris;
  std::vector<uint32_t> insts;
  bool empty() const { return tris.empty() && insts.empty(); }
};

struct Live {
  V3f p, n;
  float r;
  uint32_t tri;
  float b1, b2;
  double weight;
};

class PoissonSampler {
 public:
  PoissonSampler(const Scene& scene, const SurfelOptions& options, const SpacingField& field,
                 const SurfelChunkSink& sink, ProgressMeter& meter, uint64_t meter_total)
      : scene_(scene), options_(options), field_(field), sink_(sink), meter_(meter),
        meter_total_(meter_total) {
    // Bounds and area of every instance, in parallel (each walks its
    // prototype's triangles once).
    whole_.resize(scene.instances.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, whole_.size(), 1), [&](const auto& r) {
      for (size_t k = r.begin(); k != r.end(); ++k) {
        const TriangleRange range = triangle_range(scene, k + 1);
        WholeInstance& w = whole_[k];
        for (uint32_t j = 0; j < range.size(); ++j) {
          const TriangleRef t = range.triangle(j);
          for (int c = 0; c < 3; ++c) w.bounds.extendBy(t.position(c));
        }
        w.area = range_area(range).total;
      }
    });
  }

  // The items of the whole scene: the world soup's triangles and every
  // instance with some area.
  CellItems root_items() const {
    CellItems items;
    items.tris.reserve(scene_.triangles.triangle_count());
    for (size_t i = 0; i < scene_.triangles.triangle_count(); ++i) items.tris.push_back(uint32_t(i));
    for (size_t k = 0; k < whole_.size(); ++k)
      if (whole_[k].area > 0.0) items.insts.push_back(uint32_t(k));
    return items;
  }

  // Samples everything inside `cube` (which encloses the scene).
  void run(const Box3f& cube, CellItems items, double root_estimate) {
    root_estimate_ = std::max(root_estimate, 1.0);
    process(cube, items, 0);
    flush();
  }

  // Expected surfels over the pieces of the items inside `box` (whole
  // instances lie inside it); drops the triangles with no area inside.
  double estimate(const Box3f& box, CellItems& items) const {
    double e = 0;
    for (uint32_t k : items.insts) {
      const float h = field_.at(whole_[k].bounds.center());
      e += whole_[k].area / (double(h) * h);
    }
    std::vector<uint32_t>& tris = items.tris;
    size_t kept = 0;
    for (uint32_t t : tris) {
      const Polygon p = clip_to_box(vertex(t, 0), vertex(t, 1), vertex(t, 2), box);
      const double a = polygon_area(p);
      if (!(a > 0.0)) continue;
      tris[kept++] = t;
      const float h = field_.at(polygon_mean(p));
      e += a / (double(h) * h) * (twin(t) ? 2.0 : 1.0);
    }
    tris.resize(kept);
    return e;
  }

 private:
  // Scene triangle ids: instances' triangles are transformed on the fly.
  V3f vertex(uint32_t tri, int k) const { return scene_.triangle(tri).position(k); }
  bool twin(uint32_t tri) const { return scene_.triangle(tri).double_sided(); }
  float radius_at(const V3f& p) const { return kRadiusFactor * field_.at(p); }

  // Appends the triangles of instance k to `tris` (scene ids, ascending).
  void expand(uint32_t k, std::vector<uint32_t>& tris) const {
    const TriangleRange range = triangle_range(scene_, k + 1);
    for (uint32_t j = 0; j < range.size(); ++j) tris.push_back(range.first_id + j);
  }

  void process(const Box3f& box, CellItems& items, int depth) {
    const double expected = estimate(box, items);
    const size_t mark = live_.size();
    std::vector<uint32_t>& tris = items.tris;
    if (!items.empty()) {
      const float h_min = field_.min_in(box), h_max = field_.max_in(box);
      const float edge = box.size().x;
      const bool split = depth < kMaxDepth && edge > 4.f * kRadiusFactor * h_min &&
                         (expected > kMaxTileSamples || h_max > 2.f * h_min);
      if (split) {
        const V3f mid = box.center();
        CellItems child[8];
        Box3f cbox[8];
        for (int c = 0; c < 8; ++c) {
          for (int k = 0; k < 3; ++k) {
            const bool hi = (c >> k) & 1;
            cbox[c].min[k] = hi ? mid[k] : box.min[k];
            cbox[c].max[k] = hi ? box.max[k] : mid[k];
          }
        }
        // Instances strictly inside a child (touching none of its faces,
        // so that none of their triangles is routed to another child, as
        // when expanded) stay whole; the others are expanded here, their
        // triangles routed like the rest.
        bool expanded = false;
        for (uint32_t k : items.insts) {
          const Box3f& b = whole_[k].bounds;
          int inside = -1;
          for (int c = 0; c < 8 && inside < 0; ++c)
            if (strictly_inside(b, cbox[c])) inside = c;
          if (inside >= 0) {
            child[inside].insts.push_back(k);
          } else {
            expand(k, tris);
            expanded = true;
          }
        }
        std::vector<uint32_t>().swap(items.insts);
        if (expanded) std::sort(tris.begin(), tris.end());
        for (uint32_t t : tris) {
          Box3f tb;
          tb.extendBy(vertex(t, 0));
          tb.extendBy(vertex(t, 1));
          tb.extendBy(vertex(t, 2));
          for (int c = 0; c < 8; ++c)
            if (tb.intersects(cbox[c])) child[c].tris.push_back(t);
        }
        std::vector<uint32_t>().swap(tris);
        for (int c = 0; c < 8; ++c) process(cbox[c], child[c], depth + 1);
      } else {
        // A tile: every item as triangles, in ascending id order.
        if (!items.insts.empty()) {
          for (uint32_t k : items.insts) expand(k, tris);
          std::vector<uint32_t>().swap(items.insts);
          std::sort(tris.begin(), tris.end());
        }
        sample_tile(box, tris, field_.min_in(box), field_.max_in(box));
        done_ += expected;
        const uint64_t target = uint64_t(double(meter_total_) * std::min(1.0, done_ / root_estimate_));
        if (target > reported_) {
          meter_.advance(target - reported_);
          reported_ = target;
        }
      }
    }
    finalize(box, mark, depth == 0);
  }

  void sample_tile(const Box3f& box, const std::vector<uint32_t>& tris, float h_min, float h_max) {
    // 1. Candidates, piece by piece.
    const float g = kLatticeFactor * kRadiusFactor * h_min;
    cands_.clear();
    pieces_.clear();
    piece_cands_.clear();
    for (uint32_t t : tris) {
      const V3f &a = vertex(t, 0), &b = vertex(t, 1), &c = vertex(t, 2);
      const Polygon piece = clip_to_box(a, b, c, box);
      const double area = polygon_area(piece);
      if (!(area > 0.0)) continue;
      TriangleFrame f;
      f.p0 = a;
      f.n = (b - a).cross(c - a).normalized();
      f.u1 = (b - a).length();
      f.e1 = (b - a) / f.u1;
      f.e2 = f.n.cross(f.e1);
      f.u2 = (c - a).dot(f.e1);
      f.v2 = (c - a).dot(f.e2);
      float umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
      for (int i = 0; i < piece.n; ++i) {
        const V3f d = piece.v[i] - a;
        umin = std::min(umin, d.dot(f.e1));
        umax = std::max(umax, d.dot(f.e1));
        vmin = std::min(vmin, d.dot(f.e2));
        vmax = std::max(vmax, d.dot(f.e2));
      }
      const size_t first = cands_.size();
      const int64_t i0 = int64_t(std::floor(umin / g)), i1 = int64_t(std::floor(umax / g));
      const int64_t j0 = int64_t(std::floor(vmin / g)), j1 = int64_t(std::floor(vmax / g));
      for (int64_t j = j0; j <= j1; ++j) {
        for (int64_t i = i0; i <= i1; ++i) {
          const uint64_t cell = (uint64_t(uint32_t(int32_t(i))) << 32) | uint32_t(int32_t(j));
          const uint64_t h = hash_ids(options_.seed, kJitterDomain, t, cell);
          const float u = (float(i) + float(h & 0xffffff) * 0x1p-24f) * g;
          const float v = (float(j) + float((h >> 24) & 0xffffff) * 0x1p-24f) * g;
          float b1, b2;
          if (!f.barycentrics(u, v, b1, b2)) continue;
          const V3f p = a + u * f.e1 + v * f.e2;
          if (!in_box_half_open(p, box)) continue;
          cands_.push_back({p, t, b1, b2, 0.0, hash_ids(options_.seed, kPriorityDomain, t, cell)});
        }
      }
      if (cands_.size() == first) {
        // A sliver with no lattice point: its centroid carries its area.
        const V3f m = polygon_mean(piece);
        const V3f d = m - a;
        float b1 = 0, b2 = 0;
        f.barycentrics(d.dot(f.e1), d.dot(f.e2), b1, b2);
        cands_.push_back({m, t, std::max(b1, 0.f), std::max(b2, 0.f), 0.0,
                          hash_ids(options_.seed, kPriorityDomain, t, ~uint64_t(first))});
      }
      const double share = area / double(cands_.size() - first);
      for (size_t k = first; k < cands_.size(); ++k) cands_[k].weight = share;
      PlanarPiece pp;
      if (PlanarPiece::of_triangle(a, b, c, &pp)) {
        pp.bounds = Box3f();  // the piece's, not the triangle's
        for (int i = 0; i < piece.n; ++i) pp.bounds.extendBy(piece.v[i]);
        pieces_.push_back(pp);
        piece_cands_.push_back({first, cands_.size()});
      }
    }
    count_coincident_cover(box, h_min);
    std::sort(cands_.begin(), cands_.end(), [](const Candidate& x, const Candidate& y) {
      return x.priority != y.priority ? x.priority < y.priority : x.tri < y.tri;
    });

    // 2. The neighbour grid: live surfels that can conflict with this tile.
    //    Cells of twice the largest radius: a ball of radius r around a
    //    point then touches at most two cells per axis.
    cell_ = 2.f * kRadiusFactor * h_max;
    inv_cell_ = 1.f / cell_;
    heads_.clear();
    next_.assign(live_.size(), kNone);

    for (uint32_t i = 0; i < live_.size(); ++i)
      if (distance_to_box(live_[i].p, box) < cell_) insert(i);

    // 3. Dart throwing in priority order.
    rejected_.clear();
    for (uint32_t k = 0; k < cands_.size(); ++k) {
      const Candidate& c = cands_[k];
      const V3f n = triangle_normal(c.tri);
      const float r = radius_at(c.p);
      if (nearest_conflict(c.p, n, r) != kNone) {
        rejected_.push_back(k);
        continue;
      }
      live_.push_back({c.p, n, r, c.tri, c.b1, c.b2, c.weight});
      next_.push_back(kNone);
      insert(uint32_t(live_.size() - 1));
    }
    // 4. Each rejected candidate's area goes to the nearest surfel accepted
    //    by now (its rejecter or one accepted after it): a Voronoi-like
    //    split, so every surfel stands for the area closest to it.
    for (uint32_t k : rejected_) {
      const Candidate& c = cands_[k];
      const uint32_t owner = nearest_conflict(c.p, triangle_normal(c.tri), radius_at(c.p));
      live_[owner].weight += c.weight;  // the rejecter is still there: never kNone
    }
  }

  // Divides each candidate's share by the number of pieces of this tile
  // covering its point in the same plane with the same facing (see step 3
  // at the top; coincident_surfaces.h).
  void count_coincident_cover(const Box3f& box, float h_min) {
    if (pieces_.size() < 2) return;
    const CoincidentCover cover(
        uint32_t(pieces_.size()),
        [this](uint32_t i, PlanarPiece* out) {
          *out = pieces_[i];
          return true;
        },
        box.center(), kCoplanarTolerance * kRadiusFactor * h_min);
    if (!cover.any()) return;
    for (uint32_t i = 0; i < pieces_.size(); ++i)
      for (size_t k = piece_cands_[i].first; k < piece_cands_[i].second; ++k)
        cands_[k].weight /= double(cover.cover(i, cands_[k].p));
  }

  V3f triangle_normal(uint32_t t) const {
    return (vertex(t, 1) - vertex(t, 0)).cross(vertex(t, 2) - vertex(t, 0)).normalized();
  }

  static constexpr uint32_t kNone = ~uint32_t(0);

  static constexpr double kMaxDenseCells = double(1 << 22);

  uint64_t cell_key(int64_t x, int64_t y, int64_t z) const {
    auto b = [](int64_t v) { return uint64_t(v + (int64_t(1) << 20)) & 0x1fffffull; };
    return b(x) | b(y) << 21 | b(z) << 42;
  }

  // Cell coordinates of p (relative to the grid origin).
  void cell_of(const V3f& p, float q[3]) const {
    const V3f r = (p - grid_origin_) * inv_cell_;
    q[0] = r.x;
    q[1] = r.y;
    q[2] = r.z;
  }

  // The head of cell (x, y, z), or nullptr for an empty cell outside the grid.
  const uint32_t* head(int64_t x, int64_t y, int64_t z) const {
    if (dense_) {
      if (x < 0 || y < 0 || z < 0 || x >= dims_ || y >= dims_ || z >= dims_) return nullptr;
      return &dense_heads_[size_t((x * dims_ + y) * dims_ + z)];
    }
    const auto it = heads_.find(cell_key(x, y, z));
    return it == heads_.end() ? nullptr : &it->second;
  }

  void insert(uint32_t i) {
    float q[3];
    cell_of(live_[i].p, q);
    const int64_t x = int64_t(std::floor(q[0])), y = int64_t(std::floor(q[1])), z = int64_t(std::floor(q[2]));
    if (dense_) {
      if (x < 0 || y < 0 || z < 0 || x >= dims_ || y >= dims_ || z >= dims_) return;  // too far to matter
      uint32_t& h = dense_heads_[size_t((x * dims_ + y) * dims_ + z)];
      next_[i] = h;
      h = i;
      return;
    }
    auto [it, fresh] = heads_.try_emplace(cell_key(x, y, z), i);
    if (!fresh) {
      next_[i] = it->second;
      it->second = i;
    }
  }

  // The nearest live surfel closer than min(r, its r) with a compatible
  // normal, or kNone. Cells are at least 2r wide, so the ball around p
  // touches at most two cells per axis: p's and the nearer neighbour.
  uint32_t nearest_conflict(const V3f& p, const V3f& n, float r) const {
    float q[3];
    cell_of(p, q);
    int64_t base[3], other[3];
    for (int k = 0; k < 3; ++k) {
      const float fl = std::floor(q[k]);
      base[k] = int64_t(fl);
      other[k] = q[k] - fl < 0.5f ? base[k] - 1 : base[k] + 1;
    }
    uint32_t best = kNone;
    float best_d2 = INFINITY;
    for (int c = 0; c < 8; ++c) {
      const uint32_t* h = head(c & 1 ? other[0] : base[0], c & 2 ? other[1] : base[1], c & 4 ? other[2] : base[2]);
      if (!h) continue;
      for (uint32_t i = *h; i != kNone; i = next_[i]) {
        const Live& s = live_[i];
        const float d2 = (s.p - p).length2();
        const float rr = std::min(r, s.r);
        if (d2 < rr * rr && d2 < best_d2 && s.n.dot(n) > kMinNormalDot) {
          best = i;
          best_d2 = d2;
        }
      }
    }
    return best;
  }

  // Emits the live surfels of this cell that no later candidate can reach;
  // keeps the others for the cells still to come.
  void finalize(const Box3f& box, size_t mark, bool root) {
    size_t kept = mark;
    for (size_t i = mark; i < live_.size(); ++i) {
      const Live& s = live_[i];
      if (root || distance_to_faces(s.p, box) >= s.r) {
        emit(s);
      } else {
        live_[kept++] = s;
      }
    }
    live_.resize(kept);
  }

  void emit(const Live& s) {
    Surfel out;
    out.position = s.p;
    out.normal = s.n;
    // Cut-out or partly transparent surface (surface_opacity.h): the
    // surfel covers only what is there; none where it is cut out.
    out.radius = std::sqrt(float(s.weight) * surface_coverage(scene_, s.tri, s.b1, s.b2) * kInvPi);
    if (!(out.radius > 0.f)) return;
    const SurfaceColors colors = surface_colors(scene_, s.tri, s.b1, s.b2, 2.f * out.radius);
    set_surfel_material(scene_, s.tri, colors, options_.glossy_roughness, out);
    out.radiance = colors.emission;
    chunk_.push_back(out);
    if (twin(s.tri)) {
      out.normal = -s.n;
      chunk_.push_back(out);
    }
    if (chunk_.size() >= kChunk) flush();
  }

  void flush() {
    if (chunk_.empty()) return;
    sink_(chunk_);
    chunk_.clear();
  }

  const Scene& scene_;
  const SurfelOptions& options_;
  const SpacingField& field_;
  const SurfelChunkSink& sink_;
  ProgressMeter& meter_;
  const uint64_t meter_total_;
  double root_estimate_ = 1, done_ = 0;
  uint64_t reported_ = 0;

  std::vector<WholeInstance> whole_;  // per Scene::instances entry
  std::vector<Live> live_;
  std::vector<Candidate> cands_;
  // The tile's triangle pieces and their candidates' range in cands_
  // (before the priority sort), for count_coincident_cover().
  std::vector<PlanarPiece> pieces_;
  std::vector<std::pair<size_t, size_t>> piece_cands_;
  std::vector<uint32_t> rejected_;
  std::vector<Surfel> chunk_;
  std::unordered_map<uint64_t, uint32_t> heads_;
  std::vector<uint32_t> dense_heads_;
  bool dense_ = false;
  int64_t dims_ = 0;
  V3f grid_origin_{0, 0, 0};
  std::vector<uint32_t> next_;
  float cell_ = 1.f, inv_cell_ = 1.f;
};

}  // namespace

void sample_poisson(const Scene& scene, const SurfelOptions& options, const SurfelChunkSink& sink,
                    const ProgressFn& progress) {
  const SceneArea area = scene_area(scene);
  if (!(area.total > 0.0)) return;
  const SpacingField field = options.adaptive() ? SpacingField(scene, options)
                                                : SpacingField(absolute_spacing(scene, options, area.total));

  // The cube the octree splits: the scene's bounds, squared and widened a
  // little so that no vertex lies on its far faces (cells are half-open).
  const Box3f b = scene.bounds();
  const float side = std::max({b.size().x, b.size().y, b.size().z}) * 1.001f + 1e-6f;
  const V3f lo = b.min - V3f(side * 0.0005f + 1e-7f);
  const Box3f cube(lo, lo + V3f(side));

  constexpr uint64_t kMeterSteps = 1000;
  ProgressMeter meter(progress, "sample_surfels", kMeterSteps);
  PoissonSampler sampler(scene, options, field, sink, meter, kMeterSteps);
  CellItems items = sampler.root_items();
  const double expected = sampler.estimate(cube, items);
  if (expected > double(1ull << 31)) {
    throw InvalidArgument(fmt::format("{}: the surfel spacing would produce {:.3g} surfels (limit 2^31)",
                                      scene.source_path, expected));
  }
  sampler.run(cube, std::move(items), expected);
  meter.finish();
}

}  // namespace pbgi
