#include "server/scene/unrepresentable_geometry.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

namespace pbgi {
namespace {

using Imath::V3d;

// The spacing of floats at magnitude m: infinite where floats overflow.
double float_step(double m) {
  const float f = float(std::fabs(m));
  if (!std::isfinite(f)) return std::numeric_limits<double>::infinity();
  return double(std::nextafter(f, std::numeric_limits<float>::infinity())) - double(f);
}

double max_abs(const V3d& p) { return std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)}); }

// A frame the scene is (or will be) stored in: positions + shift, rounded
// to float, and the float step at the bulk's farthest corner there.
struct Frame {
  V3d shift{0.0, 0.0, 0.0};
  double bulk_step = 0.0;

  Frame(const V3d& s, const Box3f& bulk) : shift(s) {
    const V3d lo = V3d(bulk.min.x, bulk.min.y, bulk.min.z) + s;
    const V3d hi = V3d(bulk.max.x, bulk.max.y, bulk.max.z) + s;
    bulk_step = float_step(std::max(max_abs(lo), max_abs(hi)));
  }

  // The float position of p in this frame (p + shift rounded as the
  // rebase rounds it), in double.
  V3d place(const V3f& p) const {
    return V3d(float(double(p.x) + shift.x), float(double(p.y) + shift.y), float(double(p.z) + shift.z));
  }
};

// What a piece (a triangle's corners, an instance's box corners) looks
// like in one frame: its largest coordinate, the float step there and its
// size measured on the rounded points.
struct Placement {
  double distance = 0.0;
  double step = 0.0;
  double size = 0.0;

  // Also where the frame overflows floats.
  bool too_coarse() const { return !std::isfinite(distance) || !(size >= kMinFloatSteps * step); }
};

template <typename SizeFn>
Placement place(const Frame& f, const V3f* points, int n, SizeFn size_of) {
  V3d placed[8];
  Placement p;
  for (int k = 0; k < n; ++k) {
    placed[k] = f.place(points[k]);
    p.distance = std::max(p.distance, max_abs(placed[k]));
  }
  p.step = float_step(p.distance);
  p.size = size_of(placed, n);
  return p;
}

double longest_edge(const V3d* p, int) {
  return std::max({(p[1] - p[0]).length(), (p[2] - p[1]).length(), (p[0] - p[2]).length()});
}

double largest_side(const V3d* p, int n) {
  Imath::Box3d b;
  for (int k = 0; k < n; ++k) b.extendBy(p[k]);
  const V3d s = b.size();
  return std::max({s.x, s.y, s.z});
}

// Whether to drop a piece, and the placement that condemns it: too coarse
// in the local frame though it was not in the incoming one (the frame
// would destroy it), or too coarse in the incoming frame beyond the bulk
// (destroyed before the daemon saw it; within the bulk's steps a small or
// degenerate piece is input as authored).
struct Verdict {
  bool drop = false;
  Placement at;
  double distance = 0.0;  // from the render origin (local frame)
};

template <typename SizeFn>
Verdict judge(const Frame& incoming, const Frame& local, const V3f* points, int n, SizeFn size_of) {
  const Placement in = place(incoming, points, n, size_of);
  const Placement out = place(local, points, n, size_of);
  Verdict v;
  v.distance = out.distance;
  if (!in.too_coarse() && out.too_coarse()) {
    v.drop = true;
    v.at = out;
  } else if (in.too_coarse() && in.step > incoming.bulk_step) {
    v.drop = true;
    v.at = in;
  }
  return v;
}

