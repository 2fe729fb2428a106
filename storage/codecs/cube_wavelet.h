// Outgoing radiance of a glossy sender as a Haar-transformed cube map
// (Wang, Meng & Boubekeur, Wavelet PBGI, 2015, section 3.1): the radiance
// L(w) is sampled at the pixel centres of a cube map of 6 faces x n x n
// pixels (n = 8 .. 32, a power of two), RGB, and each face and channel is
// transformed by the 2D Haar transform (storage/codecs/haar_wavelet.h).
//
// Coefficient vector layout (CubeLayout::floats() = 18 n^2 floats):
//   face f (0..5 = +x, -x, +y, -y, +z, -z), channel c (r, g, b), then the
//   n x n coefficients of that image, row-major:
//   index = (f * 3 + c) * n^2 + y * n + x.
// A face occupies 3 n^2 consecutive floats, so faces are natural blocks
// for the tree coding's thresholding (wavelet_tree_coding.h).
//
// Face parameterization: for the major axis of w, (u, v) in [-1, 1] are
//   +x: (-z, -y)  -x: (z, -y)  +y: (x, z)  -y: (x, -z)  +z: (x, -y)  -z: (-x, -y)
// divided by |major|; pixel (x, y) covers u in [-1 + 2x/n, -1 + 2(x+1)/n].
//
// Linear: averaging the coefficient vectors of children averages their
// radiance functions, which is how tree nodes are formed.
// Thread-safety: pure functions.
#pragma once

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace pbgi::storage {

struct CubeLayout {
  static constexpr uint32_t kMinResolution = 8;
  static constexpr uint32_t kMaxResolution = 32;

  uint32_t n = 8;

  // Throws InvalidArgument unless n is a power of two in [8, 32].
  void validate() const;
  size_t image_floats() const { return size_t(n) * n; }
  size_t face_floats() const { return 3 * image_floats(); }
  size_t floats() const { return 6 * face_floats(); }
  size_t index(uint32_t face, uint32_t channel, uint32_t x, uint32_t y) const {
    return (size_t(face) * 3 + channel) * image_floats() + size_t(y) * n + x;
  }
  // Unit direction through the centre of pixel (x, y) of `face`.
  Imath::V3f direction(uint32_t face, uint32_t x, uint32_t y) const;
  // Face and pixel that direction `w` (any non-zero length) falls in.
  void pixel(const Imath::V3f& w, uint32_t& face, uint32_t& x, uint32_t& y) const;
  // Exact solid angle of pixel (x, y) (the same on every face; they sum
  // to 4 pi).
  float solid_angle(uint32_t x, uint32_t y) const;
};

// Samples L at every pixel centre (spatial domain, layout above).
std::vector<float> sample_cube(const CubeLayout& layout, const std::function<Imath::C3f(const Imath::V3f&)>& L);
// In place: Haar transform of every face and channel, and back.
void cube_forward(const CubeLayout& layout, std::span<float> values);
void cube_inverse(const CubeLayout& layout, std::span<float> coeffs);
// The radiance in direction w from the coefficients (pixel lookup, no
// interpolation), in O(log n) per channel.
Imath::C3f cube_evaluate(const CubeLayout& layout, std::span<const float> coeffs, const Imath::V3f& w);
// The same from one face's block (its 3 n^2 coefficients, r, g, b images)
// at pixel (x, y) of that face.
Imath::C3f face_evaluate(const CubeLayout& layout, const float* face_coeffs, uint32_t x, uint32_t y);

// A test and example sender: diffuse colour `kd` plus a normalized Phong
// lobe of colour `ks` around `mirror` whose width grows with `roughness`
// (exponent 2 / roughness^2 - 2), zero below the surface (n . w <= 0).
Imath::C3f glossy_radiance(const Imath::V3f& normal, const Imath::V3f& mirror, float roughness,
                           const Imath::C3f& kd, const Imath::C3f& ks, const Imath::V3f& w);

}  // namespace pbgi::storage
