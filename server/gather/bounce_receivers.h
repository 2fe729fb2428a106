// Sparse receivers of a build-time bounce (docs/gather.md, section 9c).
//
// The light a bounce adds to the surfels reaches the image only through
// the render's own gather, after at least one more reflection: it is
// smooth, like the irradiance caches and point-cloud filtering of
// production renderers' bounce passes. So a bounce need not be gathered
// at every surfel: of each run of `stride` consecutive receivers in the
// tree's Morton order (a compact patch) one, the member nearest the run's
// centroid, is gathered (the *representative*), and every other member
// interpolates the representatives of its own and the two adjacent runs.
//
// A representative counts for a member only if it faces the same way
// (normals within kMaxNormalAngleCos) and lies near the member's tangent
// plane and within reach (kReach x sqrt(stride) x the member's radius: a
// few runs' widths): irradiance is not carried round an edge, across a
// step or to a surfel far off in a run that straddles a Morton cell. Its
// weight falls smoothly to 0 at those limits, so interpolated values are
// continuous. A member that no representative counts for is gathered
// itself (a "fallback"), so corners and thin features keep their own
// gather.
//
// Thread-safety: the functions are reentrant.
#pragma once

#include "storage/tree/surfel.h"

#include <Imath/ImathColor.h>

#include <cstdint>
#include <span>
#include <vector>

namespace pbgi {

struct BounceReceiverLimits {
  // A representative counts only with a normal within ~25 degrees.
  static constexpr float kMaxNormalAngleCos = 0.9f;
  // Reach, in run widths: kReach x sqrt(stride) x the member's radius.
  static constexpr float kReach = 3.f;
  // Largest distance from the member's tangent plane, in reaches.
  static constexpr float kMaxPlaneOffset = 0.25f;
};

// `run` holds indices into `surfels` in Morton order. Returns the positions
// in `run` of the representatives, one per run of `stride` consecutive
// entries (stride >= 1; 1: every entry), ascending.
std::vector<uint32_t> pick_representatives(std::span<const Surfel> surfels,
                                           std::span<const uint32_t> run, uint32_t stride);

// Interpolates irradiance[run[j]] for every non-representative position j
// of `run` from `gathered` (gathered[k]: the irradiance of
// run[representatives[k]]), which is also copied to the representatives'
// own entries. Positions j that no representative counts for are appended
// to `fallback` (their irradiance is left as is: gather them). `stride` and
// `representatives` as pick_representatives() made them.
void interpolate_from_representatives(std::span<const Surfel> surfels, std::span<const uint32_t> run,
                                      uint32_t stride, std::span<const uint32_t> representatives,
                                      std::span<const Imath::C3f> gathered,
                                      std::span<Imath::C3f> irradiance, std::vector<uint32_t>& fallback);

}  // namespace pbgi
