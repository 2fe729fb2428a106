#include "storage/tree/surfel_checks.h"

#include "common/errors.h"

#include <cmath>
#include <string>

namespace pbgi::tree {

namespace {
bool finite(const Imath::V3f& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool non_negative(const Imath::C3f& c) { return c.x >= 0.f && c.y >= 0.f && c.z >= 0.f; }
}  // namespace

void check_surfel(Surfel& s, uint64_t index) {
  const float len = s.normal.length();
  const bool ok = finite(s.position) && finite(s.normal) && std::isfinite(s.radius) && s.radius >= 0 &&
                  len > 1e-6f && finite(s.radiance) && finite(s.albedo) && finite(s.emission) &&
                  non_negative(s.radiance) && non_negative(s.albedo) && non_negative(s.emission) &&
                  std::isfinite(s.gloss.alpha) && s.gloss.alpha >= 0.f && s.gloss.alpha <= 1.f &&
                  finite(s.gloss.f0) && non_negative(s.gloss.f0);
  if (!ok) {
    throw InvalidArgument("surfel " + std::to_string(index) +
                          " is invalid (non-finite field, negative radius or colour, or zero normal): "
                          "position (" +
                          std::to_string(s.position.x) + ", " + std::to_string(s.position.y) + ", " +
                          std::to_string(s.position.z) + "), radius " + std::to_string(s.radius));
  }
  s.normal /= len;
}

}  // namespace pbgi::tree
