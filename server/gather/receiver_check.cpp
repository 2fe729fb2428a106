#include "server/gather/receiver_check.h"

#include "common/errors.h"

#include <cmath>
#include <string>

namespace pbgi::gather {

namespace {

bool finite(const Imath::V3f& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// How far a glossy view direction's length may be from 1.
constexpr float kUnitTolerance = 1e-3f;

// Names receiver `index` of a batch (or, without one, just "Receiver").
std::string receiver_name(size_t index) {
  return index == SIZE_MAX ? std::string("Receiver") : "receiver " + std::to_string(index);
}

}  // namespace

Receiver checked_receiver(const Receiver& r, size_t index) {
  if (!finite(r.position) || !finite(r.normal)) {
    throw InvalidArgument(receiver_name(index) + ": non-finite position or normal");
  }
  const float len = r.normal.length();
  if (!(len > 1e-12f)) throw InvalidArgument(receiver_name(index) + ".normal: zero length");
  const GlossyLobe& g = r.glossy;
  const bool colour_ok = std::isfinite(g.specular.x) && std::isfinite(g.specular.y) &&
                         std::isfinite(g.specular.z) && g.specular.x >= 0.f &&
                         g.specular.y >= 0.f && g.specular.z >= 0.f;
  if (!colour_ok) {
    throw InvalidArgument(receiver_name(index) + ".glossy.specular: not a finite colour >= 0");
  }
  if (g.active()) {
    if (!finite(g.view) || !(std::abs(g.view.length() - 1.f) <= kUnitTolerance)) {
      throw InvalidArgument(receiver_name(index) + ".glossy.view = (" + std::to_string(g.view.x) +
                            ", " + std::to_string(g.view.y) + ", " + std::to_string(g.view.z) +
                            "): not a unit vector");
    }
    if (!(g.roughness >= 0.f && g.roughness <= 1.f)) {
      throw InvalidArgument(receiver_name(index) + ".glossy.roughness = " +
                            std::to_string(g.roughness) + ": not in [0, 1]");
    }
  }
  return {r.position, r.normal / len, g};
}

}  // namespace pbgi::gather
