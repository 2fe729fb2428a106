// The air-region grid (storage/tree/region_grid.h): runs along x that
// answer the dense labels they were made from, and stored runs that do not
// tile the grid refused.
#include "storage/tree/region_grid.h"
#include "common/errors.h"

#include <gtest/gtest.h>

#include <random>

namespace pbgi::tree {
namespace {

// A grid from runs given row by row, each row ending at dims.x, as the
// manifest reader appends them.
RegionGrid from_runs(const Imath::V3f& origin, float voxel, const Imath::V3i& dims, uint32_t region_count,
                     const std::vector<RegionRun>& runs) {
  RegionGrid g = RegionGrid::with_no_rows(origin, voxel, dims, region_count);
  size_t row_start = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    if (runs[i].end_x >= uint32_t(dims.x) || i + 1 == runs.size()) {
      g.append_row({runs.data() + row_start, i + 1 - row_start});
      row_start = i + 1;
    }
  }
  g.check_complete();
  return g;
}

TEST(RegionGrid, RunsAnswerTheDenseLabels) {
  const Imath::V3i dims(7, 5, 3);
  std::vector<uint32_t> labels(size_t(dims.x * dims.y * dims.z));
  std::mt19937 rng(3);
  for (uint32_t& l : labels) l = rng() % 4 == 0 ? kSolidVoxel : 1 + rng() % 3;
  const RegionGrid g = RegionGrid::from_dense({1, 2, 3}, 0.5f, dims, labels);
  EXPECT_LE(g.region_count(), 3u);
  for (int z = 0; z < dims.z; ++z) {
    for (int y = 0; y < dims.y; ++y) {
      for (int x = 0; x < dims.x; ++x) {
        EXPECT_EQ(g.label({x, y, z}), labels[size_t(x + dims.x * (y + dims.y * z))]) << x << " " << y << " " << z;
      }
    }
  }
  // The same runs, row by row, make the same grid.
  std::vector<RegionRun> runs;
  for (uint64_t r = 0; r < g.row_count(); ++r) runs.insert(runs.end(), g.row(r).begin(), g.row(r).end());
  EXPECT_EQ(from_runs(g.origin(), g.voxel(), dims, g.region_count(), runs), g);
}

TEST(RegionGrid, EqualRowsShareTheirRuns) {
  // Every row the same but the last: two rows' worth of runs are kept.
  const Imath::V3i dims(6, 4, 4);
  std::vector<uint32_t> labels(size_t(dims.x * dims.y * dims.z), 1);
  for (size_t r = 0; r < 16; ++r) labels[r * 6 + 2] = kSolidVoxel;
  labels[15 * 6 + 4] = 2;
  const RegionGrid g = RegionGrid::from_dense({0, 0, 0}, 1.f, dims, labels);
  EXPECT_EQ(g.unique_runs(), 3u + 5u);
  EXPECT_TRUE(g.same_as_previous(1));
  EXPECT_FALSE(g.same_as_previous(15));
  EXPECT_EQ(g.label({4, 3, 3}), 2u);
  EXPECT_EQ(g.label({4, 2, 3}), 1u);
  EXPECT_EQ(g.label({2, 0, 0}), kSolidVoxel);
  // Read back as a manifest stores it: repeated rows as repeats.
  RegionGrid read = RegionGrid::with_no_rows(g.origin(), g.voxel(), dims, g.region_count());
  for (uint64_t r = 0; r < g.row_count(); ++r) {
    if (g.same_as_previous(r)) {
      read.repeat_row();
    } else {
      read.append_row(g.row(r));
    }
  }
  read.check_complete();
  EXPECT_EQ(read, g);
  EXPECT_EQ(read.unique_runs(), g.unique_runs());
  EXPECT_THROW(read.repeat_row(), InvalidArgument);  // past the last row
}

TEST(RegionGrid, VoxelOfAPointInsideAndOutside) {
  const RegionGrid g = RegionGrid::from_dense({0, 0, 0}, 1.f, {2, 2, 2}, std::vector<uint32_t>(8, 1));
  EXPECT_EQ(g.voxel_of({1.5f, 0.5f, 0.2f}), Imath::V3i(1, 0, 0));
  EXPECT_EQ(g.center({1, 0, 0}), Imath::V3f(1.5f, 0.5f, 0.5f));
  EXPECT_FALSE(g.voxel_of({-0.1f, 0.5f, 0.5f}));
  EXPECT_FALSE(g.voxel_of({0.5f, 2.f, 0.5f}));
  EXPECT_FALSE(g.voxel_of({0.5f, std::nanf(""), 0.5f}));
  EXPECT_FALSE(RegionGrid().voxel_of({0, 0, 0}));
}

TEST(RegionGrid, StoredRunsThatDoNotTileTheGridAreRefused) {
  const Imath::V3i dims(4, 1, 2);  // two rows of 4
  const std::vector<RegionRun> good = {{4, 1}, {2, 1}, {4, 2}};
  EXPECT_NO_THROW(from_runs({0, 0, 0}, 1.f, dims, 2, good));
  // A row left short, one row missing, a run going back, a label above the count, too many rows.
  EXPECT_THROW(from_runs({0, 0, 0}, 1.f, dims, 2, {{4, 1}, {3, 1}}), InvalidArgument);
  EXPECT_THROW(from_runs({0, 0, 0}, 1.f, dims, 2, {{4, 1}}), InvalidArgument);
  EXPECT_THROW(from_runs({0, 0, 0}, 1.f, dims, 2, {{4, 1}, {2, 1}, {2, 2}, {4, 2}}), InvalidArgument);
  EXPECT_THROW(from_runs({0, 0, 0}, 1.f, dims, 1, good), InvalidArgument);
  EXPECT_THROW(from_runs({0, 0, 0}, 1.f, dims, 2, {{4, 1}, {4, 1}, {4, 1}}), InvalidArgument);
  EXPECT_THROW(from_runs({0, 0, 0}, 0.f, dims, 2, good), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::tree
