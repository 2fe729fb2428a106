// The look-up table (LUT) of quantized SH payloads (Buchholz & Boubekeur
// 2012): l representative normalized node data vectors learned by k-means,
// plus the parameters of the scale quantizer. One table serves a whole page
// set; it is stored with the page set's metadata and versioned
// (kShLutFormatV1 below).
//
// Learning (train_sh_lut): the caller builds a temporary tree over a random
// subset of the scene's surfels (ShLutOptions::sample_fraction, see
// sample_surfels()) and passes all of its nodes, leaves included. Their
// normalized vectors (storage/codecs/sh_normalization.h) are clustered with
// k-means; the scale range comes from the sample's scales.
//
// Serialized form (all little-endian; H = 32 in V1, 40 in V2):
//   offset  size     field
//   0       4        magic 'PBGL'
//   4       4        version u32 (1 or 2; written: 2)
//   8       4        dims u32 (36)
//   12      4        entry_count u32 l (1 .. 65536)
//   16      4        scale_bits u32 (4 .. 16)
//   20      4        coverage_weight f32 (> 0)
//   24      4        log2_scale_lo f32
//   28      4        log2_scale_hi f32 (> lo)
//   32      4        V2: hdr_log2_scale f32 (may be +inf: no HDR rule)
//   36      4        V2: hdr_max_error f32 (>= 0)
//   H       144 l    entries: l x 36 f32 normalized vectors
//   H+144l  8        XXH3-64 of bytes [0, H + 144 l)
// V1 tables read as hdr_log2_scale = +inf (no HDR rule).
//
// The HDR rule (V2). A few very bright nodes (emitters, and the small nodes
// around them) dominate the light they send, yet are too rare for k-means to
// spend entries on their unusual colours and lobes: their normalized error
// can reach tens of percent. So a node whose scale is at least
// 2^hdr_log2_scale (the sample's hdr_quantile) and whose normalized
// quantization error |v' - v| / |v| exceeds hdr_max_error is stored raw.
//
// Thread-safety: QuantizedShTable is an immutable value once built.
#pragma once

#include "storage/codecs/kmeans.h"
#include "storage/codecs/sh_normalization.h"
#include "storage/format/format_version.h"
#include "storage/tree/node.h"
#include "storage/tree/surfel.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace pbgi::storage {

inline constexpr uint32_t kShLutMagic = fourcc("PBGL");
inline constexpr uint32_t kShLutFormatV1 = 1;
inline constexpr uint32_t kShLutFormatV2 = 2;  // + the HDR rule

struct ShLutOptions {
  static constexpr uint32_t kMinEntries = 64;
  static constexpr uint32_t kMaxEntries = 1u << 16;

  // LUT size l (64 .. 65536; 2^7 .. 2^16 are the design range, the paper
  // uses 100 / 1000 / 10000). Indices take ceil(log2 l) bits. A sample with
  // fewer distinct vectors yields a smaller table.
  uint32_t entries = 4096;
  // Bits of the log-coded scale (6 .. 16); 12 bits over 40 octaves give a
  // relative error below 0.4 %.
  uint32_t scale_bits = 12;
  // Weight of the coverage block in the clustering distance (> 0). 1 gives
  // it the units of the normalized radiance blocks.
  float coverage_weight = 1.f;
  // Nodes brighter (larger scale) than this quantile of the sample's scales
  // are stored unquantized (raw), so the few very bright nodes (emitters)
  // stay exact. 1 = only nodes brighter than the whole sample.
  double bright_quantile = 0.9999;
  // The HDR rule (above): nodes at or above this quantile of the sample's
  // scales are stored raw when their normalized error exceeds
  // hdr_max_error. 1 disables the rule.
  double hdr_quantile = 0.99;
  float hdr_max_error = 0.1f;
  // The scale range spans at most this many octaves below the bright
  // threshold; dimmer nodes are coded with absolute error below its bottom.
  float max_range_octaves = 40.f;
  // Fraction of the scene's surfels the caller samples for the temporary
  // tree (paper: 1-10 % are safe, 0.1 % misses rare colours).
  double sample_fraction = 0.02;
  // At least this many surfels are sampled (or all of them), so small
  // scenes still learn a LUT from enough nodes.
  uint64_t min_sample_surfels = 20000;
  // And at least this many per LUT entry, so large tables get enough
  // distinct nodes to place their centres (k-means needs several points
  // per cluster; a sample tree has about 2 / leaf_size nodes per surfel).
  uint32_t min_surfels_per_entry = 16;
  KMeansOptions kmeans{};  // clusters is overridden by `entries`

  void validate() const;  // throws InvalidArgument naming the field
};

class QuantizedShTable {
 public:
  static constexpr size_t kDims = kNormalizedDims;

  QuantizedShTable(std::vector<float> entries, uint32_t scale_bits, float coverage_weight, float log2_scale_lo,
                   float log2_scale_hi, float hdr_log2_scale = std::numeric_limits<float>::infinity(),
                   float hdr_max_error = 0.f);

  size_t size() const { return entries_.size() / kDims; }
  uint32_t index_bits() const;
  uint32_t scale_bits() const { return scale_bits_; }
  float coverage_weight() const { return coverage_weight_; }
  float log2_scale_lo() const { return lo_; }
  float log2_scale_hi() const { return hi_; }
  const float* entry(uint32_t i) const { return &entries_[size_t(i) * kDims]; }
  const std::vector<float>& entries() const { return entries_; }
  LogScaleQuantizer scale_quantizer() const { return {scale_bits_, lo_, hi_}; }
  float hdr_log2_scale() const { return hdr_lo_; }
  float hdr_max_error() const { return hdr_err_; }
  // Whether a node of scale s falls under the HDR rule.
  bool is_hdr(float s) const { return s > 0.f && std::log2(s) >= hdr_lo_; }

  std::vector<uint8_t> serialize() const;
  // Throws CorruptionError (prefixed with `what`) for a bad magic, size,
  // checksum or field; VersionError for an unknown version.
  static QuantizedShTable deserialize(std::span<const uint8_t> bytes, const std::string& what);

 private:
  std::vector<float> entries_;
  uint32_t scale_bits_;
  float coverage_weight_;
  float lo_, hi_;
  float hdr_lo_, hdr_err_;
};

struct ShLutTraining {
  QuantizedShTable table;
  KMeansResult kmeans;          // objective history, timings
  uint64_t sample_nodes = 0;    // nodes given
  uint64_t clustered = 0;       // of which clustered (regular + dark)
  double seconds = 0;           // whole training
};

// Learns the LUT from the nodes of a sample tree. Throws InvalidArgument for
// invalid options or no usable node.
ShLutTraining train_sh_lut(std::span<const tree::Node> sample_nodes, const ShLutOptions& options);

// The random subset of `surfels` to build the sample tree over:
// max(min_sample_surfels, min_surfels_per_entry * entries,
//     sample_fraction * size) surfels (all if fewer),
// chosen uniformly without replacement, deterministic for a seed.
std::vector<Surfel> sample_surfels(std::span<const Surfel> surfels, const ShLutOptions& options,
                                   uint64_t seed = 1);

}  // namespace pbgi::storage
