#include "server/surfels/cross_range_cover.h"

#include "server/scene/rng.h"
#include "server/surfels/triangle_ranges.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <unordered_map>

namespace pbgi {
namespace {

// An object of the candidate search: a world triangle (range 0) or an
// instance's whole bounds (range k + 1).
struct Object {
  Box3f box;
  uint32_t range;
};

// A box spanning more grid cells than this is checked against every object
// instead (a ground plane's two triangles).
constexpr int64_t kMaxCells = 512;

Box3f triangle_box(const TriangleRange& range, uint32_t j, float widen) {
  const TriangleRef t = range.triangle(j);
  Box3f b;
  for (int k = 0; k < 3; ++k) b.extendBy(t.position(k));
  b.min -= V3f(widen);
  b.max += V3f(widen);
  return b;
}

Box3f instance_box(const Scene& scene, const Instance& inst, float widen) {
  Box3f local;
  for (const V3f& v : scene.prototypes[inst.prototype].triangles.positions) local.extendBy(v);
  Box3f b;
  if (local.isEmpty()) return b;
  for (int c = 0; c < 8; ++c) {
    const V3f corner((c & 1) ? local.max.x : local.min.x, (c & 2) ? local.max.y : local.min.y,
                     (c & 4) ? local.max.z : local.min.z);
    V3f world;
    inst.local_to_world.multVecMatrix(corner, world);
    b.extendBy(world);
  }
  b.min -= V3f(widen);
  b.max += V3f(widen);
  return b;
}

// Objects in a uniform grid of cubic cells (hashed).
class ObjectGrid {
 public:
  ObjectGrid(const std::vector<Object>& objects, float cell) : objects_(objects), inv_(1.f / cell) {
    for (uint32_t i = 0; i < objects.size(); ++i) {
      int64_t lo[3], hi[3];
      if (!cells(objects[i].box, lo, hi)) {
        big_.push_back(i);
        continue;
      }
      for (int64_t x = lo[0]; x <= hi[0]; ++x)
        for (int64_t y = lo[1]; y <= hi[1]; ++y)
          for (int64_t z = lo[2]; z <= hi[2]; ++z) cells_[key(x, y, z)].push_back(i);
    }
  }

  // Whether `box` meets an object of a range other than `range`.
  bool meets_other(const Box3f& box, uint32_t range) const {
    auto hit = [&](uint32_t i) {
      const Object& o = objects_[i];
      return o.range != range && o.box.intersects(box);
    };
    for (const uint32_t i : big_)
      if (hit(i)) return true;
    int64_t lo[3], hi[3];
    if (!cells(box, lo, hi)) {
      for (uint32_t i = 0; i < objects_.size(); ++i)
        if (hit(i)) return true;
      return false;
    }
    for (int64_t x = lo[0]; x <= hi[0]; ++x)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t z = lo[2]; z <= hi[2]; ++z) {
          const auto it = cells_.find(key(x, y, z));
          if (it == cells_.end()) continue;
          for (const uint32_t i : it->second)
            if (hit(i)) return true;
        }
    return false;
  }

 private:
  static uint64_t key(int64_t x, int64_t y, int64_t z) {
    return hash_ids(uint64_t(x), hash_ids(uint64_t(y), uint64_t(z)));
  }
  // The cell range of a box; false when it spans more than kMaxCells.
  bool cells(const Box3f& b, int64_t lo[3], int64_t hi[3]) const {
    int64_t n = 1;
    for (int a = 0; a < 3; ++a) {
      const double l = std::floor(double(b.min[a]) * inv_), h = std::floor(double(b.max[a]) * inv_);
      if (!std::isfinite(l) || !std::isfinite(h) || h - l + 1 > double(kMaxCells)) return false;
      lo[a] = int64_t(l);
      hi[a] = int64_t(h);
      n *= hi[a] - lo[a] + 1;
      if (n > kMaxCells) return false;
    }
    return true;
  }

  const std::vector<Object>& objects_;
  float inv_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
  std::vector<uint32_t> big_;
};

uint64_t index_key(size_t range, uint32_t j) { return uint64_t(range) << 32 | j; }

}  // namespace

CrossRangeCover::CrossRangeCover(const Scene& scene, const V3f& centre, float plane_tolerance) {
  const size_t ranges = range_count(scene);
  if (ranges < 2) return;
  // 1. Objects: the world soup's triangles and the instances' bounds.
  std::vector<Object> objects;
  const TriangleRange world = triangle_range(scene, 0);
  for (uint32_t j = 0; j < world.size(); ++j) {
    if (world.area(j) > 0.f) objects.push_back({triangle_box(world, j, plane_tolerance), 0});
  }
  for (size_t r = 1; r < ranges; ++r) {
    const Box3f b = instance_box(scene, scene.instances[r - 1], plane_tolerance);
    if (!b.isEmpty()) objects.push_back({b, uint32_t(r)});
  }
  if (objects.empty()) return;
  // Cells about the median object's size.
  std::vector<float> sizes;
  sizes.reserve(objects.size());
  for (const Object& o : objects) sizes.push_back((o.box.max - o.box.min).length());
  const auto median = sizes.begin() + std::ptrdiff_t(sizes.size() / 2);
  std::nth_element(sizes.begin(), median, sizes.end());
  const float cell = std::max(*median, 1e-6f);
  const ObjectGrid grid(objects, cell);

  // 2. Candidates: triangles whose bounds meet another range's object.
  //    An instance is looked at triangle by triangle only when its bounds
  //    meet another range's.
  std::vector<std::pair<size_t, uint32_t>> picked;
  std::vector<uint8_t> meets;
  auto pick = [&](size_t r) {
    const TriangleRange range = triangle_range(scene, r);
    meets.assign(range.size(), 0);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, range.size(), 4096), [&](const auto& q) {
      for (uint32_t j = q.begin(); j != q.end(); ++j) {
        meets[j] = range.area(j) > 0.f && grid.meets_other(triangle_box(range, j, plane_tolerance), uint32_t(r));
      }
    });
    for (uint32_t j = 0; j < range.size(); ++j)
      if (meets[j]) picked.emplace_back(r, j);
  };
  pick(0);
  for (size_t r = 1; r < ranges; ++r) {
    const Box3f b = instance_box(scene, scene.instances[r - 1], plane_tolerance);
    if (!b.isEmpty() && grid.meets_other(b, uint32_t(r))) pick(r);
  }
  if (picked.empty()) return;

  // 3. The cover of the candidates, in world space.
  auto piece = [&](uint32_t i, PlanarPiece* out) {
    const TriangleRef t = triangle_range(scene, picked[i].first).triangle(picked[i].second);
    return PlanarPiece::of_triangle(t.position(0), t.position(1), t.position(2), out);
  };
  cover_ = CoincidentCover(uint32_t(picked.size()), piece, centre, plane_tolerance);
  if (!cover_.any()) return;
  index_.reserve(picked.size());
  for (uint32_t i = 0; i < picked.size(); ++i) index_.emplace_back(index_key(picked[i].first, picked[i].second), i);
  std::sort(index_.begin(), index_.end());
}

uint32_t CrossRangeCover::cover(size_t range, uint32_t j, const V3f& p) const {
  const uint64_t k = index_key(range, j);
  const auto it = std::lower_bound(index_.begin(), index_.end(), std::pair<uint64_t, uint32_t>(k, 0));
  if (it == index_.end() || it->first != k) return 0;
  return cover_.cover(it->second, p);
}

}  // namespace pbgi
