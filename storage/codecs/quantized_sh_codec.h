// Codec 1 (`kmeans-sh`): SH payloads quantized over a LUT learned by k-means
// (Buchholz & Boubekeur 2012), in the normalized domain of
// storage/codecs/sh_normalization.h.
//
// Per node a fixed-width code of index_bits + scale_bits bits:
//   index  ceil(log2 l) bits  nearest LUT entry to the normalized vector
//   scale  scale_bits bits    LogScaleQuantizer code; the escape code marks
//                             a raw node (too bright, unusual, see
//                             sh_normalization.h, or an HDR node the LUT
//                             represents badly, see sh_lut.h), whose index
//                             bits are 0
// Page payload layout:
//   codes      packed_bytes(N, index_bits + scale_bits) bytes, LSB-first
//              (storage/codecs/bit_packing.h), node order, zero-padded
//   raw nodes  E x 144 bytes: float32 r[9] g[9] b[9] coverage[9] of each
//              escaped node, in node order (E = number of escape codes)
//
// Quantization is exact nearest-centre search (NearestCentreTable over the
// LUT in its own PCA basis), so the dequantized normalized vector is the
// LUT entry nearest to the node's: the error is the nearest-centre distance
// (or zero, for a node stored raw).
//
// Thread-safety: immutable after construction; every method is const and
// may run concurrently.
#pragma once

#include "storage/codecs/nearest_centre.h"
#include "storage/codecs/payload_codec.h"
#include "storage/codecs/pca_basis.h"
#include "storage/codecs/sh_lut.h"

#include <memory>

namespace pbgi::storage {

// The code of one node; `raw` holds the payload of escaped nodes.
struct QuantizedPayload {
  uint32_t index = 0;
  uint32_t scale = 0;
  bool raw = false;  // escaped: stored unquantized
};

class QuantizedShCodec final : public PayloadCodec {
 public:
  explicit QuantizedShCodec(std::shared_ptr<const QuantizedShTable> table);

  uint32_t id() const override { return static_cast<uint32_t>(CodecId::kQuantizedSh); }
  std::string name() const override { return "kmeans-sh"; }
  // 0: the size depends on how many nodes are stored raw.
  size_t bytes_per_node() const override { return 0; }
  void encode(std::span<const tree::Node> nodes, std::vector<uint8_t>& out) const override;
  // code_bits(), plus 144 bytes if the node escapes (is stored raw).
  uint32_t payload_bits(const tree::Node& node) const override;
  // Whether quantize(node) stores it raw; no LUT search.
  bool escapes(const tree::Node& node) const;
  std::vector<uint8_t> state() const override { return table_->serialize(); }
  void decode(std::span<const uint8_t> bytes, std::span<tree::Node> nodes,
              const std::string& what) const override;

  // The streaming build's steps: quantize one node's payload (`hint`: a LUT
  // index likely near, e.g. a sibling's), and write the dequantized payload
  // of a code into a node. dequantize(quantize(n)) is what a reader decodes.
  QuantizedPayload quantize(const tree::Node& node, uint32_t hint = NearestCentreTable::kNoHint) const;
  void dequantize(const QuantizedPayload& code, tree::Node& node) const;
  // Payload bytes of a page of `node_count` nodes, `raw_count` of them raw.
  size_t encoded_bytes(size_t node_count, size_t raw_count) const;
  // Appends a page payload from precomputed codes; raw nodes take their
  // payload from nodes[i] (the unquantized node).
  void encode_codes(std::span<const QuantizedPayload> codes, std::span<const tree::Node> nodes,
                    std::vector<uint8_t>& out) const;

  uint32_t code_bits() const { return index_bits_ + scale_.bits(); }
  const QuantizedShTable& table() const { return *table_; }
  // The normalized-domain nearest entry (for tests and statistics).
  NearestResult nearest(const float* normalized) const;

 private:
  bool hdr_error_too_large(const float* normalized, float distance2) const;

  std::shared_ptr<const QuantizedShTable> table_;
  uint32_t index_bits_;
  LogScaleQuantizer scale_;
  PcaBasis basis_;
  NearestCentreTable search_;
};

}  // namespace pbgi::storage
