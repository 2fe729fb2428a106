// The leaf formats of a page set: its build option (storage/tree/
// build_options.h) and the size of its surfel records (page_records.h).
// Apart from the records so that the options, which the client's flags
// read too, need nothing of the page layout.
#pragma once

#include "common/options/option_table.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace pbgi::storage {

// How leaves store their surfels, chosen per page set (BuildOptions::
// leaf_format, stored in the manifest, flagged in every page). The two
// formats of Buchholz & Boubekeur 2012, table 2:
//   relative  format "B": positions relative to the leaf's frame (the
//             parent-relative coding of QSplat, Rusinkiewicz & Levoy
//             2000), 16-bit fixed point, octahedral normal, RGB9E5
//             colours. 24 bytes. The default: smallest.
//   half      format "A": half floats (Kontkanen et al. 2011) except the
//             position, which keeps full float32 precision. 38 bytes.
//             For scenes whose colours need more than RGB9E5's shared
//             9-bit mantissa, or positions exact to the float.
// (The paper's records hold one colour; ours hold albedo, emission and
// radiance, which multiple bounces need.)
enum class LeafFormat : uint8_t { kRelative = 0, kHalf = 1 };
inline constexpr options::EnumName<LeafFormat> kLeafFormatNames[] = {{LeafFormat::kRelative, "relative"},
                                                                     {LeafFormat::kHalf, "half"}};
constexpr std::span<const options::EnumName<LeafFormat>> enum_names(LeafFormat) { return kLeafFormatNames; }

// The byte layout of a page's surfel records, which the leaf format and
// the page format together decide (storage/tree/page_records.h):
//   relative  leaf format relative in V4/V5 pages: 24 bytes (read only);
//   compact   leaf format relative in V6/V7 pages: 18 bytes, emission out
//             of line (the page's emission section);
//   half      leaf format half in any page: 38 bytes;
//   compact shared albedo: the compact record without its albedo, 14
//             bytes, in V6/V7 pages whose surfels all have one albedo
//             (kPageFlagSharedAlbedo: the page stores it once). Only page
//             readers and writers see it; the tree build makes compact ones.
enum class SurfelRecords : uint8_t { kRelative = 0, kCompact = 1, kHalf = 2, kCompactSharedAlbedo = 3 };

inline constexpr size_t kRelativeSurfelRecordBytes = 24;
inline constexpr size_t kCompactSurfelRecordBytes = 18;
inline constexpr size_t kCompactSharedAlbedoRecordBytes = 14;
inline constexpr size_t kHalfSurfelRecordBytes = 38;
constexpr size_t surfel_record_bytes(SurfelRecords r) {
  return r == SurfelRecords::kHalf                  ? kHalfSurfelRecordBytes
         : r == SurfelRecords::kCompact             ? kCompactSurfelRecordBytes
         : r == SurfelRecords::kCompactSharedAlbedo ? kCompactSharedAlbedoRecordBytes
                                                    : kRelativeSurfelRecordBytes;
}
// The records of leaf format `f` in pages with (V6/V7) or without (V4/V5)
// compact records.
constexpr SurfelRecords surfel_records_of(LeafFormat f, bool compact_pages) {
  if (f == LeafFormat::kHalf) return SurfelRecords::kHalf;
  return compact_pages ? SurfelRecords::kCompact : SurfelRecords::kRelative;
}
// The records this build writes for leaf format `f` (V6/V7 pages).
constexpr SurfelRecords written_surfel_records(LeafFormat f) { return surfel_records_of(f, true); }
// Bytes per surfel this build writes for leaf format `f`.
constexpr size_t surfel_record_bytes(LeafFormat f) { return surfel_record_bytes(written_surfel_records(f)); }
// Whether a record of `r` keeps its emission out of line: in the page's
// emission section (4 bytes per emitting surfel), flagged in the record.
constexpr bool emission_out_of_line(SurfelRecords r) {
  return r == SurfelRecords::kCompact || r == SurfelRecords::kCompactSharedAlbedo;
}
inline constexpr size_t kEmissionEntryBytes = 4;
// As written in config files, CLI flags, requests and `pbgi inspect`.
// parse_leaf_format throws InvalidArgument naming the accepted values.
LeafFormat parse_leaf_format(const std::string& name);
std::string to_string(LeafFormat format);

}  // namespace pbgi::storage
