#include "server/scene/scene_bulk.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace pbgi {
namespace {

using Imath::V3d;
using Box3d = Imath::Box3d;

constexpr double kLowQuantile = 0.01;
constexpr double kHighQuantile = 0.99;
// How far from the core's geometry a piece still belongs to the bulk, in
// units of the core's largest side.
constexpr double kReach = 2.0;
// Samples per axis for the percentiles; larger scenes are strided.
constexpr size_t kMaxSamples = size_t(1) << 20;

bool finite(const V3f& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
V3d to_d(const V3f& p) { return V3d(p.x, p.y, p.z); }
double largest_side(const Box3d& b) {
  const V3d s = b.size();
  return std::max({s.x, s.y, s.z});
}

// Per prototype: its box and area in its own space.
struct PrototypeShape {
  Box3f box;
  double area = 0.0;
};

double triangle_area(const V3f& a, const V3f& b, const V3f& c) {
  return 0.5 * (to_d(b) - to_d(a)).cross(to_d(c) - to_d(a)).length();
}

PrototypeShape prototype_shape(const TriangleSoup& t) {
  PrototypeShape s;
  for (const V3f& p : t.positions)
    if (finite(p)) s.box.extendBy(p);
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    const double a = triangle_area(t.positions[t.indices[3 * i]], t.positions[t.indices[3 * i + 1]],
                                   t.positions[t.indices[3 * i + 2]]);
    if (std::isfinite(a)) s.area += a;
  }
  return s;
}

// A world triangle or an instance, as the statistics see it.
struct Piece {
  Box3d box;
  double area = 0.0;
  uint64_t triangles = 0;
  V3d centre() const { return box.center(); }
};

// Walks the scene's pieces: f(piece, instance or -1, world triangle index).
class Pieces {
 public:
  explicit Pieces(const Scene& scene) : scene_(scene) {
    shapes_.reserve(scene.prototypes.size());
    for (const Prototype& p : scene.prototypes) shapes_.push_back(prototype_shape(p.triangles));
  }

  size_t count() const { return scene_.triangles.triangle_count() + scene_.instances.size(); }

  // Pieces with a non-finite corner are skipped (bounds() leaves such
  // vertices out too).
  template <typename F>
  void for_each(F&& f) const {
    const TriangleSoup& t = scene_.triangles;
    for (size_t i = 0; i < t.triangle_count(); ++i) {
      const V3f& a = t.positions[t.indices[3 * i]];
      const V3f& b = t.positions[t.indices[3 * i + 1]];
      const V3f& c = t.positions[t.indices[3 * i + 2]];
      if (!finite(a) || !finite(b) || !finite(c)) continue;
      Piece p;
      p.box.extendBy(to_d(a));
      p.box.extendBy(to_d(b));
      p.box.extendBy(to_d(c));
      p.area = triangle_area(a, b, c);
      p.triangles = 1;
      f(p, -1, i);
    }
    for (size_t k = 0; k < scene_.instances.size(); ++k) {
      const Instance& inst = scene_.instances[k];
      const PrototypeShape& s = shapes_[inst.prototype];
      if (s.box.isEmpty()) continue;
      Piece p;
      bool ok = true;
      for (int corner = 0; corner < 8; ++corner) {
        const V3f local((corner & 1) ? s.box.max.x : s.box.min.x, (corner & 2) ? s.box.max.y : s.box.min.y,
                        (corner & 4) ? s.box.max.z : s.box.min.z);
        V3f w;
        inst.local_to_world.multVecMatrix(local, w);
        ok = ok && finite(w);
        p.box.extendBy(to_d(w));
      }
      if (!ok) continue;
      const double scale = std::cbrt(std::fabs(double(inst.local_to_world.determinant())));
      p.area = s.area * scale * scale;
      p.triangles = scene_.prototypes[inst.prototype].triangles.triangle_count();
      f(p, long(k), 0);
    }
  }

