#include "server/scene/air_regions.h"

#include "common/errors.h"
#include "server/scene/scene_bulk.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace pbgi {

namespace {

using V3d = Imath::V3d;

// Whether the triangle (a, b, c), relative to a box's centre, overlaps the
// box [-h, h]^3: the separating axis test over the box's three axes, the
// triangle's normal and the nine cross products of their edges.
bool triangle_overlaps_box(const V3d& a, const V3d& b, const V3d& c, double h) {
  const V3d e[3] = {b - a, c - b, a - c};
  const V3d v[3] = {a, b, c};
  auto separated = [&](const V3d& axis) {
    const double p0 = axis.dot(v[0]), p1 = axis.dot(v[1]), p2 = axis.dot(v[2]);
    const double r = h * (std::abs(axis.x) + std::abs(axis.y) + std::abs(axis.z));
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
  };
  const V3d box_axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const V3d& u : box_axes) {
    if (separated(u)) return false;
    for (const V3d& edge : e) {
      const V3d axis = u.cross(edge);
      if (axis.length2() > 0.0 && separated(axis)) return false;
    }
  }
  const V3d normal = e[0].cross(e[1]);
  return !(normal.length2() > 0.0 && separated(normal));
}

bool opaque(const Material& m) {
  if (m.opacity_texture.bound()) return false;
  return m.opacity >= 1.f || (m.opacity_threshold > 0.f && m.opacity >= m.opacity_threshold);
}

struct Dense {
  V3f origin;
  float voxel = 0.f;
  Imath::V3i dims;
  size_t index(int x, int y, int z) const {
    return size_t(x) + size_t(dims.x) * (size_t(y) + size_t(dims.y) * size_t(z));
  }
  V3f center(int x, int y, int z) const {
    return origin + voxel * V3f(float(x) + 0.5f, float(y) + 0.5f, float(z) + 0.5f);
  }
};

// Marks the voxels the scene's opaque triangles overlap.
std::vector<uint8_t> solid_voxels(const Scene& scene, const Dense& d) {
  std::vector<uint8_t> solid(size_t(d.dims.x) * size_t(d.dims.y) * size_t(d.dims.z), 0);
  const double h = 0.5 * double(d.voxel);
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, scene.triangle_count(), 4096), [&](const auto& range) {
    for (uint64_t id = range.begin(); id != range.end(); ++id) {
      const TriangleRef t = scene.triangle(uint32_t(id));
      if (!opaque(scene.materials[t.material()])) continue;
      const V3f p[3] = {t.position(0), t.position(1), t.position(2)};
      int lo[3], hi[3];
      bool inside = true;  // the triangle's box meets the grid (far outliers do not)
      for (int a = 0; a < 3; ++a) {
        const double mn = (double(std::min({p[0][a], p[1][a], p[2][a]})) - d.origin[a]) / d.voxel;
        const double mx = (double(std::max({p[0][a], p[1][a], p[2][a]})) - d.origin[a]) / d.voxel;
        inside = inside && mx >= 0.0 && mn < double(d.dims[a]);  // false for NaN too
        if (!inside) break;
        lo[a] = std::max(0, int(std::floor(mn)));
        hi[a] = std::min(d.dims[a] - 1, int(std::floor(mx)));
      }
      if (!inside) continue;
      for (int z = lo[2]; z <= hi[2]; ++z) {
        for (int y = lo[1]; y <= hi[1]; ++y) {
          for (int x = lo[0]; x <= hi[0]; ++x) {
            uint8_t& cell = solid[d.index(x, y, z)];
            if (std::atomic_ref<uint8_t>(cell).load(std::memory_order_relaxed)) continue;
            const V3f c = d.center(x, y, z);
            const V3d cd(c.x, c.y, c.z);
            auto rel = [&](const V3f& q) { return V3d(q.x, q.y, q.z) - cd; };
            // A hair larger than the voxel: a triangle along a face counts.
            if (triangle_overlaps_box(rel(p[0]), rel(p[1]), rel(p[2]), h * (1.0 + 1e-5))) {
              std::atomic_ref<uint8_t>(cell).store(1, std::memory_order_relaxed);
            }
          }
        }
      }
    }
  });
  return solid;
}

