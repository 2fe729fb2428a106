// Test fog: a Volume whose grid holds one density over a box of voxels,
// for slabs and cubes with known optical depths.
#pragma once

#include "server/scene/scene.h"
#include "server/volumes/volume_grid.h"

#include <openvdb/openvdb.h>

#include <memory>
#include <string>

namespace pbgi::test {

// Voxels `voxels` (index space; voxel k is centred at k x `voxel` in world)
// filled with `density`, active; bounds are the voxels' world bounds.
inline Volume constant_fog(const openvdb::CoordBBox& voxels, float voxel, float density,
                           const std::string& prim_path = "/Fog") {
  openvdb::initialize();
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.f);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
  grid->fill(voxels, density, true);
  Volume v;
  v.prim_path = prim_path;
  v.kind = VolumeKind::Fog;
  v.voxel_size = voxel;
  v.grid = std::make_shared<VolumeGrid>(grid);
  const openvdb::Coord& lo = voxels.min();
  const openvdb::Coord& hi = voxels.max();
  v.bounds = Box3f(V3f(float(lo.x()) - 0.5f, float(lo.y()) - 0.5f, float(lo.z()) - 0.5f) * voxel,
                   V3f(float(hi.x()) + 0.5f, float(hi.y()) + 0.5f, float(hi.z()) + 0.5f) * voxel);
  return v;
}

}  // namespace pbgi::test
