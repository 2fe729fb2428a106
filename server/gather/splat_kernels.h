// The per-splat arithmetic of the rasterizer (rasterizer.h) for a batch of
// splats at once, one splat per SIMD lane: the splat's ellipse on its home
// cube face and, when the tent's support lies inside that face, the tent's
// column and row masses and the solid angle they cover. What is left per
// splat (the fragments' insertion into the microbuffer, footprints that
// cross a face edge) stays scalar in the Rasterizer.
//
// The kernel is compiled for every x86-64 target Highway knows (SSSE3 to
// AVX-512, and a scalar fallback for any x86-64) and the best one the CPU
// supports is picked at run time. Results do not depend on the target:
// every lane runs the scalar formulas of the Rasterizer operation by
// operation, in the same order (IEEE +, -, *, /, sqrt are exactly rounded
// whatever the vector width; the file is compiled with -ffp-contract=off
// so that no target fuses a multiply-add; min and max are written as
// compare-and-select with std::min/std::max's semantics; nothing is summed
// across lanes). tests/server/gather/splat_kernels_test.cpp runs every
// compiled target and checks the outputs bit for bit.
//
// Thread-safety: a SplatBatch is one Rasterizer's scratch; the kernel
// itself has no state.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pbgi::gather {

// Up to kCapacity splats as arrays (structure of arrays: lane i of a SIMD
// vector is splat i), the kernel's inputs and outputs. Sized once; the
// Rasterizer fills it and flushes it when full.
struct SplatBatch {
  static constexpr size_t kCapacity = 64;
  // The tent's column (row) masses of a splat inside one face: at most
  // this many columns (rows); wider splats take the general path.
  static constexpr uint32_t kMaxSide = 8;

  size_t size = 0;
  // Inputs (Rasterizer::Shape and the unit direction of the splat).
  alignas(64) float dx[kCapacity], dy[kCapacity], dz[kCapacity];
  alignas(64) float omega[kCapacity], ratio[kCapacity], max_radius[kCapacity];
  alignas(64) float sx[kCapacity], sy[kCapacity], sz[kCapacity];  // squash direction
  // Outputs: the ellipse (Rasterizer::Ellipse) ...
  alignas(64) float major[kCapacity], minor[kCapacity];
  alignas(64) float u[kCapacity], v[kCapacity], hu[kCapacity], hv[kCapacity];
  alignas(64) int32_t home[kCapacity];
  // ... and, where inside[i] != 0 (the tent's support lies inside the home
  // face and spans at most kMaxSide columns and rows), the first column and
  // row i0, j0, the counts ni, nj, the masses mu[c][i] of columns i0 + c
  // (c < ni) and mv[r][i] of rows j0 + r (r < nj), and the solid angle they
  // cover, sum_r mv[r] sum_c mu[c] Omega(pixel), summed in row order.
  // inside, i0, j0, ni, nj and covered are zero where inside[i] == 0.
  alignas(64) int32_t inside[kCapacity];
  alignas(64) int32_t i0[kCapacity], j0[kCapacity], ni[kCapacity], nj[kCapacity];
  alignas(64) float mu[kMaxSide][kCapacity], mv[kMaxSide][kCapacity];
  alignas(64) float covered[kCapacity];
};

// The cube layout's constants the kernel needs (cube_layout.h).
struct SplatLayout {
  uint32_t resolution = 0;
  float pixel_width = 0.f;
  float inv_pixel_width = 0.f;
  const float* solid_angles = nullptr;  // per pixel
};

// Computes the outputs of batch[0, size) with the best target of this CPU
// (tests pick another with hwy::SetSupportedTargetsForTest).
void run_splat_kernel(const SplatLayout& layout, SplatBatch& batch);

}  // namespace pbgi::gather
