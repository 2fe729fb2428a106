// The 2D Haar wavelet transform of one square image, orthonormal, in the
// nonstandard decomposition (Stollnitz, DeRose & Salesin, "Wavelets for
// Computer Graphics: A Primer", 1995): one averaging/differencing step on
// all rows, then on all columns, then recurse on the low-pass quadrant.
//
// In-place layout after the transform of an n x n image (row-major, n a
// power of two): element (0, 0) is the overall average times n; for each
// level with block size k = 2s (k = n, n/2, ..., 2) the quadrants of the
// top-left k x k block are
//   (i, s + j)       detail along x, average along y
//   (s + i, j)       average along x, detail along y
//   (s + i, s + j)   detail along both
// for i, j < s. Each step maps (a, b) -> ((a + b)/sqrt2, (a - b)/sqrt2), so
// the transform is orthonormal: the L2 norm of any set of coefficients is
// the L2 norm of the image it contributes (what the tree coding's
// thresholds rely on).
//
// Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <span>

namespace pbgi::storage {

// True for 1, 2, 4, ...
inline bool is_power_of_two(uint32_t n) { return n != 0 && (n & (n - 1)) == 0; }

// In place; image.size() must be n * n, n a power of two (InvalidArgument).
void haar2d_forward(std::span<float> image, uint32_t n);
void haar2d_inverse(std::span<float> coeffs, uint32_t n);
// Pixel (x, y) of the image from its coefficients in O(log n), without
// reconstructing the rest: the on-demand point evaluation of the paper.
float haar2d_point(std::span<const float> coeffs, uint32_t n, uint32_t x, uint32_t y);

}  // namespace pbgi::storage
