#include "storage/tree/bounds_rounding.h"

#include "common/errors.h"
#include "storage/format/packed_values.h"
#include "storage/tree/page_records.h"

#include <Imath/half.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pbgi::tree {

namespace {

constexpr int kAxisBits = 16;

Imath::V3f decode_axis(uint32_t code) { return storage::decode_octahedral_bits(code, kAxisBits); }

float half_value(uint16_t bits) {
  Imath::half h;
  h.setBits(bits);
  return float(h);
}

// The smallest half float >= x (x in [0, 2]), as bits.
uint16_t half_at_least(double x) {
  uint16_t bits = Imath::half(float(x)).bits();
  if (double(half_value(bits)) < x) ++bits;  // positive halves: the next one up
  return bits;
}

// cos = 1 - s for a half float s in [0, 2], rounded down to a float (1 - s
// is exact in double: s has 11 significant bits and an exponent >= -24).
float cos_of(uint16_t s_bits) {
  const double c = 1.0 - double(half_value(s_bits));
  auto f = float(c);
  if (double(f) > c) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace

// A decoded axis that encodes to a code decoding to it again, so that
// cone_code() finds it. Re-encoding a decoded axis is not always stable:
// on the lower hemisphere's fold a coordinate decoded as 0 encodes to the
// mirrored code, which decodes a few ulp away; a few rounds reach a
// stable one. false if they do not (never seen; the caller widens).
bool stable_axis(const Imath::V3f& axis, Imath::V3f& out) {
  uint32_t code = storage::encode_octahedral_bits(axis, kAxisBits);
  for (int round = 0; round < 4; ++round) {
    out = decode_axis(code);
    const uint32_t again = storage::encode_octahedral_bits(out, kAxisBits);
    // The same code decodes to `out` again: no second decode (the common
    // case; every node a page derives rounds its cone here).
    if (again == code || decode_axis(again) == out) return true;
    code = again;
  }
  return false;
}

NormalCone round_cone_outward(const NormalCone& c) {
  NormalCone out;
  if (!stable_axis(c.axis, out.axis)) {
    // The whole sphere around a stable axis: contains anything.
    stable_axis({0.f, 0.f, 1.f}, out.axis);
    out.cos_half_angle = -1.f;
    return out;
  }
  // The axis moved by the angle between the two unit vectors, at most
  // 2 asin(chord / 2) <= 1.0001 chord for the chords here (< 1e-3); the
  // float normalization adds ~1e-7.
  const double chord = (Imath::V3d(c.axis) - Imath::V3d(out.axis)).length();
  const double delta = 1.0001 * chord + 1e-7;
  // cos(theta + delta) >= cos(theta) cos(delta) - sin(theta) sin(delta),
  // with cos(delta) >= 1 - delta^2 / 2 and sin(delta) <= delta.
  const double cos_theta = std::clamp(double(c.cos_half_angle), -1.0, 1.0);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  const double lowered = (cos_theta >= 0 ? cos_theta * (1.0 - 0.5 * delta * delta) : cos_theta) - sin_theta * delta;
  // 1 - cos, with a margin for the double rounding of the line above.
  const double s = std::min(2.0, (1.0 - lowered) * (1.0 + 0x1p-40) + 0x1p-60);
  out.cos_half_angle = cos_of(half_at_least(s));
  return out;
}

bool cone_code(const NormalCone& rounded, uint32_t& axis_code, uint16_t& one_minus_cos) {
  // 1 - cos: the half float whose cos_of() is the cone's.
  const double s = 1.0 - double(rounded.cos_half_angle);
  const uint16_t bits = half_at_least(s);
  bool found = false;
  for (const uint16_t b : {bits, uint16_t(bits - 1)}) {
    if (b <= 0x4000u && cos_of(b) == rounded.cos_half_angle) {  // 0x4000: 2.0
      one_minus_cos = b;
      found = true;
      break;
    }
  }
  if (!found) return false;
  // The axis: the code it encodes to, or a neighbour (re-encoding a
  // decoded axis may land one step off).
  const uint32_t code = storage::encode_octahedral_bits(rounded.axis, kAxisBits);
  const int u = int(code & 0xffffu), v = int(code >> 16);
  for (int du = 0; du <= 2; ++du) {
    for (int dv = 0; dv <= 2; ++dv) {
      const int cu = u + (du == 2 ? -1 : du), cv = v + (dv == 2 ? -1 : dv);
      if (cu < 0 || cv < 0 || cu > 0xffff || cv > 0xffff) continue;
      const uint32_t c = uint32_t(cu) | uint32_t(cv) << 16;
      if (decode_axis(c) == rounded.axis) {
        axis_code = c;
        return true;
      }
    }
  }
  return false;
}

bool cone_of_code(uint32_t axis_code, uint16_t one_minus_cos, NormalCone& out) {
  const float s = half_value(one_minus_cos);
  if (!(s >= 0.f && s <= 2.f)) return false;  // NaN, infinite, negative or beyond 2
  out.axis = decode_axis(axis_code);
  out.cos_half_angle = cos_of(one_minus_cos);
  return true;
}

void round_bounds(Node& n) {
  const storage::LeafFrame sphere = storage::round_frame_outward({n.center, n.radius}).frame();
  n.center = sphere.center;
  n.radius = sphere.radius;
  const NormalCone cone = round_cone_outward({n.cone_axis, n.cone_cos});
  n.cone_axis = cone.axis;
  n.cone_cos = cone.cos_half_angle;
}

}  // namespace pbgi::tree