bool finite(const V3f& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Per prim, in the order first met: what was dropped, for one warning.
struct PrimLoss {
  std::string prim;
  uint64_t count = 0;
  Verdict worst;  // the farthest piece
};

class Losses {
 public:
  void record(const std::string& prim, const Verdict& v) {
    const auto [it, added] = index_.try_emplace(prim, losses_.size());
    if (added) losses_.push_back({prim, 0, v});
    PrimLoss& l = losses_[it->second];
    ++l.count;
    if (v.distance > l.worst.distance) l.worst = v;
  }

  // One warning per prim (the first kMaxPrecisionWarnings), then a count.
  void warn(Scene& scene, const char* what) const {
    for (size_t i = 0; i < losses_.size() && i < kMaxPrecisionWarnings; ++i) {
      const PrimLoss& l = losses_[i];
      scene.warnings.push_back(fmt::format(
          "{}: {} {} dropped for float precision: {:.3g} units from the scene's render origin (the centre "
          "of the bulk of its geometry) floats are {:.3g} units apart, and their size there ({:.3g}) is "
          "under {} of those steps",
          l.prim, l.count, what, l.worst.distance, l.worst.at.step, l.worst.at.size, kMinFloatSteps));
    }
    if (losses_.size() > kMaxPrecisionWarnings)
      scene.warnings.push_back(fmt::format("{} more prims lost {} to float precision (dropped)",
                                           losses_.size() - kMaxPrecisionWarnings, what));
  }

 private:
  std::vector<PrimLoss> losses_;
  std::unordered_map<std::string, size_t> index_;
};

// Keeps the triangles with keep[i] and the vertices they use.
void compact_soup(TriangleSoup& t, const std::vector<uint8_t>& keep) {
  std::vector<uint32_t> remap(t.positions.size(), UINT32_MAX);
  std::vector<uint32_t> indices;
  std::vector<uint32_t> material, mesh;
  std::vector<uint32_t> vertices;  // old ids of the vertices kept, in new order
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    if (!keep[i]) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t& id = remap[t.indices[3 * i + k]];
      if (id == UINT32_MAX) {
        id = uint32_t(vertices.size());
        vertices.push_back(t.indices[3 * i + k]);
      }
      indices.push_back(id);
    }
    if (!t.material.empty()) material.push_back(t.material[i]);
    if (!t.mesh.empty()) mesh.push_back(t.mesh[i]);
  }
  auto gather = [&](auto& values) {
    if (values.empty()) return;
    std::remove_reference_t<decltype(values)> kept;
    kept.reserve(vertices.size());
    for (uint32_t v : vertices) kept.push_back(values[v]);
    values = std::move(kept);
  };
  gather(t.positions);
  gather(t.normals);
  gather(t.uvs);
  gather(t.colors);
  t.indices = std::move(indices);
  t.material = std::move(material);
  t.mesh = std::move(mesh);
}

// Keeps the instances with keep[k], renumbered as add_instance() numbers them.
void compact_instances(Scene& scene, const std::vector<uint8_t>& keep) {
  std::vector<Instance> kept;
  scene.instanced_triangle_count = 0;
  scene.instanced_mesh_count = 0;
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    if (!keep[k]) continue;
    Instance inst = scene.instances[k];
    const TriangleSoup& t = scene.prototypes[inst.prototype].triangles;
    inst.first_triangle = scene.instanced_triangle_count;
    inst.first_mesh = scene.instanced_mesh_count;
    scene.instanced_triangle_count += t.triangle_count();
    scene.instanced_mesh_count += uint32_t(std::max<size_t>(t.mesh_paths.size(), 1));
    kept.push_back(inst);
  }
  scene.instances = std::move(kept);
}

}  // namespace

DroppedGeometry drop_unrepresentable_geometry(Scene& scene, const V3d& origin, const Box3f& bulk) {
  DroppedGeometry dropped;
  if (bulk.isEmpty()) return dropped;
  const Frame incoming(V3d(0.0), bulk);
  const Frame local(scene.render_origin - origin, bulk);

  // 1. World triangles, judged one by one.
  TriangleSoup& t = scene.triangles;
  std::vector<uint8_t> keep(t.triangle_count(), 1);
  Losses triangle_losses;
  for (size_t i = 0; i < t.triangle_count(); ++i) {
    const V3f corners[3] = {t.positions[t.indices[3 * i]], t.positions[t.indices[3 * i + 1]],
                            t.positions[t.indices[3 * i + 2]]};
    if (!finite(corners[0]) || !finite(corners[1]) || !finite(corners[2])) continue;  // not a precision matter
    const Verdict v = judge(incoming, local, corners, 3, longest_edge);
    if (!v.drop) continue;
    keep[i] = 0;
    ++dropped.triangles;
    triangle_losses.record(TriangleRef{&t, uint32_t(i), nullptr}.mesh_path(), v);
  }

  // 2. Instances, by the corners of their transformed prototype box.
  std::vector<uint8_t> keep_instance(scene.instances.size(), 1);
  Losses instance_losses;
  std::vector<Box3f> prototype_boxes(scene.prototypes.size());
  for (size_t p = 0; p < scene.prototypes.size(); ++p)
    for (const V3f& q : scene.prototypes[p].triangles.positions)
      if (finite(q)) prototype_boxes[p].extendBy(q);
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const Instance& inst = scene.instances[k];
    const Box3f& b = prototype_boxes[inst.prototype];
    if (b.isEmpty()) continue;
    V3f corners[8];
    bool ok = true;
    for (int c = 0; c < 8; ++c) {
      const V3f p((c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y, (c & 4) ? b.max.z : b.min.z);
      inst.local_to_world.multVecMatrix(p, corners[c]);
      ok = ok && finite(corners[c]);
    }
    if (!ok) continue;
    const Verdict v = judge(incoming, local, corners, 8, largest_side);
    if (!v.drop) continue;
    keep_instance[k] = 0;
    ++dropped.instances;
    instance_losses.record(scene.prototypes[inst.prototype].prim_path, v);
  }

  // 3. Remove them, and say so per prim.
  if (dropped.triangles > 0) compact_soup(t, keep);
  if (dropped.instances > 0) compact_instances(scene, keep_instance);
  triangle_losses.warn(scene, "triangles");
  instance_losses.warn(scene, "instances");
  return dropped;
}

}  // namespace pbgi
