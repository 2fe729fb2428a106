// Opens the OpenVDB grids a scene names (UsdVol.Volume fields, or a .vdb
// file given directly as the scene) and turns them into what the pipeline
// reads:
//
// - level sets (GRID_LEVEL_SET) -> triangles appended to Scene::triangles
//   (mesh path = the volume prim, the volume's material; see
//   level_set_mesh.h for density, normals and winding);
// - fog/density and other float grids -> kept in Scene::volumes with the
//   grid, its world voxel size and bounds; opening the scene makes them a
//   participating medium and volume points (server/engine/scene_fog.h,
//   fog_field.h, fog_points.h).
//
// Each distinct .vdb file is opened once and its bytes hashed (xxh64) into
// Scene::content_hash together with the meshing options, so caches keyed by
// the hash follow the grids, not only the USD layers. A file or grid that
// cannot be read is a warning naming the prim and the file; the volume
// stays in Scene::volumes with grid == nullptr.
//
// Not thread-safe for one Scene; different Scenes may load concurrently.
#pragma once

#include "server/scene/asset_roots.h"
#include "server/scene/scene.h"

#include <filesystem>

namespace pbgi {

struct VolumeOptions {
  // World-space target edge length for level-set meshes (the surfel
  // spacing); 0 = the grid's own voxel size. See LevelSetMeshOptions.
  float target_edge_length = 0.f;
  double adaptivity = 0.0;  // volumeToMesh adaptivity, [0, 1]
  // A level set whose mesh would exceed this many triangles is skipped with
  // a warning (raise target_edge_length instead).
  uint64_t max_triangles_per_volume = 20'000'000;
  // false: level sets are opened and classified but not meshed, and the
  // content hash is left alone -- for scenes whose meshes were stored
  // already (server/ingest/chunk_store.h).
  bool mesh_level_sets = true;
  // Directories the .vdb files must lie below (default: anywhere).
  AssetRoots roots;
};

// Loads the grid of every entry of scene.volumes (as the reader sent them)
// and meshes the level sets. Throws InvalidArgument for bad options,
// PermissionDenied naming the volume and field (never the file) if a file
// lies outside options.roots -- every file is checked before any is read.
void load_scene_volumes(Scene& scene, const VolumeOptions& options = {});

// A .vdb file given directly: one volume per float grid, named
// "/<grid name>" (non-identifier characters replaced by '_'), identity
// transform, one grey diffuse material. Throws SceneError naming the file
// if it cannot be opened or holds no float grid, PermissionDenied if it
// lies outside options.roots.
Scene read_vdb_scene(const std::filesystem::path& path, const VolumeOptions& options = {});

}  // namespace pbgi
