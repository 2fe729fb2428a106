#include "server/scene/render_origin.h"

#include "common/errors.h"
#include "server/scene/scene_bulk.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

V3f moved(const V3f& p, const V3d& shift) {
  return V3f(float(double(p.x) + shift.x), float(double(p.y) + shift.y),
             float(double(p.z) + shift.z));
}

// The translation row of a row-vector transform (p' = p * M).
void move_translation(M44f& m, const V3d& shift) {
  const V3f t = moved(V3f(m[3][0], m[3][1], m[3][2]), shift);
  m[3][0] = t.x;
  m[3][1] = t.y;
  m[3][2] = t.z;
}

// The origin for a scene at `current` whose bulk has bounds `b`.
V3d origin_for_bulk(const Box3f& b, const V3d& current) {
  if (b.isEmpty()) return V3d(0.0);
  const V3d lo(b.min.x, b.min.y, b.min.z), hi(b.max.x, b.max.y, b.max.z);
  const V3d centre = current + 0.5 * (lo + hi);
  const double side = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  if (!(side > 0.0)) return centre;
  const double q = std::ldexp(1.0, int(std::ceil(std::log2(side))) - 4);
  return V3d(std::round(centre.x / q) * q, std::round(centre.y / q) * q,
             std::round(centre.z / q) * q);
}

}  // namespace

V3d render_origin_for(const Scene& scene) { return origin_for_bulk(scene_bulk(scene).bounds, scene.render_origin); }

void rebase_scene(Scene& scene, const V3d& origin) {
  const V3d shift = scene.render_origin - origin;
  if (shift == V3d(0.0)) return;
  for (V3f& p : scene.triangles.positions) p = moved(p, shift);
  // Instances move with their transforms; prototypes stay in their own space.
  for (Instance& i : scene.instances) move_translation(i.local_to_world, shift);
  for (Light& l : scene.lights) move_translation(l.local_to_world, shift);
  for (auto& [path, camera] : scene.cameras) move_translation(camera.local_to_world, shift);
  for (Volume& v : scene.volumes) {
    move_translation(v.local_to_world, shift);
    if (!v.bounds.isEmpty()) {
      v.bounds.min = moved(v.bounds.min, shift);
      v.bounds.max = moved(v.bounds.max, shift);
    }
  }
  scene.render_origin = origin;
}

LocalFrame rebase_to_local_frame(Scene& scene) {
  const SceneBulk bulk = scene_bulk(scene);
  LocalFrame frame;
  frame.origin = origin_for_bulk(bulk.bounds, scene.render_origin);
  frame.outliers = bulk.has_outliers();
  frame.dropped = drop_unrepresentable_geometry(scene, frame.origin, bulk.bounds);
  if (frame.dropped.any() && scene.triangle_count() == 0) {
    throw SceneError(fmt::format("{}: every triangle was dropped for float precision ({})", scene.source_path,
                                 scene.warnings.empty() ? std::string() : scene.warnings.back()));
  }
  rebase_scene(scene, frame.origin);
  return frame;
}

}  // namespace pbgi
