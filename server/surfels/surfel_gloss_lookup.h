// A stored surfel's glossy lobe, found again from the scene.
//
// Page records keep a surfel's diffuse radiance, not its GGX lobe
// (storage/tree/surfel.h: the lobe lives only while the build sorts; pages
// store its outgoing radiance as wavelet cube maps). A page set built from
// stored surfels (a bounce's, server/engine/bounce_pages.h) must give its
// glossy senders their lobes back to light and code them again: a short
// ray from just above each surfel down its normal finds the triangle it
// was sampled on, and the material there gives the lobe exactly as
// sampling did (set_surfel_material with the same texture footprint).
//
// The triangle must face the surfel's way (or be the back of a
// double-sided mesh): a coincident surface facing the other way (a box's
// bottom face lying on a floor) is passed through. A surfel whose ray
// meets no such triangle keeps no lobe: it is counted, never guessed.
//
// Thread-safety: reentrant; the scene is only read.
#pragma once

#include "server/scene/ray_scene.h"
#include "storage/tree/surfel.h"

#include <cstdint>
#include <span>

namespace pbgi {

struct GlossLookupStats {
  uint64_t glossy = 0;  // surfels given a lobe
  uint64_t missed = 0;  // surfels whose triangle was not found
};

// Sets surfels[i].gloss for every surfel (cleared where the material has
// no lobe below `glossy_roughness`; 0 clears all). Albedo, emission and
// radiance are left as stored.
GlossLookupStats restore_surfel_gloss(const RayScene& rays, float glossy_roughness,
                                      std::span<Surfel> surfels);

}  // namespace pbgi
