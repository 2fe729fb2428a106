// Fixed-size records inside a V1 page: the topology record of a node (its
// bounds, cone, area and links, everything but the payload) and the surfel
// record. Both are 64 bytes of little-endian fields; FORMAT.md gives the
// offsets. The payload of a node is stored apart, by a codec.
#pragma once

#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <cstddef>
#include <cstdint>

namespace pbgi::storage {

inline constexpr size_t kTopologyRecordBytes = 64;
inline constexpr size_t kSurfelRecordBytes = 64;
// The largest payload any codec of this build stores per node (float32 SH);
// used to check that a page can always hold one full leaf.
inline constexpr size_t kMaxPayloadBytesPerNode = 144;

// Writes everything of `n` but the payload (radiance_sh, coverage_sh).
void write_topology_record(const tree::Node& n, uint8_t* out);
// Reads the fields written above; payload fields are left untouched.
void read_topology_record(const uint8_t* in, tree::Node& n);

void write_surfel_record(const Surfel& s, uint8_t* out);
void read_surfel_record(const uint8_t* in, Surfel& s);

// Bytes a page needs at most for one leaf of `leaf_size` surfels: the
// smallest legal page size for that leaf size.
constexpr size_t min_page_bytes(uint32_t leaf_size) {
  return 32 /*header*/ + 8 /*trailer*/ + kTopologyRecordBytes + kMaxPayloadBytesPerNode +
         size_t(leaf_size) * kSurfelRecordBytes;
}

}  // namespace pbgi::storage
