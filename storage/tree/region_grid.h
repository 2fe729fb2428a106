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
// row, a row equal to the one before it sharing its runs: rooms and the
// outside are large boxes of one label, walls repeat row after row.
//
// Thread-safety: an immutable value once built.
#pragma once

#include "storage/tree/node.h"

#include <Imath/ImathVec.h>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace pbgi::tree {

// The most voxels along a side a stored grid may have (the build's at most
// 256 and its padding, with room to raise it).
inline constexpr int kMaxRegionGridSide = 1032;

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
  // Row by row (the manifest reader: nothing is expanded, so memory is
  // bounded by what was read): a grid with no rows yet, then append_row()
  // or repeat_row() per row, then check_complete(). All throw
  // InvalidArgument for what does not tile the grid.
  static RegionGrid with_no_rows(const Imath::V3f& origin, float voxel, const Imath::V3i& dims, uint32_t region_count);
  void append_row(std::span<const RegionRun> runs);
  void repeat_row();
  void check_complete() const;

  bool empty() const { return rows_.empty(); }
  const Imath::V3f& origin() const { return origin_; }
  float voxel() const { return voxel_; }
  const Imath::V3i& dims() const { return dims_; }
  uint32_t region_count() const { return region_count_; }
  uint64_t row_count() const { return rows_.size(); }
  // The runs of row (y, z) = y + dims.y * z; a row equal to the one before
  // it shares its runs (same_as_previous()).
  std::span<const RegionRun> row(uint64_t r) const {
    return {runs_.data() + rows_[r].begin, size_t(rows_[r].end - rows_[r].begin)};
  }
  bool same_as_previous(uint64_t r) const { return r > 0 && rows_[r].begin == rows_[r - 1].begin; }
  size_t unique_runs() const { return runs_.size(); }

  // The voxel holding p, or nothing outside the grid.
  std::optional<Imath::V3i> voxel_of(const Imath::V3f& p) const;
  // The label of voxel v (inside the grid).
  uint32_t label(const Imath::V3i& v) const;
  Imath::V3f center(const Imath::V3i& v) const {
    return origin_ + voxel_ * Imath::V3f(float(v.x) + 0.5f, float(v.y) + 0.5f, float(v.z) + 0.5f);
  }
  size_t memory_bytes() const { return runs_.capacity() * sizeof(RegionRun) + rows_.capacity() * sizeof(Row); }
  bool operator==(const RegionGrid& o) const;

 private:
  struct Row {
    uint32_t begin = 0, end = 0;  // its runs in runs_
  };
  // Appends a row's runs, or shares the previous row's when equal.
  void add_row(std::span<const RegionRun> runs);

  Imath::V3f origin_{0, 0, 0};
  float voxel_ = 0.f;
  Imath::V3i dims_{0, 0, 0};
  uint32_t region_count_ = 0;
  std::vector<RegionRun> runs_;
  std::vector<Row> rows_;  // per (y, z) row
};

}  // namespace pbgi::tree
