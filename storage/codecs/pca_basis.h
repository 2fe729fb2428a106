// Principal axes of a set of vectors, used to order a nearest-centre search
// (storage/codecs/nearest_centre.h): after rotating into this basis the
// coordinates come by decreasing variance, so the first one bounds
// distances best and partial distance sums grow fastest.
//
// The eigen-decomposition is a cyclic Jacobi sweep in double precision:
// deterministic (same input, same basis on every host), robust for the
// small symmetric matrices used here (dimension <= 64), and free of
// third-party code.
//
// Thread-safety: immutable after construction; rotate() is const.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace pbgi::storage {

class PcaBasis {
 public:
  // The identity basis around 0 (rotate() copies).
  explicit PcaBasis(size_t dims);
  // Mean and principal axes of `count` vectors of `dims` floats, stored
  // contiguously in `vectors`. Axes are sorted by decreasing variance;
  // each axis' sign is fixed (largest component positive) so the basis does
  // not depend on the eigen solver's sign choices.
  static PcaBasis fit(std::span<const float> vectors, size_t dims);

  size_t dims() const { return dims_; }
  // out = A (x - mean): the coordinates of x along the axes. L2 distances
  // are preserved (A is orthonormal) up to float rounding.
  void rotate(const float* x, float* out) const;
  // x = A^T y + mean.
  void unrotate(const float* y, float* out) const;
  // Variance along each axis, decreasing.
  const std::vector<double>& variances() const { return variances_; }

 private:
  size_t dims_;
  std::vector<float> mean_;
  std::vector<float> axes_;  // row k = axis k
  // axes_ transposed (column i = component i of every axis): rotate() sums
  // columns into the output lanes, a loop compilers vectorize without
  // reassociating float sums.
  std::vector<float> columns_;
  std::vector<double> variances_;
};

// Eigen-decomposition of a symmetric n x n matrix `a` (row-major, destroyed):
// eigenvalues in `values`, eigenvectors as the rows of `vectors`, unsorted.
void symmetric_eigen(std::vector<double>& a, size_t n, std::vector<double>& values,
                     std::vector<double>& vectors);

}  // namespace pbgi::storage
