// The payload of a node (see node.h): area and area-averaged SH of the
// clamped-cosine-weighted radiance and coverage of the surfels below it.
// Adding surfels or adding child nodes gives the same result (up to
// rounding), because a child's payload is itself an area-weighted average:
//   P(parent) = sum_c A_c P(c) / sum_c A_c.
// Sums run in double so that the order of accumulation does not matter to
// float precision.
#pragma once

#include "storage/sh/sh.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <array>

namespace pbgi::tree {

class PayloadAccumulator {
 public:
  void add_surfel(const Surfel& s);
  void add_node(const Node& n);
  // Writes area, radiance_sh and coverage_sh of `n`. Zero total area gives a
  // zero payload (such a node emits and covers nothing).
  void store(Node& n) const;
  double area() const { return area_; }

 private:
  // radiance r, g, b then coverage; each sh::kCoeffs wide.
  static constexpr int kWidth = 4 * sh::kCoeffs;
  void add(double weight, const float* values);

  double area_ = 0;
  std::array<double, kWidth> sum_{};
};

}  // namespace pbgi::tree
