#include "storage/tree/normal_cone.h"

#include <algorithm>
#include <cmath>

namespace pbgi::tree {

namespace {
constexpr double kPi = 3.14159265358979323846;
// Widening of every cone, in radians: covers float rounding of axes and of
// the stored normals (about 1e-6 each) with a wide margin.
constexpr double kAngleSlack = 1e-5;

Imath::V3d to_d(const Imath::V3f& v) { return {v.x, v.y, v.z}; }

NormalCone make_cone(const Imath::V3d& axis, double half_angle) {
  NormalCone c;
  half_angle += kAngleSlack;
  if (half_angle >= kPi) return c;  // wide
  const Imath::V3d a = axis.normalized();
  c.axis = Imath::V3f(float(a.x), float(a.y), float(a.z));
  c.cos_half_angle = std::max(-1.f, float(std::cos(half_angle)));
  return c;
}

double angle_of(float cos_half_angle) {
  return std::acos(std::clamp(double(cos_half_angle), -1.0, 1.0));
}

// Any unit vector perpendicular to a.
Imath::V3d perpendicular(const Imath::V3d& a) {
  const Imath::V3d t = std::abs(a.x) < 0.9 ? Imath::V3d(1, 0, 0) : Imath::V3d(0, 1, 0);
  return a.cross(t).normalized();
}
}  // namespace

NormalCone cone_of_normals(std::span<const Surfel> surfels) {
  Imath::V3d sum(0);
  for (const Surfel& s : surfels) sum += to_d(s.normal);
  if (sum.length() < 1e-6 * double(surfels.size())) return {};  // no dominant direction
  const Imath::V3d axis = sum.normalized();
  double min_cos = 1.0;
  for (const Surfel& s : surfels) min_cos = std::min(min_cos, axis.dot(to_d(s.normal).normalized()));
  return make_cone(axis, std::acos(std::clamp(min_cos, -1.0, 1.0)));
}

NormalCone merge_cones(const NormalCone& a_in, const NormalCone& b_in) {
  if (a_in.is_wide()) return a_in;
  if (b_in.is_wide()) return b_in;
  // Let a be the wider cone. (Each angle is taken once: an acos per cone
  // is a good part of deriving a page's nodes when it loads.)
  const double t_in[2] = {angle_of(a_in.cos_half_angle), angle_of(b_in.cos_half_angle)};
  const bool swap = t_in[0] < t_in[1];
  const NormalCone& a = swap ? b_in : a_in;
  const NormalCone& b = swap ? a_in : b_in;
  const double ta = t_in[swap ? 1 : 0], tb = t_in[swap ? 0 : 1];
  const Imath::V3d aa = to_d(a.axis).normalized(), ab = to_d(b.axis).normalized();
  const double cos_d = std::clamp(aa.dot(ab), -1.0, 1.0);
  const double td = std::acos(cos_d);
  if (std::min(td + tb, kPi) <= ta) return a;  // b lies inside a
  const double to = 0.5 * (ta + td + tb);
  if (to >= kPi) return {};
  // Rotate a's axis towards b's by (to - ta), in the plane of both axes.
  Imath::V3d w = ab - aa * cos_d;
  w = w.length() > 1e-9 ? w.normalized() : perpendicular(aa);
  const double tr = to - ta;
  const Imath::V3d axis = aa * std::cos(tr) + w * std::sin(tr);
  return make_cone(axis, to);
}

}  // namespace pbgi::tree
