// A surfel: a small oriented disk sampled from a surface, carrying the
// outgoing diffuse radiance computed by direct lighting (and bounces), and
// for a glossy surface its GGX lobe (the tree build turns the lobe into a
// wavelet cube map of outgoing radiance: storage/codecs/glossy_pages.h).
#pragma once

#include <Imath/ImathColor.h>
#include <Imath/ImathVec.h>

#include <cstdint>

namespace pbgi {

// A glossy sender's specular lobe (server/surfels/surfel_material.h): GGX
// alpha and reflectance at normal incidence. f0 = 0: none, the surfel is
// diffuse only.
struct SurfelGloss {
  float alpha = 0.f;
  Imath::C3f f0{0, 0, 0};
  bool glossy() const { return alpha > 0.f && (f0.x > 0.f || f0.y > 0.f || f0.z > 0.f); }
};

struct Surfel {
  Imath::V3f position;
  Imath::V3f normal;        // unit; the side that emits
  float radius = 0.f;       // disk radius; area = pi r^2
  Imath::C3f albedo{0, 0, 0};
  Imath::C3f emission{0, 0, 0};
  Imath::C3f radiance{0, 0, 0};  // outgoing diffuse radiance (emission + reflected)
  // Carried through the build's sort, not stored in page records: pages
  // keep the lobe's outgoing radiance (wavelet cube maps) instead.
  SurfelGloss gloss;
  // The air region its front faces (region_grid.h; kAnyRegion = 0: the
  // scene has one, or none is known). Carried through the build's sort,
  // which keeps each region's surfels in a subtree of their own; not
  // stored in page records (a page's surfels are all its subtree's region).
  uint32_t region = 0;

  float area() const { return 3.14159265358979f * radius * radius; }
};

}  // namespace pbgi
