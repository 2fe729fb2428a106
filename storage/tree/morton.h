// Morton (Z-order) codes of positions: 21 bits per axis interleaved into 63
// bits, over a cube that encloses the scene. Sorting surfels by code puts
// surfels that are close in space close in the sequence, which is what lets
// the tree be built from a sorted stream (streaming_tree_builder.h).
//
// The cube (not the box) is used so that every cell is a cube: the binary
// radix tree over the codes then splits space in halves of equal extent,
// and an axis along which the scene is thin is simply not split early.
// Positions outside the cube are clamped: they still sort, only less well.
//
// Thread-safety: MortonFrame is an immutable value.
#pragma once

#include <Imath/ImathBox.h>
#include <Imath/ImathVec.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pbgi::tree {

inline constexpr int kMortonBitsPerAxis = 21;

// Spreads the low 21 bits of v so that bit i lands at bit 3i.
inline uint64_t spread_bits_3(uint64_t v) {
  v &= 0x1fffffull;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

class MortonFrame {
 public:
  MortonFrame() = default;
  // The cube of side max(extent) at bounds.min. An empty or degenerate box
  // gives a frame where every position has code 0 (still a valid order).
  explicit MortonFrame(const Imath::Box3f& bounds) {
    if (bounds.isEmpty()) return;
    origin_ = Imath::V3d(bounds.min.x, bounds.min.y, bounds.min.z);
    const Imath::V3f e = bounds.size();
    const double side = std::max({double(e.x), double(e.y), double(e.z)});
    if (side > 0 && std::isfinite(side)) scale_ = double(1u << kMortonBitsPerAxis) / side;
  }

  uint64_t code(const Imath::V3f& p) const {
    constexpr double kMaxCell = double((1u << kMortonBitsPerAxis) - 1);
    auto cell = [&](float x, double o) -> uint64_t {
      const double c = (double(x) - o) * scale_;
      if (!(c > 0.0)) return 0;  // also NaN
      return uint64_t(std::min(c, kMaxCell));
    };
    return spread_bits_3(cell(p.x, origin_.x)) | spread_bits_3(cell(p.y, origin_.y)) << 1 |
           spread_bits_3(cell(p.z, origin_.z)) << 2;
  }

 private:
  Imath::V3d origin_{0, 0, 0};
  double scale_ = 0;  // cells per unit
};

}  // namespace pbgi::tree
