// The OpenVDB grid behind a Scene::Volume (server/scene/scene.h holds it
// as an opaque shared_ptr<const VolumeGrid>, so that code which does not
// read grids needs no OpenVDB headers).
//
// Immutable once built; OpenVDB's const accessors are safe to use from
// several threads (each thread should make its own ConstAccessor/sampler).
#pragma once

#include <openvdb/openvdb.h>

namespace pbgi {

class VolumeGrid {
 public:
  explicit VolumeGrid(openvdb::FloatGrid::ConstPtr grid) : grid_(std::move(grid)) {}
  const openvdb::FloatGrid& grid() const { return *grid_; }
  openvdb::FloatGrid::ConstPtr shared_grid() const { return grid_; }

 private:
  openvdb::FloatGrid::ConstPtr grid_;
};

}  // namespace pbgi
