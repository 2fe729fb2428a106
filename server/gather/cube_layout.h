// Geometry of the cube microbuffer: six faces of N x N pixels around the
// receiver, with each pixel's unit direction and exact solid angle.
//
// Face f looks along axis f/2 with sign (f odd ? -1 : +1). On a face, a
// direction d maps to plane coordinates (u, v) in [-1, 1]^2 by
//   w = d . axis_w,  u = (d . axis_u) / w,  v = (d . axis_v) / w,
// with axis_u = e[(k+1)%3], axis_v = e[(k+2)%3] for k = f/2. Pixel (i, j)
// of face f spans u in [-1 + 2i/N, -1 + 2(i+1)/N] (same for v, j) and has
// linear index (f*N + j)*N + i.
//
// Thread-safety: immutable after construction.
#pragma once

#include <Imath/ImathVec.h>

#include <cstdint>
#include <vector>

namespace pbgi::gather {

// An inclusive rectangle of pixels on one face.
struct PixelRect {
  uint32_t i0 = 0, i1 = 0, j0 = 0, j1 = 0;
};

class CubeLayout {
 public:
  static constexpr int kFaces = 6;
  // 32 for the diffuse microbuffer; the glossy refinement goes to 64.
  static constexpr uint32_t kMaxResolution = 64;

  explicit CubeLayout(uint32_t resolution);
  // The shared layout of a resolution in [4, 64], built once per process
  // (thread-safe). Throws InvalidArgument outside that range.
  static const CubeLayout& get(uint32_t resolution);

  uint32_t resolution() const { return n_; }
  uint32_t pixel_count() const { return 6 * n_ * n_; }
  // Width of one pixel in face-plane units (2/N).
  float pixel_width() const { return pixel_width_; }
  uint32_t index(int face, uint32_t i, uint32_t j) const { return (face * n_ + j) * n_ + i; }

  // Per-pixel unit direction, as three arrays (vectorizable dot products).
  const float* dir_x() const { return dx_.data(); }
  const float* dir_y() const { return dy_.data(); }
  const float* dir_z() const { return dz_.data(); }
  Imath::V3f direction(uint32_t k) const { return {dx_[k], dy_[k], dz_[k]}; }
  // Mean direction of each pixel, (1/Omega) * integral of w over the pixel
  // (length slightly below 1): n . mean_dir * Omega is the pixel's exact
  // cosine-weighted solid angle for a normal n whose hemisphere holds it.
  const float* mean_dir_x() const { return mx_.data(); }
  const float* mean_dir_y() const { return my_.data(); }
  const float* mean_dir_z() const { return mz_.data(); }
  // A pixel lies wholly above the horizon of unit normal n when
  // n . mean_dir(k) > horizon_margin(k) (|mean_dir| times the sine of the
  // largest angle between the mean direction and a corner).
  const float* horizon_margins() const { return margin_.data(); }
  // Exact solid angle of each pixel (steradians); they sum to 4 pi.
  const float* solid_angles() const { return omega_.data(); }
  float solid_angle(uint32_t k) const { return omega_[k]; }
  // Mean solid angle of a pixel, 4 pi / (6 N^2).
  float mean_pixel_solid_angle() const { return mean_omega_; }

  // Face coordinates of direction d: w along the face axis, u and v across.
  static void face_coords(int face, const Imath::V3f& d, float& u, float& v, float& w) {
    const int k = face >> 1;
    const float s = (face & 1) ? -1.f : 1.f;
    w = s * d[k];
    u = d[(k + 1) % 3];
    v = d[(k + 2) % 3];
  }

  // The pixel a (non-zero) direction d falls in.
  uint32_t pixel_of(const Imath::V3f& d) const;

  // Solid angle of the face-plane rectangle [u0,u1] x [v0,v1] seen from the
  // cube center (exact: Manne's formula via the arctangent of corners).
  static double rect_solid_angle(double u0, double v0, double u1, double v1);

  // Pixels of `face` whose centers may lie inside the cone of unit `axis`
  // and half angle a (given as sin a, cos a). Returns false when the cone
  // misses the face. Conservative (may include pixels just outside).
  bool cone_pixels(int face, const Imath::V3f& axis, float sin_a, float cos_a,
                   PixelRect& rect) const;

 private:
  uint32_t n_;
  float pixel_width_;
  float mean_omega_;
  std::vector<float> dx_, dy_, dz_, mx_, my_, mz_, omega_, margin_;
};

}  // namespace pbgi::gather