 private:
  const Scene& scene_;
  std::vector<PrototypeShape> shapes_;
};

// The value below which a fraction q of the total weight lies.
double weighted_quantile(std::vector<std::pair<double, double>>& samples, double total, double q) {
  std::sort(samples.begin(), samples.end());
  double sum = 0.0;
  for (const auto& [value, weight] : samples) {
    sum += weight;
    if (sum >= q * total) return value;
  }
  return samples.back().first;
}

// The box of the area-weighted percentiles of the pieces' centres.
Box3d percentile_box(const Pieces& pieces) {
  const size_t stride = std::max<size_t>(1, (pieces.count() + kMaxSamples - 1) / kMaxSamples);
  std::vector<std::pair<double, double>> axis[3];
  size_t n = 0;
  double total = 0.0;
  pieces.for_each([&](const Piece& p, long, size_t) {
    if (n++ % stride != 0) return;
    const V3d c = p.centre();
    const double w = std::isfinite(p.area) ? p.area : 0.0;
    for (int a = 0; a < 3; ++a) axis[a].emplace_back(c[a], w);
    total += w;
  });
  Box3d box;
  if (axis[0].empty()) return box;
  if (!(total > 0.0)) {  // only degenerate triangles: count them instead
    for (auto& v : axis)
      for (auto& s : v) s.second = 1.0;
    total = double(axis[0].size());
  }
  for (int a = 0; a < 3; ++a) {
    box.min[a] = weighted_quantile(axis[a], total, kLowQuantile);
    box.max[a] = weighted_quantile(axis[a], total, kHighQuantile);
  }
  return box;
}

bool contains(const Box3d& b, const V3d& p) {
  return p.x >= b.min.x && p.x <= b.max.x && p.y >= b.min.y && p.y <= b.max.y && p.z >= b.min.z &&
         p.z <= b.max.z;
}

// Bounds of the bulk's vertices (as Scene::bounds() computes them).
Box3f vertex_bounds(const Scene& scene, const std::vector<uint8_t>& outlying_triangle,
                    const std::vector<uint8_t>& outlying_instance) {
  Box3f box;
  const TriangleSoup& t = scene.triangles;
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    if (outlying_triangle[i]) continue;
    for (int k = 0; k < 3; ++k) {
      const V3f& p = t.positions[t.indices[3 * i + k]];
      if (finite(p)) box.extendBy(p);
    }
  }
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    if (outlying_instance[k]) continue;
    const Instance& inst = scene.instances[k];
    for (const V3f& p : scene.prototypes[inst.prototype].triangles.positions) {
      V3f w;
      inst.local_to_world.multVecMatrix(p, w);
      if (finite(w)) box.extendBy(w);
    }
  }
  return box;
}

}  // namespace

SceneBulk scene_bulk(const Scene& scene) {
  SceneBulk bulk;
  const Pieces pieces(scene);
  // 1. The percentile box of the centres, then the core: every piece
  //    centred in it, whole.
  const Box3d percentiles = percentile_box(pieces);
  Box3d core;
  if (!percentiles.isEmpty()) {
    pieces.for_each([&](const Piece& p, long, size_t) {
      if (contains(percentiles, p.centre())) core.extendBy(p.box);
    });
  }
  if (core.isEmpty()) {
    bulk.bounds = scene.bounds();
    return bulk;
  }
  // 2. The reach around the core; pieces centred beyond it lie apart.
  const double reach = kReach * largest_side(core);
  const Box3d within(core.min - V3d(reach), core.max + V3d(reach));
  std::vector<uint8_t> outlying_triangle(scene.triangles.triangle_count(), 0);
  std::vector<uint8_t> outlying_instance(scene.instances.size(), 0);
  pieces.for_each([&](const Piece& p, long instance, size_t triangle) {
    if (contains(within, p.centre())) return;
    (instance < 0 ? outlying_triangle[triangle] : outlying_instance[size_t(instance)]) = 1;
    bulk.outlying_triangles += p.triangles;
    bulk.outlying_extent = std::max(bulk.outlying_extent, float(largest_side(p.box)));
  });
  // 3. Nothing apart: the scene's own bounds, bit for bit.
  bulk.bounds = bulk.has_outliers() ? vertex_bounds(scene, outlying_triangle, outlying_instance) : scene.bounds();
  return bulk;
}

}  // namespace pbgi
