// Records inside a V4-V7 page (FORMAT.md gives the byte offsets):
//
//  * shape byte, one per node in pre-order: child count and which children
//    live in another page. The shapes alone determine the treelet.
//  * leaf record: the leaf's frame (bounding sphere, also the quantization
//    frame of its surfels) and its surfel count: 18 bytes of floats in
//    V4-V7 pages; in V8/V9 pages, whose frames are rounded (RoundedFrame
//    below: every frame the tree build makes is), a bit-packed leaf
//    section (storage/pages/leaf_section.h).
//  * compact link record (V8/V9): the link record with the rounded
//    bounds (bounds_rounding.h) in 26 bytes instead of 40.
//  * link record: a child that lives in another page: that page's id and
//    the bounds, cone and area of its root (its payload follows in the
//    page's payload array), so that the ancestors' bounds and payloads can
//    be derived without loading the other page.
//  * surfel record, in the page's record layout (SurfelRecords,
//    leaf_format.h):
//    compact (18 bytes, V6/V7 pages, leaf format relative): position and
//      radius relative to the leaf's frame and a 12-bit octahedral normal
//      packed in 80 bits, RGB9E5 albedo and radiance; a flag says the
//      surfel emits, its RGB9E5 emission is in the page's emission
//      section (emission is zero on almost every surfel);
//    relative (24 bytes, V4/V5 pages, read only): position and radius
//      relative to the frame, 16-bit octahedral normal, RGB9E5 colours;
//    half (38 bytes): float32 position, half-float normal, radius (as a
//      fraction of the frame radius) and colours.
//
// Precision of a decoded surfel, with R the radius of its leaf's frame.
// Compact: each position coordinate on a grid of step 2^shift R / 8191
// (position_grid_shift below: shift 0, the 14-bit code, within R / 16382;
// a leaf whose smallest surfel radius r allows it, shift up to 4, a step
// of at most r / 32, within half a step, or a whole one within a step of
// the frame's edge, where the grid ends) (plus float
// rounding), radius within R / 16382, normal within kOctahedral12MaxAngle
// radians, each colour channel within max(r, g, b) / 512 (packed_values.h;
// emission exactly as RGB9E5 codes it, out of line or not).
// Relative: each position coordinate within R / 65534, radius within
// R / 131070, normal within kOctahedralMaxAngle radians, colours as compact.
// Half: position exact, radius within R / 4096, normal within 1e-3 rad,
// each colour channel within 2^-11 of itself (relative) above half's
// smallest normal 6.1e-5, and absolute 6e-8 below. All clamp colours to
// [0, 65408] (compact, relative) / [0, 65504] (half).
#pragma once

#include "storage/tree/leaf_format.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <Imath/ImathVec.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

inline constexpr size_t kShapeBytes = 1;
inline constexpr size_t kLeafRecordBytes = 18;
inline constexpr size_t kLinkRecordBytes = 40;

// The largest payload any codec of this build stores per node (float32 SH).
inline constexpr size_t kMaxPayloadBytesPerNode = 144;
// Most surfels a leaf record can count (u16).
inline constexpr uint32_t kMaxLeafSurfels = 65535;

// ---- shape byte ----
// bits 0-1: child count (0 = leaf); bit 2 / bit 3: child 0 / child 1 lives
// in another page; bits 4-7: zero.
struct NodeShape {
  uint8_t child_count = 0;
  bool external[2] = {false, false};
};
uint8_t encode_shape(const NodeShape& s);
// Returns false for a byte no writer produces (reserved bits, more than two
// children, an external flag on a missing child).
bool decode_shape(uint8_t byte, NodeShape& out);

// ---- leaf record ----
// The frame of a leaf: every decoded surfel disk lies inside the sphere
// (center, radius), and positions and radii are stored relative to it.
struct LeafFrame {
  Imath::V3f center{0, 0, 0};
  float radius = 0.f;
};
void write_leaf_record(const LeafFrame& f, uint32_t surfel_count, uint8_t* out);
void read_leaf_record(const uint8_t* in, LeafFrame& f, uint32_t& surfel_count);

