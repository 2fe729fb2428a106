// Codec 0: payloads stored verbatim as little-endian float32, in the order
// radiance r[0..8], g[0..8], b[0..8], coverage[0..8] (144 bytes per node).
// Lossless; the reference the compressed codecs are measured against.
#pragma once

#include "storage/codecs/payload_codec.h"

namespace pbgi::storage {

class FloatShCodec final : public PayloadCodec {
 public:
  static constexpr size_t kFloatsPerNode = 3 * sh::kCoeffs + sh::kCoeffs;  // 36
  static constexpr size_t kBytesPerNode = kFloatsPerNode * sizeof(float);  // 144

  uint32_t id() const override { return static_cast<uint32_t>(CodecId::kFloatSh); }
  std::string name() const override { return "float32-sh"; }
  size_t bytes_per_node() const override { return kBytesPerNode; }
  void encode(std::span<const tree::Node> nodes, std::vector<uint8_t>& out) const override;
  uint32_t payload_bits(const tree::Node&) const override { return kBytesPerNode * 8; }
  void decode(std::span<const uint8_t> bytes, std::span<tree::Node> nodes,
              const std::string& what) const override;
};

}  // namespace pbgi::storage
