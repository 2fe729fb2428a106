#include "server/scene/scene.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace pbgi {
namespace {

bool finite(const V3f& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

template <typename T>
size_t capacity_bytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

size_t soup_bytes(const TriangleSoup& t) {
  size_t n = capacity_bytes(t.positions) + capacity_bytes(t.normals) + capacity_bytes(t.indices) +
             capacity_bytes(t.material) + capacity_bytes(t.mesh) + capacity_bytes(t.double_sided) +
             capacity_bytes(t.uvs) + capacity_bytes(t.colors) + capacity_bytes(t.mesh_paths);
  for (const std::string& s : t.mesh_paths) n += s.capacity();
  return n;
}

}  // namespace

V3f TriangleRef::position(int k) const {
  const V3f& p = soup->positions[corners()[k]];
  if (!instance) return p;
  V3f out;
  instance->local_to_world.multVecMatrix(p, out);
  return out;
}

V3f TriangleRef::normal(int k) const {
  const V3f& n = soup->normals[corners()[k]];
  if (!instance) return n;
  V3f out;
  instance->normal_to_world.multDirMatrix(n, out);
  return out;
}

const std::string& TriangleRef::mesh_path() const {
  static const std::string kUnknown = "<unknown mesh>";
  if (index >= soup->mesh.size() || soup->mesh[index] >= soup->mesh_paths.size()) return kUnknown;
  return soup->mesh_paths[soup->mesh[index]];
}

// Bounds of all vertex positions (also unreferenced ones: ingest only emits
// vertices its triangles use), instances' transformed vertex by vertex so
// the box is as tight as for the same scene flattened. Non-finite positions
// are left out so one bad vertex cannot turn every epsilon derived from the
// bounds into NaN.
Box3f Scene::bounds() const {
  Box3f box;  // empty
  for (const V3f& p : triangles.positions) {
    if (finite(p)) box.extendBy(p);
  }
  for (const Instance& inst : instances) {
    for (const V3f& p : prototypes[inst.prototype].triangles.positions) {
      V3f w;
      inst.local_to_world.multVecMatrix(p, w);
      if (finite(w)) box.extendBy(w);
    }
  }
  return box;
}

const Camera* Scene::find_camera(const std::string& path) const {
  const auto it = cameras.find(path);
  return it == cameras.end() ? nullptr : &it->second;
}

TriangleRef Scene::triangle(uint32_t id) const {
  const size_t world = triangles.triangle_count();
  if (id < world) return TriangleRef{&triangles, id, nullptr};
  const uint64_t local = uint64_t(id) - world;
  // The last instance whose first triangle is <= local.
  const auto it = std::upper_bound(instances.begin(), instances.end(), local,
                                   [](uint64_t v, const Instance& i) { return v < i.first_triangle; });
  const Instance& inst = *(it - 1);
  return TriangleRef{&prototypes[inst.prototype].triangles, uint32_t(local - inst.first_triangle), &inst};
}

uint32_t Scene::mesh_ordinal(uint32_t id) const {
  const TriangleRef r = triangle(id);
  const uint32_t mesh = r.soup->mesh.empty() ? 0 : r.soup->mesh[r.index];
  if (!r.instance) return mesh;
  return uint32_t(triangles.mesh_paths.size()) + r.instance->first_mesh + mesh;
}

void Scene::add_instance(uint32_t prototype, const M44f& local_to_world) {
  if (prototype >= prototypes.size()) {
    throw SceneError(fmt::format("{}: instance of prototype {} but there are {} prototypes", source_path,
                                 prototype, prototypes.size()));
  }
  const TriangleSoup& t = prototypes[prototype].triangles;
  Instance inst;
  inst.prototype = prototype;
  inst.local_to_world = local_to_world;
  const float det = local_to_world.determinant();
  if (!(std::fabs(det) > 0.f) || !std::isfinite(det)) {
    throw SceneError(fmt::format("{}: instance {} of {} has a singular or non-finite transform", source_path,
                                 instances.size(), prototypes[prototype].prim_path));
  }
  inst.normal_to_world = local_to_world.inverse().transposed();
  inst.mirrored = det < 0.f;
  inst.first_triangle = instanced_triangle_count;
  inst.first_mesh = instanced_mesh_count;
  instanced_triangle_count += t.triangle_count();
  instanced_mesh_count += uint32_t(std::max<size_t>(t.mesh_paths.size(), 1));
  instances.push_back(inst);
}

size_t Scene::geometry_bytes() const {
  size_t n = soup_bytes(triangles) + capacity_bytes(prototypes) + capacity_bytes(instances);
  for (const Prototype& p : prototypes) n += soup_bytes(p.triangles) + p.prim_path.capacity();
  return n;
}

}  // namespace pbgi
