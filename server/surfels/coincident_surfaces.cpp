#include "server/surfels/coincident_surfaces.h"

#include "server/scene/rng.h"

#include <tbb/parallel_sort.h>

#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

// Plane keys: normal components quantized by this step.
constexpr float kNormalStep = 1.f / 64.f;
// Plane offsets quantized by this many tolerances.
constexpr float kOffsetSteps = 16.f;
// A piece spanning more grid cells than this is paired with every member of
// its key instead (few: the cell follows the members' median size).
constexpr int64_t kMaxCellsPerPiece = 256;

uint64_t cell_key(int64_t a, int64_t b) { return hash_ids(uint64_t(a), uint64_t(b)); }

// Whether the triangles of two coplanar pieces overlap with positive area
// (separating axes in a's plane, with a margin relative to their size), so
// that neighbours sharing an edge or a vertex are not paired.
bool triangles_overlap(const PlanarPiece& a, const PlanarPiece& b) {
  using V2 = Imath::V2f;
  auto in_a = [&a](const V3f& p) {
    const V3f d = p - a.p0;
    return V2(d.dot(a.e1), d.dot(a.e2));
  };
  const V2 ta[3] = {V2(0, 0), V2(a.u1, 0), V2(a.u2, a.v2)};
  const V2 tb[3] = {in_a(b.p0), in_a(b.p0 + b.u1 * b.e1), in_a(b.p0 + b.u2 * b.e1 + b.v2 * b.e2)};
  const float size = std::max({a.u1, std::fabs(a.u2), std::fabs(a.v2), b.u1, std::fabs(b.u2), std::fabs(b.v2)});
  const float margin = 1e-4f * size;
  for (const V2* t : {ta, tb})
    for (int e = 0; e < 3; ++e) {
      const V2 edge = t[(e + 1) % 3] - t[e];
      const float len = edge.length();
      if (!(len > 0.f)) continue;
      const V2 axis(-edge.y / len, edge.x / len);
      float amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
      for (int k = 0; k < 3; ++k) {
        amin = std::min(amin, axis.dot(ta[k]));
        amax = std::max(amax, axis.dot(ta[k]));
        bmin = std::min(bmin, axis.dot(tb[k]));
        bmax = std::max(bmax, axis.dot(tb[k]));
      }
      if (amax <= bmin + margin || bmax <= amin + margin) return false;
    }
  return true;
}

}  // namespace

bool PlanarPiece::of_triangle(const V3f& a, const V3f& b, const V3f& c, PlanarPiece* out) {
  const V3f n = (b - a).cross(c - a);
  const float len = n.length();
  const float u1 = (b - a).length();
  if (!(len > 0.f) || !(u1 > 0.f) || !std::isfinite(len)) return false;
  PlanarPiece& f = *out;
  f.p0 = a;
  f.n = n / len;
  f.u1 = u1;
  f.e1 = (b - a) / u1;
  f.e2 = f.n.cross(f.e1);
  f.u2 = (c - a).dot(f.e1);
  f.v2 = (c - a).dot(f.e2);
  if (!(f.v2 != 0.f)) return false;
  f.bounds = Box3f();
  f.bounds.extendBy(a);
  f.bounds.extendBy(b);
  f.bounds.extendBy(c);
  return true;
}

