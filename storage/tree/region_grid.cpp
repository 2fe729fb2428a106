#include "storage/tree/region_grid.h"

#include "common/errors.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace pbgi::tree {

namespace {

uint64_t rows_of(const Imath::V3i& d) { return uint64_t(d.y) * uint64_t(d.z); }

void check_dims(const Imath::V3f& origin, float voxel, const Imath::V3i& dims) {
  if (!(voxel > 0.f) || !std::isfinite(voxel) || !std::isfinite(origin.x) || !std::isfinite(origin.y) ||
      !std::isfinite(origin.z)) {
    throw InvalidArgument("region grid: voxel size " + std::to_string(voxel) + " or origin is not finite and positive");
  }
  constexpr int kMaxSide = kMaxRegionGridSide;
  if (dims.x < 1 || dims.y < 1 || dims.z < 1 || dims.x > kMaxSide || dims.y > kMaxSide || dims.z > kMaxSide) {
    throw InvalidArgument("region grid: " + std::to_string(dims.x) + " x " + std::to_string(dims.y) + " x " +
                          std::to_string(dims.z) + " voxels (each side must be in [1, " + std::to_string(kMaxSide) +
                          "])");
  }
}

}  // namespace

void RegionGrid::add_row(std::span<const RegionRun> runs) {
  if (!rows_.empty()) {
    const Row prev = rows_.back();
    if (std::equal(runs.begin(), runs.end(), runs_.begin() + prev.begin, runs_.begin() + prev.end)) {
      rows_.push_back(prev);
      return;
    }
  }
  const auto begin = uint32_t(runs_.size());
  runs_.insert(runs_.end(), runs.begin(), runs.end());
  rows_.push_back({begin, uint32_t(runs_.size())});
}

RegionGrid RegionGrid::from_dense(const Imath::V3f& origin, float voxel, const Imath::V3i& dims,
                                  const std::vector<uint32_t>& labels) {
  check_dims(origin, voxel, dims);
  if (labels.size() != rows_of(dims) * uint64_t(dims.x)) {
    throw InvalidArgument("region grid: " + std::to_string(labels.size()) + " labels for " +
                          std::to_string(rows_of(dims) * uint64_t(dims.x)) + " voxels");
  }
  RegionGrid g;
  g.origin_ = origin;
  g.voxel_ = voxel;
  g.dims_ = dims;
  g.rows_.reserve(rows_of(dims));
  std::vector<RegionRun> row;
  for (uint64_t r = 0; r < rows_of(dims); ++r) {
    row.clear();
    const uint32_t* l = labels.data() + r * uint64_t(dims.x);
    for (uint32_t x = 0; x < uint32_t(dims.x); ++x) {
      g.region_count_ = std::max(g.region_count_, l[x]);
      if (x + 1 == uint32_t(dims.x) || l[x + 1] != l[x]) row.push_back({x + 1, l[x]});
    }
    g.add_row(row);
  }
  return g;
}

RegionGrid RegionGrid::with_no_rows(const Imath::V3f& origin, float voxel, const Imath::V3i& dims,
                                    uint32_t region_count) {
  check_dims(origin, voxel, dims);
  RegionGrid g;
  g.origin_ = origin;
  g.voxel_ = voxel;
  g.dims_ = dims;
  g.region_count_ = region_count;
  return g;
}

void RegionGrid::append_row(std::span<const RegionRun> runs) {
  if (rows_.size() == rows_of(dims_)) {
    throw InvalidArgument("region grid: a row past the last of " + std::to_string(rows_of(dims_)));
  }
  uint32_t prev_end = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    const RegionRun& r = runs[i];
    if (r.end_x <= prev_end || r.end_x > uint32_t(dims_.x) || r.label > region_count_) {
      throw InvalidArgument("region grid: row " + std::to_string(rows_.size()) + ", run " + std::to_string(i) +
                            " (end " + std::to_string(r.end_x) + ", label " + std::to_string(r.label) +
                            ") does not follow the previous run (end " + std::to_string(prev_end) + ") within " +
                            std::to_string(dims_.x) + " voxels and " + std::to_string(region_count_) + " regions");
    }
    prev_end = r.end_x;
  }
  if (prev_end != uint32_t(dims_.x)) {
    throw InvalidArgument("region grid: row " + std::to_string(rows_.size()) + " ends at voxel " +
                          std::to_string(prev_end) + " of " + std::to_string(dims_.x));
  }
  add_row(runs);
}

void RegionGrid::repeat_row() {
  if (rows_.empty() || rows_.size() == rows_of(dims_)) {
    throw InvalidArgument("region grid: a repeated row " + std::to_string(rows_.size()) +
                          " with no row before it or past the last");
  }
  rows_.push_back(rows_.back());
}

void RegionGrid::check_complete() const {
  if (rows_.size() != rows_of(dims_)) {
    throw InvalidArgument("region grid: " + std::to_string(rows_.size()) + " of " + std::to_string(rows_of(dims_)) +
                          " rows");
  }
}

bool RegionGrid::operator==(const RegionGrid& o) const {
  if (origin_ != o.origin_ || voxel_ != o.voxel_ || dims_ != o.dims_ || region_count_ != o.region_count_ ||
      rows_.size() != o.rows_.size()) {
    return false;
  }
  for (uint64_t r = 0; r < rows_.size(); ++r) {
    const std::span<const RegionRun> a = row(r), b = o.row(r);
    if (!std::equal(a.begin(), a.end(), b.begin(), b.end())) return false;
  }
  return true;
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
  const Row& r = rows_[uint64_t(v.y) + uint64_t(dims_.y) * uint64_t(v.z)];
  const auto first = runs_.begin() + r.begin, last = runs_.begin() + r.end;
  const auto it =
      std::upper_bound(first, last, uint32_t(v.x), [](uint32_t x, const RegionRun& r) { return x < r.end_x; });
  return it == last ? kSolidVoxel : it->label;
}

}  // namespace pbgi::tree
