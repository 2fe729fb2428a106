// The SH payload of a node in V6/V7 page sets, rounded to a fixed-point
// form that a page's link can store in 76 bytes instead of 144, exactly.
//
// Each of the four 9-coefficient blocks of a payload (radiance r, g, b and
// coverage) is rounded to signed 16-bit multiples of a power of two 2^e
// chosen per block: the smallest e for which the largest coefficient fits
// (|q| <= 32767). Every coefficient moves by at most 2^(e-1), i.e. by at
// most 2^-15 of its block's largest magnitude; blocks whose largest
// magnitude is below 2^-100 become zero.
//
// Why round every node, not only the links. Derived pages (V6) store no
// payload but at links, and a reader derives every other node's payload
// from its children (storage/format/FORMAT.md). If only the link payloads
// were rounded, a node's payload would depend on where the page boundaries
// fall. Instead the tree itself is defined with rounded payloads: every
// node's payload, leaf or internal, is the rounded area-weighted average
// of what lies below it (node_summary.h), in the build, in the in-memory
// tree and in a page reader alike. Rounding is idempotent, so a link's
// payload, written in this form, decodes to exactly the payload the linked
// page derives for its root, and every page set still equals the
// in-memory tree of the same surfels bit for bit. The rounding errors of
// a node and its ancestors add up along a path at most (one rounding per
// level, never compounded through a lossy code), each 2^-15 of a block's
// largest coefficient.
//
// Thread-safety: pure functions.
#pragma once

#include "storage/tree/node.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace pbgi::tree {

// Bytes of one rounded payload: 4 blocks of a u8 exponent and 9 i16.
inline constexpr size_t kRoundedPayloadBytes = 4 * (1 + 9 * 2);

// Rounds n.radiance_sh and n.coverage_sh in place (idempotent).
void round_payload(Node& n);

// Writes the rounded payload of `n` (round_payload() must hold it already:
// the encoding is exact only for rounded values) to kRoundedPayloadBytes
// at `out`; reads it back into `n`'s payload. read_rounded_payload returns
// false for bytes no writer produces (an exponent byte outside [14, 242]).
void write_rounded_payload(const Node& n, uint8_t* out);
bool read_rounded_payload(const uint8_t* in, Node& n);
// The same into a payload's two parts (the gather's page views keep wide
// nodes' payloads in this form).
bool read_rounded_payload(const uint8_t* in, sh::ShRgb& radiance, sh::Sh9& coverage);

// The compact form of a rounded payload (V8/V9 link payloads), the same
// values in fewer bytes. Per block: the exponent byte (0: the block is
// zero, nothing follows); then 9 two-bit classes, LSB first in a u24
// whose top 6 bits are zero (0: q = 0, 1: an i8 follows, 2: an i16
// follows); then the values, in coefficient order. 4 to 88 bytes; zero
// blocks (a channel no light reaches) and small higher-band coefficients
// are common.
// write appends to `out` (the payload must be rounded); read returns the
// bytes it took from `in`, or 0 for bytes no writer produces (past the
// end of `in`, an exponent out of range, class 3, non-zero spare bits, a
// value of the wrong class: zero, or an i16 that fits an i8, or a block
// of only zeros under an exponent).
inline constexpr size_t kMaxCompactPayloadBytes = 4 * (1 + 3 + 9 * 2);
void write_compact_payload(const Node& n, std::vector<uint8_t>& out);
size_t read_compact_payload(std::span<const uint8_t> in, Node& n);

}  // namespace pbgi::tree
