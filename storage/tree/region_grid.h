// Air regions: the connected parts of a scene's empty space, on a voxel
// grid (docs/gather.md, section 11). A surfel emits into the empty space
// its front faces, so light from it reaches only receivers in that same
// region: a closed room's inner walls face its own region, the sunlit
// ground outside faces another, and no path joins them. The tree keeps
// each region's surfels in a subtree of its own (streaming_tree_builder.h)
// and a receiver walks only its region's subtree, so no node ever mixes
// the lit outside of a thin wall with the dark inside.
//
// The grid is computed from the scene's opaque triangles by the server
// (server/scene/air_regions.h) and stored with the page set (the manifest,
// storage/format/FORMAT.md), so that the regions a receiver is looked up in
// are the ones the tree was built with. Stored as runs along x per (y, z)
// row: rooms and the outside are large boxes of one label.
//
// Thread-safety: an immutable value once built.
#pragma once

#include "storage/tree/node.h"

#include <Imath/ImathVec.h>

#include <cstdint>
#include <optional>
#include <vector>

namespace pbgi::tree {

// Label 0: solid (a surface passes through the voxel); 1..count: regions.
inline constexpr uint32_t kSolidVoxel = 0;
// A surfel's or receiver's region when none is known: the whole tree.
inline constexpr uint32_t kAnyRegion = 0;

struct RegionRun {
  uint32_t end_x = 0;  // one past the run's last voxel along x
  uint32_t label = 0;
  bool operator==(const RegionRun&) const = default;
};

class RegionGrid {
 public:
  RegionGrid() = default;
  // From labels of nx*ny*nz voxels, x fastest. `voxel` > 0.
  static RegionGrid from_dense(const Imath::V3f& origin, float voxel, const Imath::V3i& dims,
                               const std::vector<uint32_t>& labels);
  // From stored runs (the manifest): row by row, each row's runs ending at
  // dims.x. Throws InvalidArgument if they do not tile the grid or name a
  // label above `region_count`.
  static RegionGrid from_runs(const Imath::V3f& origin, float voxel, const Imath::V3i& dims, uint32_t region_count,
                              std::vector<RegionRun> runs);

  bool empty() const { return runs_.empty(); }
  const Imath::V3f& origin() const { return origin_; }
  float voxel() const { return voxel_; }
  const Imath::V3i& dims() const { return dims_; }
  uint32_t region_count() const { return region_count_; }
  const std::vector<RegionRun>& runs() const { return runs_; }

  // The voxel holding p, or nothing outside the grid.
  std::optional<Imath::V3i> voxel_of(const Imath::V3f& p) const;
  // The label of voxel v (inside the grid).
  uint32_t label(const Imath::V3i& v) const;
  Imath::V3f center(const Imath::V3i& v) const {
    return origin_ + voxel_ * Imath::V3f(float(v.x) + 0.5f, float(v.y) + 0.5f, float(v.z) + 0.5f);
  }
  size_t memory_bytes() const {
    return runs_.capacity() * sizeof(RegionRun) + row_begin_.capacity() * sizeof(uint32_t);
  }
  bool operator==(const RegionGrid& o) const {
    return origin_ == o.origin_ && voxel_ == o.voxel_ && dims_ == o.dims_ && region_count_ == o.region_count_ &&
           runs_ == o.runs_;
  }

 private:
  Imath::V3f origin_{0, 0, 0};
  float voxel_ = 0.f;
  Imath::V3i dims_{0, 0, 0};
  uint32_t region_count_ = 0;
  std::vector<RegionRun> runs_;
  std::vector<uint32_t> row_begin_;  // per (y, z) row, its first run; one more at the end
};

}  // namespace pbgi::tree
