// A surfel: a small oriented disk sampled from a surface, carrying the
// outgoing diffuse radiance computed by direct lighting (and bounces).
#pragma once

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

namespace pbgi {

struct Surfel {
  Imath::V3f position;
  Imath::V3f normal;        // unit; the side that emits
  float radius = 0.f;       // disk radius; area = pi r^2
  Imath::C3f albedo{0, 0, 0};
  Imath::C3f emission{0, 0, 0};
  Imath::C3f radiance{0, 0, 0};  // outgoing diffuse radiance (emission + reflected)

  float area() const { return 3.14159265358979f * radius * radius; }
};

}  // namespace pbgi
