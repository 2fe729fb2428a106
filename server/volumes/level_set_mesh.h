// A narrow-band level set (OpenVDB GRID_LEVEL_SET, negative inside) ->
// world-space triangles of its zero crossing.
//
// openvdb::tools::volumeToMesh extracts the isosurface at `isovalue`
// (quads are split along their shorter diagonal). When the caller's target
// spacing is coarser than twice the grid's voxel, the level set is first
// rebuilt at voxel = target / 2 (openvdb::tools::levelSetRebuild), so the
// mesh has the density the surfels need, not the grid's. Normals are the
// normalized gradient of the level set (central differences of trilinear
// samples, one voxel apart) at each vertex, mapped to world space by the
// inverse transpose of `to_world`; each triangle is wound counter-clockwise
// around them (outward for a level set).
//
// Vertices lie on the trilinear zero crossing of the grid: within a small
// fraction of a voxel of the surface the level set samples (the test
// checks half a voxel on a sphere).
//
// Thread-safe: reads the grid only.
#pragma once

#include "server/scene/scene.h"

#include <openvdb/openvdb.h>

#include <vector>

namespace pbgi {

struct LevelSetMeshOptions {
  double isovalue = 0.0;
  // volumeToMesh adaptivity in [0, 1]: 0 keeps every voxel's polygon, larger
  // values merge polygons in flat regions.
  double adaptivity = 0.0;
  // World-space target edge length (the surfel spacing); 0 = the grid's own
  // resolution. Coarser than two voxels -> rebuilt at target / 2 first.
  float target_edge_length = 0.f;
};

struct LevelSetMesh {
  std::vector<V3f> positions;      // world space
  std::vector<V3f> normals;        // unit, per vertex
  std::vector<uint32_t> indices;   // 3 per triangle
  float voxel_size = 0.f;          // world voxel of the grid that was meshed
  size_t triangle_count() const { return indices.size() / 3; }
};

// `to_world` maps the grid's world space to the scene (USD row vectors).
// Throws InvalidArgument for bad options.
LevelSetMesh mesh_level_set(const openvdb::FloatGrid& grid, const M44f& to_world,
                            const LevelSetMeshOptions& options = {});

// World-space length of the grid's largest voxel edge after `to_world`.
float world_voxel_size(const openvdb::GridBase& grid, const M44f& to_world);

}  // namespace pbgi
