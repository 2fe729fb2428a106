#include "server/gather/cube_layout.h"

#include "common/errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>

namespace pbgi::gather {

namespace {
// Solid angle of the face-plane rectangle [0,x] x [0,y] (signed by x*y).
double corner_term(double x, double y) { return std::atan2(x * y, std::sqrt(x * x + y * y + 1.0)); }
// acos(1/sqrt(3)): the largest angle between a face axis and a direction
// that still projects onto that face (the face corners).
constexpr float kCosFaceCorner = 0.57735027f;  // 1/sqrt(3)
constexpr float kSinFaceCorner = 0.81649658f;  // sqrt(2/3)
}  // namespace

double CubeLayout::rect_solid_angle(double u0, double v0, double u1, double v1) {
  return corner_term(u1, v1) - corner_term(u0, v1) - corner_term(u1, v0) + corner_term(u0, v0);
}

uint32_t CubeLayout::pixel_of(const Imath::V3f& d) const {
  const float ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  const int k = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
  const int face = 2 * k + (d[k] < 0.f ? 1 : 0);
  float u, v, w;
  face_coords(face, d, u, v, w);
  const float last = float(n_ - 1);
  const uint32_t i = uint32_t(std::clamp(std::floor((u / w + 1.f) * 0.5f * float(n_)), 0.f, last));
  const uint32_t j = uint32_t(std::clamp(std::floor((v / w + 1.f) * 0.5f * float(n_)), 0.f, last));
  return index(face, i, j);
}

const CubeLayout& CubeLayout::get(uint32_t resolution) {
  constexpr uint32_t kMin = 4, kMax = kMaxResolution;
  if (resolution < kMin || resolution > kMax) {
    throw InvalidArgument("microbuffer resolution " + std::to_string(resolution) +
                          ": must be in [4, " + std::to_string(kMax) + "]");
  }
  static std::array<std::once_flag, kMax + 1> once;
  static std::array<std::unique_ptr<CubeLayout>, kMax + 1> layouts;
  std::call_once(once[resolution],
                 [resolution] { layouts[resolution] = std::make_unique<CubeLayout>(resolution); });
  return *layouts[resolution];
}

CubeLayout::CubeLayout(uint32_t resolution)
    : n_(resolution),
      pixel_width_(2.f / float(resolution)),
      mean_omega_(float(4.0 * M_PI / (6.0 * resolution * resolution))) {
  const uint32_t count = pixel_count();
  dx_.resize(count);
  dy_.resize(count);
  dz_.resize(count);
  mx_.resize(count);
  my_.resize(count);
  mz_.resize(count);
  omega_.resize(count);
  margin_.resize(count);
  const double pw = 2.0 / n_;
  for (int f = 0; f < kFaces; ++f) {
    const int k = f >> 1;
    const double s = (f & 1) ? -1.0 : 1.0;
    for (uint32_t j = 0; j < n_; ++j) {
      for (uint32_t i = 0; i < n_; ++i) {
        const double u0 = -1.0 + pw * i, v0 = -1.0 + pw * j;
        const double u = u0 + 0.5 * pw, v = v0 + 0.5 * pw;
        double d[3];
        d[k] = s;
        d[(k + 1) % 3] = u;
        d[(k + 2) % 3] = v;
        const double inv = 1.0 / std::sqrt(1.0 + u * u + v * v);
        const uint32_t idx = index(f, i, j);
        dx_[idx] = float(d[0] * inv);
        dy_[idx] = float(d[1] * inv);
        dz_[idx] = float(d[2] * inv);
        omega_[idx] = float(rect_solid_angle(u0, v0, u0 + pw, v0 + pw));
        // Mean direction: the vector solid angle of the pixel, integral of
        // w dw, is exactly 1/2 sum over its edges of (edge angle) x (unit
        // normal of the edge's great circle) (Lambert's polygon formula).
        Imath::V3d corner[4];
        const double cu[4] = {u0, u0 + pw, u0 + pw, u0};
        const double cv[4] = {v0, v0, v0 + pw, v0 + pw};
        for (int c = 0; c < 4; ++c) {
          double p[3];
          p[k] = s;
          p[(k + 1) % 3] = cu[c];
          p[(k + 2) % 3] = cv[c];
          corner[c] = Imath::V3d(p[0], p[1], p[2]).normalized();
        }
        Imath::V3d vec(0);
        for (int c = 0; c < 4; ++c) {
          const Imath::V3d& a = corner[c];
          const Imath::V3d& b = corner[(c + 1) % 4];
          const Imath::V3d cross = a.cross(b);
          const double len = cross.length();
          vec += cross * (0.5 * std::atan2(len, a.dot(b)) / len);
        }
        const Imath::V3d center(d[0] * inv, d[1] * inv, d[2] * inv);
        if (vec.dot(center) < 0) vec = -vec;  // orientation of the corner loop
        const double total = rect_solid_angle(u0, v0, u0 + pw, v0 + pw);
        const double m[3] = {vec.x, vec.y, vec.z};
        mx_[idx] = float(m[0] / total);
        my_[idx] = float(m[1] / total);
        mz_[idx] = float(m[2] / total);
        // All corners c are above the horizon of n when the angle between n
        // and the mean direction is below 90 degrees minus the largest
        // angle rho to a corner: n . m > |m| sin(rho), rounded up a hair.
        const Imath::V3d mean = Imath::V3d(m[0], m[1], m[2]) / total;
        double min_cos = 1.0;
        for (int c = 0; c < 4; ++c) min_cos = std::min(min_cos, mean.normalized().dot(corner[c]));
        const double sin_rho = std::sqrt(std::max(0.0, 1.0 - min_cos * min_cos));
        margin_[idx] = float(mean.length() * sin_rho * 1.0001 + 1e-6);
      }
    }
  }
}

bool CubeLayout::cone_pixels(int face, const Imath::V3f& axis, float sin_a, float cos_a,
                             PixelRect& rect) const {
  float cu, cv, cw;
  face_coords(face, axis, cu, cv, cw);
  float umin = -1.f, umax = 1.f, vmin = -1.f, vmax = 1.f;
  if (cos_a > 0.f) {
    // The cone misses the face's pyramid when its axis is farther from the
    // face axis than the face corners are, plus the cone's half angle.
    const float cos_reach = kCosFaceCorner * cos_a - kSinFaceCorner * sin_a;
    if (cw < cos_reach) return false;
    if (cw > sin_a) {
      // The cone lies in w > 0: its projection onto the face plane is an
      // ellipse whose u extent solves (cu - u cw)^2 = sin^2 a (1 + u^2)
      // (planes through the v axis tangent to the cone); same for v.
      const float s2 = sin_a * sin_a;
      const float den = cw * cw - s2;
      const float ru = sin_a * std::sqrt(std::max(0.f, cu * cu + cw * cw - s2));
      const float rv = sin_a * std::sqrt(std::max(0.f, cv * cv + cw * cw - s2));
      umin = (cu * cw - ru) / den;
      umax = (cu * cw + ru) / den;
      vmin = (cv * cw - rv) / den;
      vmax = (cv * cw + rv) / den;
      if (umax < -1.f || umin > 1.f || vmax < -1.f || vmin > 1.f) return false;
    } else if (cw < -sin_a) {
      return false;  // the cone lies in w < 0
    }
  }
  // Pixel centers u_i = -1 + (i + 1/2) w inside [umin, umax], widened by a
  // hair so that rounding never drops a pixel on the boundary.
  const float inv = 1.f / pixel_width_;
  constexpr float kSlack = 1e-3f;
  const float fi0 = std::ceil((std::max(umin, -1.f) + 1.f) * inv - 0.5f - kSlack);
  const float fi1 = std::floor((std::min(umax, 1.f) + 1.f) * inv - 0.5f + kSlack);
  const float fj0 = std::ceil((std::max(vmin, -1.f) + 1.f) * inv - 0.5f - kSlack);
  const float fj1 = std::floor((std::min(vmax, 1.f) + 1.f) * inv - 0.5f + kSlack);
  const float last = float(n_ - 1);
  if (fi0 > last || fj0 > last || fi1 < 0.f || fj1 < 0.f || fi0 > fi1 || fj0 > fj1) return false;
  rect.i0 = uint32_t(std::max(0.f, fi0));
  rect.i1 = uint32_t(std::min(last, fi1));
  rect.j0 = uint32_t(std::max(0.f, fj0));
  rect.j1 = uint32_t(std::min(last, fj1));
  return true;
}

}  // namespace pbgi::gather
