#include "server/scene/scene_validation.h"

#include "storage/format/errors.h"

#include <fmt/format.h>

namespace pbgi {

const std::string& mesh_path_of(const Scene& scene, uint32_t tri) {
  static const std::string kUnknown = "<unknown mesh>";
  const TriangleSoup& t = scene.triangles;
  if (tri >= t.mesh.size() || t.mesh[tri] >= t.mesh_paths.size()) return kUnknown;
  return t.mesh_paths[t.mesh[tri]];
}

void validate_scene(const Scene& scene) {
  const TriangleSoup& t = scene.triangles;
  const std::string& file = scene.source_path;
  if (t.indices.size() % 3 != 0) {
    throw SceneError(fmt::format("{}: {} triangle indices is not a multiple of 3", file,
                                 t.indices.size()));
  }
  const size_t tris = t.triangle_count();
  if (!t.normals.empty() && t.normals.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} normals for {} vertices", file, t.normals.size(),
                                 t.positions.size()));
  }
  if (!t.uvs.empty() && t.uvs.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} uvs for {} vertices", file, t.uvs.size(), t.positions.size()));
  }
  if (!t.colors.empty() && t.colors.size() != t.positions.size()) {
    throw SceneError(fmt::format("{}: {} vertex colors for {} vertices", file, t.colors.size(),
                                 t.positions.size()));
  }
  if (t.material.size() != tris) {
    throw SceneError(fmt::format("{}: {} material ids for {} triangles", file, t.material.size(),
                                 tris));
  }
  if (!t.mesh.empty() && t.mesh.size() != tris) {
    throw SceneError(fmt::format("{}: {} mesh ids for {} triangles", file, t.mesh.size(), tris));
  }
  if (!t.double_sided.empty() && t.double_sided.size() != t.mesh_paths.size()) {
    throw SceneError(fmt::format("{}: {} double-sided flags for {} meshes", file,
                                 t.double_sided.size(), t.mesh_paths.size()));
  }
  for (size_t i = 0; i < tris; ++i) {
    if (!t.mesh.empty() && t.mesh[i] >= t.mesh_paths.size()) {
      throw SceneError(fmt::format("{}: triangle {} has mesh id {} but there are {} meshes", file,
                                   i, t.mesh[i], t.mesh_paths.size()));
    }
    for (int k = 0; k < 3; ++k) {
      if (t.indices[3 * i + k] >= t.positions.size()) {
        throw SceneError(fmt::format("{}: {}: triangle {} uses vertex {} but there are {} vertices",
                                     file, mesh_path_of(scene, static_cast<uint32_t>(i)), i,
                                     t.indices[3 * i + k], t.positions.size()));
      }
    }
    if (t.material[i] >= scene.materials.size()) {
      throw SceneError(fmt::format("{}: {}: triangle {} uses material {} but there are {} materials",
                                   file, mesh_path_of(scene, static_cast<uint32_t>(i)), i,
                                   t.material[i], scene.materials.size()));
    }
  }
}

}  // namespace pbgi