// 6-connected flood fill of the non-solid voxels: labels 1, 2, ... in scan
// order, 0 for solid ones.
std::vector<uint32_t> flood_fill(const std::vector<uint8_t>& solid, const Dense& d, uint32_t& count) {
  constexpr uint32_t kUnset = ~0u;
  std::vector<uint32_t> label(solid.size());
  for (size_t i = 0; i < solid.size(); ++i) label[i] = solid[i] ? tree::kSolidVoxel : kUnset;
  std::vector<size_t> queue;
  count = 0;
  const size_t sx = 1, sy = size_t(d.dims.x), sz = size_t(d.dims.x) * size_t(d.dims.y);
  for (size_t seed = 0; seed < label.size(); ++seed) {
    if (label[seed] != kUnset) continue;
    const uint32_t id = ++count;
    label[seed] = id;
    queue.assign(1, seed);
    while (!queue.empty()) {
      const size_t i = queue.back();
      queue.pop_back();
      const int x = int(i % sy), y = int(i / sy % size_t(d.dims.y)), z = int(i / sz);
      auto visit = [&](bool inside, size_t j) {
        if (inside && label[j] == kUnset) {
          label[j] = id;
          queue.push_back(j);
        }
      };
      visit(x > 0, i - sx);
      visit(x + 1 < d.dims.x, i + sx);
      visit(y > 0, i - sy);
      visit(y + 1 < d.dims.y, i + sy);
      visit(z > 0, i - sz);
      visit(z + 1 < d.dims.z, i + sz);
    }
  }
  return label;
}

uint32_t find(std::vector<uint32_t>& parent, uint32_t a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

// Regions the voxelization split where the surfaces leave a gap: two
// non-solid voxels on either side of one or two solid ones along an axis,
// of different regions, are joined when a ray between them (at the centre
// and four points around it) meets no surface. Labels are renumbered
// 1..count in scan order.
void join_through_gaps(std::vector<uint32_t>& label, const Dense& d, const RayScene& rays, uint32_t& count) {
  std::vector<uint32_t> parent(count + 1);
  std::iota(parent.begin(), parent.end(), 0u);
  const float q = 0.25f * d.voxel;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    V3f dir(0.f);
    dir[axis] = 1.f;
    V3f du(0.f), dv(0.f);
    du[u] = q;
    dv[v] = q;
    for (int z = 0; z < d.dims.z; ++z) {
      for (int y = 0; y < d.dims.y; ++y) {
        for (int x = 0; x < d.dims.x; ++x) {
          const uint32_t a = label[d.index(x, y, z)];
          if (a == tree::kSolidVoxel) continue;
          int at[3] = {x, y, z};
          for (int gap = 1; gap <= 2; ++gap) {
            int bt[3] = {x, y, z};
            bt[axis] += gap + 1;
            if (bt[axis] >= d.dims[axis]) break;
            bool all_solid = true;
            for (int k = 1; k <= gap; ++k) {
              int st[3] = {x, y, z};
              st[axis] += k;
              all_solid = all_solid && label[d.index(st[0], st[1], st[2])] == tree::kSolidVoxel;
            }
            if (!all_solid) break;
            const uint32_t b = label[d.index(bt[0], bt[1], bt[2])];
            if (b == tree::kSolidVoxel || find(parent, a) == find(parent, b)) continue;
            const V3f from = d.center(at[0], at[1], at[2]);
            const float length = float(gap + 1) * d.voxel;
            const V3f offsets[5] = {V3f(0.f), du, -du, dv, -dv};
            for (const V3f& o : offsets) {
              if (!rays.occluded(from + o, dir, 0.f, length)) {
                parent[find(parent, a)] = find(parent, b);
                break;
              }
            }
          }
        }
      }
    }
  }
  std::vector<uint32_t> renumber(count + 1, 0);
  uint32_t next = 0;
  for (uint32_t& l : label) {
    if (l == tree::kSolidVoxel) continue;
    const uint32_t r = find(parent, l);
    if (renumber[r] == 0) renumber[r] = ++next;
    l = renumber[r];
  }
  count = next;
}

}  // namespace