CoincidentCover::CoincidentCover(uint32_t count, const PieceFn& piece, const V3f& centre,
                                 float plane_tolerance) {
  if (count < 2 || !(plane_tolerance > 0.f)) return;
  const float tol_d = plane_tolerance, step_d = kOffsetSteps * plane_tolerance;
  auto offset = [&centre](const PlanarPiece& f) { return f.n.dot(f.p0 - centre); };

  // 1. Plane keys, sorted so that a key's pieces are contiguous; a value
  //    within tolerance of a bucket boundary goes into both buckets, so
  //    coincident pieces share at least one key.
  std::vector<std::pair<uint64_t, uint32_t>> keys;
  keys.reserve(count);
  PlanarPiece f;
  for (uint32_t i = 0; i < count; ++i) {
    if (!piece(i, &f)) continue;
    if (f.bounds.isEmpty() || !(f.n.length2() > 0.5f) || !std::isfinite(offset(f))) continue;
    const float v[4] = {f.n.x, f.n.y, f.n.z, offset(f)};
    int64_t lo[4], hi[4];
    for (int k = 0; k < 4; ++k) {
      const float step = k < 3 ? kNormalStep : step_d, tol = k < 3 ? kNormalTolerance : tol_d;
      // Buckets centred on multiples of the step: axis-aligned normals
      // (components 0 and +-1, the common case) sit in the middle of one.
      lo[k] = int64_t(std::floor((v[k] - tol) / step + 0.5f));
      hi[k] = int64_t(std::floor((v[k] + tol) / step + 0.5f));
    }
    for (int64_t a = lo[0]; a <= hi[0]; ++a)
      for (int64_t b = lo[1]; b <= hi[1]; ++b)
        for (int64_t c = lo[2]; c <= hi[2]; ++c)
          for (int64_t d = lo[3]; d <= hi[3]; ++d)
            keys.push_back({hash_ids(uint64_t(a), uint64_t(b), uint64_t(c), uint64_t(d)), i});
  }
  tbb::parallel_sort(keys.begin(), keys.end());  // a total order: deterministic

  // 2. Within a key: candidate pairs through a 2D grid over the two axes
  //    most parallel to the plane, then the exact tests.
  std::vector<std::pair<uint32_t, PlanarPiece>> members;
  int ax = 0, ay = 1, drop = 2;  // per key, below
  auto coincident = [&](const PlanarPiece& pa, const PlanarPiece& pb) {
    // Cheap tests first: along the two in-plane axes the bounds must
    // overlap by more than a sliver (neighbours sharing an edge only touch),
    // across the plane within the tolerance.
    for (const int k : {ax, ay}) {
      const float margin = 1e-4f * std::max(pa.bounds.size()[k], pb.bounds.size()[k]);
      if (pb.bounds.min[k] >= pa.bounds.max[k] - margin || pa.bounds.min[k] >= pb.bounds.max[k] - margin)
        return false;
    }
    if (pb.bounds.min[drop] > pa.bounds.max[drop] + tol_d || pa.bounds.min[drop] > pb.bounds.max[drop] + tol_d)
      return false;
    const V3f dn = pb.n - pa.n;
    if (std::fabs(dn.x) > kNormalTolerance || std::fabs(dn.y) > kNormalTolerance ||
        std::fabs(dn.z) > kNormalTolerance)
      return false;
    if (std::fabs(offset(pb) - offset(pa)) > tol_d) return false;
    return triangles_overlap(pa, pb);
  };
  auto add_pair = [&](size_t a, size_t b) {
    if (members[a].first == members[b].first || !coincident(members[a].second, members[b].second))
      return;
    pairs_.push_back({members[a].first, members[b].first});
    pairs_.push_back({members[b].first, members[a].first});
  };
  std::vector<std::pair<uint64_t, uint32_t>> grid;  // (cell, position in members), sorted
  std::vector<uint32_t> big;
  std::vector<float> sizes;
  for (size_t g0 = 0; g0 < keys.size();) {
    size_t g1 = g0 + 1;
    while (g1 < keys.size() && keys[g1].first == keys[g0].first) ++g1;
    if (g1 - g0 < 2) {
      g0 = g1;
      continue;
    }
    members.clear();
    for (size_t k = g0; k < g1; ++k) {
      members.push_back({keys[k].second, PlanarPiece()});
      piece(keys[k].second, &members.back().second);
    }
    g0 = g1;
    const V3f& n0 = members[0].second.n;
    drop = std::fabs(n0.x) >= std::fabs(n0.y) && std::fabs(n0.x) >= std::fabs(n0.z) ? 0
           : std::fabs(n0.y) >= std::fabs(n0.z)                                       ? 1
                                                                                      : 2;
    ax = (drop + 1) % 3;
    ay = (drop + 2) % 3;
    sizes.clear();
    for (const auto& m : members) {
      const V3f s = m.second.bounds.size();
      sizes.push_back(std::max(s[ax], s[ay]));
    }
    std::nth_element(sizes.begin(), sizes.begin() + sizes.size() / 2, sizes.end());
    const float cell = std::max(2.f * sizes[sizes.size() / 2], 4.f * tol_d);
    grid.clear();
    big.clear();
    for (uint32_t m = 0; m < members.size(); ++m) {
      // Pairs must overlap by more than a sliver in the plane (see
      // coincident()), so the bounds shrunk by that sliver pick the cells:
      // a mesh's triangles ending on a cell boundary stay out of the next.
      const Box3f& b = members[m].second.bounds;
      const float sx = 4e-5f * b.size()[ax], sy = 4e-5f * b.size()[ay];
      const int64_t x0 = int64_t(std::floor((b.min[ax] + sx) / cell));
      const int64_t x1 = int64_t(std::floor((b.max[ax] - sx) / cell));
      const int64_t y0 = int64_t(std::floor((b.min[ay] + sy) / cell));
      const int64_t y1 = int64_t(std::floor((b.max[ay] - sy) / cell));
      if ((x1 - x0 + 1) * (y1 - y0 + 1) > kMaxCellsPerPiece) {
        big.push_back(m);
        continue;
      }
      for (int64_t y = y0; y <= y1; ++y)
        for (int64_t x = x0; x <= x1; ++x) grid.push_back({cell_key(x, y), m});
    }
    tbb::parallel_sort(grid.begin(), grid.end());
    for (size_t c0 = 0; c0 < grid.size();) {
      size_t c1 = c0 + 1;
      while (c1 < grid.size() && grid[c1].first == grid[c0].first) ++c1;
      for (size_t a = c0; a < c1; ++a)
        for (size_t b = a + 1; b < c1; ++b) add_pair(grid[a].second, grid[b].second);
      c0 = c1;
    }
    for (uint32_t a : big)
      for (uint32_t b = 0; b < members.size(); ++b)
        if (a != b) add_pair(a, b);
  }
  tbb::parallel_sort(pairs_.begin(), pairs_.end());
  pairs_.erase(std::unique(pairs_.begin(), pairs_.end()), pairs_.end());

  // 3. Keep the frames of the paired pieces only.
  for (size_t k = 0; k < pairs_.size(); ++k) {
    if (k > 0 && pairs_[k].first == pairs_[k - 1].first) continue;
    frames_.push_back({pairs_[k].first, PlanarPiece()});
    piece(pairs_[k].first, &frames_.back().second);
  }
}

uint32_t CoincidentCover::cover(uint32_t i, const V3f& p) const {
  if (pairs_.empty()) return 1;
  auto it = std::lower_bound(pairs_.begin(), pairs_.end(), std::make_pair(i, uint32_t(0)));
  uint32_t count = 1;
  for (; it != pairs_.end() && it->first == i; ++it) {
    const auto f = std::lower_bound(frames_.begin(), frames_.end(), it->second,
                                    [](const auto& e, uint32_t j) { return e.first < j; });
    const PlanarPiece& g = f->second;
    const V3f d = p - g.p0;
    float b1, b2;
    if (g.barycentrics(d.dot(g.e1), d.dot(g.e2), b1, b2) && b1 > kInsideMargin && b2 > kInsideMargin &&
        1.f - b1 - b2 > kInsideMargin)
      ++count;
  }
  return count;
}

}  // namespace pbgi