// ---- rounded leaf frame (V8/V9) ----
// Leaf frames are rounded so that a few integers hold them exactly: the centre
// is k * 2^e per axis and the radius m * 2^e, with one exponent e per
// frame, |k| <= 2^22 and 0 <= m <= kMaxRoundedFrameRadius. e is the
// larger of ilogb(radius) - 10 (a grid step of 1/2048 to 1/1024 of the
// radius) and ilogb(largest |centre coordinate|) - 21 (k fits, and k 2^e
// is an exact float), and at least -126; so the centre moves by at most
// sqrt(3) 2^(e-1) (< 8.5e-4 of the radius when the first bound decides)
// and the radius grows by that move and then up to the next multiple of
// 2^e. The rounded sphere contains the given one.
// Why round: a frame is a leaf's bounding sphere, from which every
// ancestor's bounds derive; like rounded payloads (payload_rounding.h)
// the tree is defined with rounded frames (leaf_quantizer.h quantizes the
// surfels in them), so records hold the tree exactly and a page set
// still equals the in-memory tree bit for bit.
inline constexpr uint32_t kMaxRoundedFrameRadius = 4095;  // m: 12 bits
inline constexpr uint32_t kMaxCompactLeafSurfels = 4096;  // BuildOptions: leaf_size <= 4096
inline constexpr int kMinFrameExponent = -126;
inline constexpr int kMaxFrameExponent = 115;  // m 2^e stays a finite float
struct RoundedFrame {
  int exponent = kMinFrameExponent;
  int32_t k[3] = {0, 0, 0};
  uint32_t m = 0;
  LeafFrame frame() const;  // exact: every value is a float
};
// The rounded frame containing the sphere (center, radius) (finite, radius
// >= 0), on a grid of step at least radius / 2^(grid_bits + 1): node
// spheres take kSphereGridBits (as described above), leaf frames
// kLeafFrameGridBits since V10 (a step of R/256 to R/128: the frame grows
// by up to ~1.5% of its radius, and the leaf section stores each leaf in
// ~10 bits fewer: 2.96 -> 2.52 bytes a surfel on a generated city). Throws InvalidArgument when no
// rounded frame can hold it (a radius beyond ~2^126).
inline constexpr int kSphereGridBits = 10;
inline constexpr int kLeafFrameGridBits = 7;
RoundedFrame round_frame_outward(const LeafFrame& f, int grid_bits = kSphereGridBits);
// Whether a compact record can hold `f` exactly (some e with every centre
// coordinate k 2^e, |k| <= kMaxRoundedFrameCenter, and the radius m 2^e,
// m <= kMaxRoundedFrameRadius), and that representation (the coarsest).
// Every frame round_frame_outward() makes, and any widened as
// leaf_quantizer.h widens, is.
inline constexpr int32_t kMaxRoundedFrameCenter = (1 << 23) - 1;  // i24
bool to_rounded_frame(const LeafFrame& f, RoundedFrame& out);
// A leaf's frame and surfel count, as a page's leaf section (V8/V9,
// storage/pages/leaf_section.h) holds them.
struct LeafRecord {
  LeafFrame frame;
  uint32_t surfel_count = 0;
};

// ---- link record ----
// Writes page, center, radius, cone axis, cone cos and area of `n`.
void write_link_record(uint32_t page, const tree::Node& n, uint8_t* out);
// Reads them back into `n` (other fields untouched).
void read_link_record(const uint8_t* in, uint32_t& page, tree::Node& n);

// ---- compact link record (V8/V9) ----
// kCompactLinkRecordBytes: u32 page; the child's sphere as a compact leaf
// record's frame (u8 e + 128, three i24 k, u16 m: 12 bytes); its cone as
// a u32 octahedral axis code and the u16 half-float bits of 1 - cos
// (bounds_rounding.h); f32 area. The tree's bounds are rounded, so this
// holds the child's summary exactly. write throws Error for bounds that
// are not rounded (a writer's bug); read returns false for bytes no writer
// produces (exponent, radius or 1 - cos out of range, a centre beyond
// float range, an area that is negative or not finite).
inline constexpr size_t kCompactLinkRecordBytes = 26;
void write_compact_link_record(uint32_t page, const tree::Node& n, uint8_t* out);
bool read_compact_link_record(const uint8_t* in, uint32_t& page, tree::Node& n);