tree::RegionGrid build_air_regions(const Scene& scene, const RayScene& rays, uint32_t resolution) {
  if (resolution < 8) throw InvalidArgument("air regions: resolution " + std::to_string(resolution) + " is below 8");
  // The bulk's bounds: a far outlier must not coarsen the grid (what lies
  // outside it is in no region: kAnyRegion).
  const Box3f bounds = scene_bulk(scene).bounds;
  if (bounds.isEmpty()) return {};
  const V3f size = bounds.size();
  const float side = std::max({size.x, size.y, size.z});
  if (!(side > 0.f) || !std::isfinite(side)) return {};
  Dense d;
  d.voxel = side / float(resolution);
  // Two voxels of padding all round (a surface on the bounds can make the
  // first solid): the outside is one region around everything.
  d.origin = bounds.min - V3f(2.f * d.voxel);
  for (int a = 0; a < 3; ++a) d.dims[a] = std::max(1, int(std::ceil(size[a] / d.voxel))) + 4;
  const std::vector<uint8_t> solid = solid_voxels(scene, d);
  uint32_t count = 0;
  std::vector<uint32_t> label = flood_fill(solid, d, count);
  if (count > 1) join_through_gaps(label, d, rays, count);
  return tree::RegionGrid::from_dense(d.origin, d.voxel, d.dims, label);
}

uint32_t locate_region(const tree::RegionGrid& grid, const RayScene& rays, const V3f& p, const V3f& n, bool guess) {
  if (grid.empty()) return tree::kAnyRegion;
  const float h = grid.voxel();
  // Off the surface by a hair of the voxel, so the rays do not meet it.
  const V3f origin = p + n * (1e-3f * h);
  auto sees = [&](const Imath::V3i& v) {
    const V3f to = grid.center(v) - origin;
    const float length = to.length();
    return length > 0.f && !rays.occluded(origin, to / length, 0.f, length);
  };
  // 1. Straight out along the normal.
  for (int k = 1; k <= 3; ++k) {
    const auto v = grid.voxel_of(p + n * (float(k) * h));
    if (!v) break;
    const uint32_t l = grid.label(*v);
    if (l != tree::kSolidVoxel && sees(*v)) return l;
  }
  // 2. The voxels around one voxel out, nearest first, in front of the point.
  const auto c = grid.voxel_of(p + n * h);
  if (!c) return tree::kAnyRegion;
  struct Candidate {
    float d2;
    Imath::V3i v;
    uint32_t label;
  };
  std::array<Candidate, 125> found{};
  size_t count = 0;
  for (int dz = -2; dz <= 2; ++dz) {
    for (int dy = -2; dy <= 2; ++dy) {
      for (int dx = -2; dx <= 2; ++dx) {
        const Imath::V3i v(c->x + dx, c->y + dy, c->z + dz);
        if (v.x < 0 || v.y < 0 || v.z < 0 || v.x >= grid.dims().x || v.y >= grid.dims().y || v.z >= grid.dims().z) {
          continue;
        }
        const uint32_t l = grid.label(v);
        const V3f to = grid.center(v) - p;
        if (l == tree::kSolidVoxel || to.dot(n) <= 0.f) continue;
        found[count++] = {to.length2(), v, l};
      }
    }
  }
  std::sort(found.begin(), found.begin() + ptrdiff_t(count),
            [](const Candidate& a, const Candidate& b) { return a.d2 != b.d2 ? a.d2 < b.d2 : a.label < b.label; });
  for (size_t i = 0; i < count; ++i) {
    if (sees(found[i].v)) return found[i].label;
  }
  return guess && count > 0 ? found[0].label : tree::kAnyRegion;
}

}  // namespace pbgi
