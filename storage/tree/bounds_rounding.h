// The bounds of a node in V8/V9 page sets (bounding sphere and normal
// cone), rounded outward to a form that a link record stores exactly in
// 22 bytes instead of 32 (page_records.h, FORMAT.md).
//
// Sphere: a rounded frame (page_records.h RoundedFrame: centre on a
// power-of-two grid of at most 1/1024 of the radius, radius rounded up),
// the sphere of a leaf being its (rounded) frame.
// Cone: the axis becomes the decoded 16-bit octahedral code of itself
// (within kOctahedralMaxAngle), and the half angle grows by the axis's
// move (measured, not assumed), then 1 - cos(half angle) is rounded up to
// a half float (11 significant bits) and cos taken back, rounded down.
// Both contain what they round: every surfel disk below a node lies in its
// sphere, every normal in its cone.
//
// Why round every node, not only the links (as payload_rounding.h explains
// for payloads): a link must equal the root its child's page derives, and
// a node's bounds must not depend on where page boundaries fall, so the
// tree itself is defined with rounded bounds: an internal node's are the
// rounded bounds enclosing its children's (rounded) bounds, in the build,
// the in-memory tree and every reader of V8/V9 pages alike. Each level
// widens a sphere by at most ~0.18 % of its radius and a cone by ~1e-4 rad
// plus the half-float step; the bounds stay conservative (tests/storage/
// tree checks every node against its surfels).
//
// Thread-safety: pure functions.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/normal_cone.h"

#include <cstdint>

namespace pbgi::tree {

// The rounded cone containing `c` (a unit axis; cos in [-1, 1]).
NormalCone round_cone_outward(const NormalCone& c);

// The code of a rounded cone: the axis's octahedral code (16 bits per
// coordinate) and the half-float bits of 1 - cos. Returns false for a cone
// that round_cone_outward() did not make (no code decodes to it).
bool cone_code(const NormalCone& rounded, uint32_t& axis_code, uint16_t& one_minus_cos);
// The cone of a code; false for bits no writer produces (1 - cos not a
// finite half float in [0, 2]).
bool cone_of_code(uint32_t axis_code, uint16_t one_minus_cos, NormalCone& out);

// Rounds the sphere (round_frame_outward) and the cone of `n` in place.
void round_bounds(Node& n);

}  // namespace pbgi::tree