// ---- surfel record ----
// Encodes `s` relative to `f` in `records` (surfel_record_bytes(records)
// bytes); `s` must lie in the frame (its disk inside the sphere) for the
// stated precision to hold. Compact records leave the emission out: the
// record only says whether the surfel emits (surfel_record_emits), and
// its emission entry (write_emission_entry) goes to the page's emission
// section; decode_surfel_record then sets the emission to zero and the
// caller reads the entry (read_emission_entry).
// Compact records: positions on the grid of `position_shift` (0 ..
// kMaxPositionGridShift; other layouts ignore it).
void encode_surfel_record(SurfelRecords records, const Surfel& s, const LeafFrame& f, uint8_t* out,
                          int position_shift = 0);

// The grid of a compact leaf's positions: the coarsest (largest shift, at
// most kMaxPositionGridShift) whose step 2^shift R / 8191 is at most
// 1/kPositionStepsPerRadius of the leaf's smallest surfel radius (0 for a
// leaf with a zero radius). Why: positions relative to a frame of ~2
// surfel radii need far fewer than 14 bits (a step of r/32 moves a disk by
// ~1.5% of its radius at most), and V10/V11 surfel sections store a page
// of such leaves in 10 bits a coordinate; a sparse leaf (R >> r) keeps 14.
inline constexpr int kMaxPositionGridShift = 4;
inline constexpr double kPositionStepsPerRadius = 32;
int position_grid_shift(float frame_radius, float smallest_radius);
// How far from where it was sampled a decoded compact surfel may lie, in
// its radii: a step of r/32 per coordinate on a coarse grid (sqrt(3)/32 <
// 1/16), or R/16382 on the finest, less than r/16 for frames up to 1024
// surfel radii. Whoever looks the surfel's surface up again or casts
// shadow rays from it (server/surfels) starts this far above it.
inline constexpr float kDecodedPositionSlack = 1.f / 16.f;
void decode_surfel_record(SurfelRecords records, const uint8_t* in, const LeafFrame& f, Surfel& s);
// Whether the record at `in` has an emission entry (compact records with
// a non-zero RGB9E5 emission; never for other layouts).
bool surfel_record_emits(SurfelRecords records, const uint8_t* in);
// Shared albedo (pages whose compact records all hold one albedo): the
// RGB9E5 albedo of a compact record, and the record without it (14 bytes,
// SurfelRecords::kCompactSharedAlbedo, which decodes with albedo 0: the
// reader sets the page's).
uint32_t compact_record_albedo(const uint8_t* compact);
void drop_albedo(const uint8_t* compact, uint8_t* out);
// The kEmissionEntryBytes of an emitting surfel's entry: RGB9E5 emission.
void write_emission_entry(const Surfel& s, uint8_t* out);
Imath::C3f read_emission_entry(const uint8_t* in);

// Bytes around the records of every page: header, trailer and the padding
// that aligns the leaf records to 4 bytes.
inline constexpr size_t kPageOverheadBytes = 32 /*header*/ + 8 /*trailer*/ + 3 /*pad*/;

// The smallest legal page size for `leaf_size` surfels per leaf in
// `format`: a page must hold one full leaf, and one internal node whose
// two children both live elsewhere.
// Compact records count an emission entry for every surfel (the worst case).
constexpr size_t min_page_bytes(uint32_t leaf_size, LeafFormat format = LeafFormat::kRelative) {
  const SurfelRecords records = written_surfel_records(format);
  const size_t per_surfel = surfel_record_bytes(records) + (emission_out_of_line(records) ? kEmissionEntryBytes : 0);
  const size_t leaf = kShapeBytes + kLeafRecordBytes + size_t(leaf_size) * per_surfel;
  const size_t fork = kShapeBytes + 2 * (kLinkRecordBytes + kMaxPayloadBytesPerNode);
  return kPageOverheadBytes + (leaf > fork ? leaf : fork);
}

}  // namespace pbgi::storage
