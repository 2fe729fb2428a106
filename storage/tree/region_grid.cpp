#include "storage/tree/region_grid.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace pbgi::tree {

namespace {

uint64_t row_count(const Imath::V3i& d) { return uint64_t(d.y) * uint64_t(d.z); }

void check_dims(const Imath::V3f& origin, float voxel, const Imath::V3i& dims) {
  if (!(voxel > 0.f) || !std::isfinite(voxel) || !std::isfinite(origin.x) || !std::isfinite(origin.y) ||
      !std::isfinite(origin.z)) {
    throw InvalidArgument("region grid: voxel size " + std::to_string(voxel) + " or origin is not finite and positive");
  }
  constexpr int kMaxSide = 1 << 12;
  if (dims.x < 1 || dims.y < 1 || dims.z < 1 || dims.x > kMaxSide || dims.y > kMaxSide || dims.z > kMaxSide) {
    throw InvalidArgument("region grid: " + std::to_string(dims.x) + " x " + std::to_string(dims.y) + " x " +
                          std::to_string(dims.z) + " voxels (each side must be in [1, " + std::to_string(kMaxSide) +
                          "])");
  }
}

}  // namespace

RegionGrid RegionGrid::from_dense(const Imath::V3f& origin, float voxel, const Imath::V3i& dims,
                                  const std::vector<uint32_t>& labels) {
  check_dims(origin, voxel, dims);
  if (labels.size() != row_count(dims) * uint64_t(dims.x)) {
    throw InvalidArgument("region grid: " + std::to_string(labels.size()) + " labels for " +
                          std::to_string(row_count(dims) * uint64_t(dims.x)) + " voxels");
  }
  RegionGrid g;
  g.origin_ = origin;
  g.voxel_ = voxel;
  g.dims_ = dims;
  g.row_begin_.reserve(row_count(dims) + 1);
  for (uint64_t row = 0; row < row_count(dims); ++row) {
    g.row_begin_.push_back(uint32_t(g.runs_.size()));
    const uint32_t* l = labels.data() + row * uint64_t(dims.x);
    for (uint32_t x = 0; x < uint32_t(dims.x); ++x) {
      g.region_count_ = std::max(g.region_count_, l[x]);
      if (x + 1 == uint32_t(dims.x) || l[x + 1] != l[x]) g.runs_.push_back({x + 1, l[x]});
    }
  }
  g.row_begin_.push_back(uint32_t(g.runs_.size()));
  return g;
}

RegionGrid RegionGrid::from_runs(const Imath::V3f& origin, float voxel, const Imath::V3i& dims, uint32_t region_count,
                                 std::vector<RegionRun> runs) {
  check_dims(origin, voxel, dims);
  RegionGrid g;
  g.origin_ = origin;
  g.voxel_ = voxel;
  g.dims_ = dims;
  g.region_count_ = region_count;
  g.row_begin_.reserve(row_count(dims) + 1);
  auto prev_end = uint32_t(dims.x);  // a row starts after a run that ended at dims.x
  for (size_t i = 0; i < runs.size(); ++i) {
    const RegionRun& r = runs[i];
    if (prev_end == uint32_t(dims.x)) {
      if (g.row_begin_.size() == row_count(dims)) {
        throw InvalidArgument("region grid: run " + std::to_string(i) + " lies past the last of " +
                              std::to_string(row_count(dims)) + " rows");
      }
      g.row_begin_.push_back(uint32_t(i));
      prev_end = 0;
    }
    if (r.end_x <= prev_end || r.end_x > uint32_t(dims.x) || r.label > region_count) {
      throw InvalidArgument("region grid: run " + std::to_string(i) + " (end " + std::to_string(r.end_x) + ", label " +
                            std::to_string(r.label) + ") does not follow its row's previous run (end " +
                            std::to_string(prev_end) + ") within " + std::to_string(dims.x) + " voxels and " +
                            std::to_string(region_count) + " regions");
    }
    prev_end = r.end_x;
  }
  if (g.row_begin_.size() != row_count(dims) || prev_end != uint32_t(dims.x)) {
    throw InvalidArgument("region grid: the runs cover " + std::to_string(g.row_begin_.size()) + " of " +
                          std::to_string(row_count(dims)) + " rows");
  }
  g.runs_ = std::move(runs);
  g.row_begin_.push_back(uint32_t(g.runs_.size()));
  return g;
}

std::optional<Imath::V3i> RegionGrid::voxel_of(const Imath::V3f& p) const {
  if (empty()) return std::nullopt;
  const Imath::V3f c = (p - origin_) / voxel_;
  if (!(c.x >= 0.f && c.y >= 0.f && c.z >= 0.f)) return std::nullopt;  // also NaN
  const Imath::V3i v(int(c.x), int(c.y), int(c.z));
  if (v.x >= dims_.x || v.y >= dims_.y || v.z >= dims_.z) return std::nullopt;
  return v;
}

uint32_t RegionGrid::label(const Imath::V3i& v) const {
  const uint64_t row = uint64_t(v.y) + uint64_t(dims_.y) * uint64_t(v.z);
  const auto first = runs_.begin() + row_begin_[row], last = runs_.begin() + row_begin_[row + 1];
  const auto it =
      std::upper_bound(first, last, uint32_t(v.x), [](uint32_t x, const RegionRun& r) { return x < r.end_x; });
  return it == last ? kSolidVoxel : it->label;
}

}  // namespace pbgi::tree
