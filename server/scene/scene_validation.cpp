#include "server/scene/scene_validation.h"

#include "common/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

namespace pbgi {
namespace {

std::string mesh_of(const TriangleSoup& t, size_t tri) {
  if (tri >= t.mesh.size() || t.mesh[tri] >= t.mesh_paths.size()) return "<unknown mesh>";
  return t.mesh_paths[t.mesh[tri]];
}

// `what` names the soup in errors: the scene file, or the file and the
// prototype prim.
void validate_soup(const TriangleSoup& t, size_t material_count, const std::string& what) {
  if (t.indices.size() % 3 != 0) {
    throw SceneError(fmt::format("{}: {} triangle indices is not a multiple of 3", what, t.indices.size()));
  }
  const size_t tris = t.triangle_count();
  if (!t.normals.empty() && t.normals.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} normals for {} vertices", what, t.normals.size(), t.positions.size()));
  }
  if (!t.uvs.empty() && t.uvs.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} uvs for {} vertices", what, t.uvs.size(), t.positions.size()));
  }
  if (!t.colors.empty() && t.colors.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} vertex colors for {} vertices", what, t.colors.size(), t.positions.size()));
  }
  if (t.material.size() != tris) {
    throw SceneError(fmt::format("{}: {} material ids for {} triangles", what, t.material.size(), tris));
  }
  if (!t.mesh.empty() && t.mesh.size() != tris) {
    throw SceneError(fmt::format("{}: {} mesh ids for {} triangles", what, t.mesh.size(), tris));
  }
  if (!t.double_sided.empty() && t.double_sided.size() != t.mesh_paths.size()) {
    throw SceneError(fmt::format("{}: {} double-sided flags for {} meshes", what, t.double_sided.size(),
                                 t.mesh_paths.size()));
  }
  for (size_t i = 0; i < tris; ++i) {
    if (!t.mesh.empty() && t.mesh[i] >= t.mesh_paths.size()) {
      throw SceneError(fmt::format("{}: triangle {} has mesh id {} but there are {} meshes", what, i, t.mesh[i],
                                   t.mesh_paths.size()));
    }
    for (int k = 0; k < 3; ++k) {
      if (t.indices[3 * i + k] >= t.positions.size()) {
        throw SceneError(fmt::format("{}: {}: triangle {} uses vertex {} but there are {} vertices", what,
                                     mesh_of(t, i), i, t.indices[3 * i + k], t.positions.size()));
      }
    }
    if (t.material[i] >= material_count) {
      throw SceneError(fmt::format("{}: {}: triangle {} uses material {} but there are {} materials", what,
                                   mesh_of(t, i), i, t.material[i], material_count));
    }
  }
}

}  // namespace

const std::string& mesh_path_of(const Scene& scene, uint32_t tri) {
  static const std::string kUnknown = "<unknown mesh>";
  if (tri >= scene.triangle_count()) return kUnknown;
  return scene.triangle(tri).mesh_path();
}

void validate_scene(const Scene& scene) {
  const std::string& file = scene.source_path;
  validate_soup(scene.triangles, scene.materials.size(), file);
  for (const Prototype& p : scene.prototypes)
    validate_soup(p.triangles, scene.materials.size(), fmt::format("{}: prototype {}", file, p.prim_path));
  // The instance numbering add_instance() froze must still match the
  // prototypes (a prototype grown after its instances were added would
  // shift every later triangle id).
  uint64_t first = 0;
  uint32_t first_mesh = 0;
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const Instance& inst = scene.instances[k];
    if (inst.prototype >= scene.prototypes.size()) {
      throw SceneError(fmt::format("{}: instance {} uses prototype {} but there are {}", file, k, inst.prototype,
                                   scene.prototypes.size()));
    }
    const TriangleSoup& t = scene.prototypes[inst.prototype].triangles;
    if (inst.first_triangle != first || inst.first_mesh != first_mesh) {
      throw SceneError(fmt::format("{}: instance {} of {} is numbered from triangle {}, expected {} (prototype "
                                   "changed after its instances were added)",
                                   file, k, scene.prototypes[inst.prototype].prim_path, inst.first_triangle, first));
    }
    first += t.triangle_count();
    first_mesh += uint32_t(std::max<size_t>(t.mesh_paths.size(), 1));
  }
  if (first != scene.instanced_triangle_count || first_mesh != scene.instanced_mesh_count) {
    throw SceneError(fmt::format("{}: {} instanced triangles counted, {} found", file,
                                 scene.instanced_triangle_count, first));
  }
  // Triangle ids are 32-bit (Hit, surfel plans).
  if (scene.triangle_count() > std::numeric_limits<uint32_t>::max()) {
    throw SceneError(fmt::format("{}: {} triangles with instances expanded exceed the limit of 2^32 - 1", file,
                                 scene.triangle_count()));
  }
}

}  // namespace pbgi
