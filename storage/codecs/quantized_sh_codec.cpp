#include "storage/codecs/quantized_sh_codec.h"

#include "common/errors.h"
#include "storage/codecs/bit_packing.h"
#include "storage/codecs/float_sh_codec.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

namespace pbgi::storage {

namespace {

constexpr size_t D = kNormalizedDims;

std::vector<float> rotated_entries(const QuantizedShTable& t, const PcaBasis& b) {
  std::vector<float> out(t.size() * D);
  for (uint32_t i = 0; i < t.size(); ++i) b.rotate(t.entry(i), &out[size_t(i) * D]);
  return out;
}

}  // namespace

QuantizedShCodec::QuantizedShCodec(std::shared_ptr<const QuantizedShTable> table)
    : table_(table ? std::move(table) : throw InvalidArgument("QuantizedShCodec: no table")),
      index_bits_(table_->index_bits()),
      scale_(table_->scale_quantizer()),
      basis_(PcaBasis::fit(table_->entries(), D)),
      search_(rotated_entries(*table_, basis_), D) {}

NearestResult QuantizedShCodec::nearest(const float* v) const {
  float q[D];
  basis_.rotate(v, q);
  return search_.search(q);
}

QuantizedPayload QuantizedShCodec::quantize(const tree::Node& node, uint32_t hint) const {
  QuantizedPayload code;
  const NormalizedPayload p = normalize_payload(node, table_->coverage_weight());
  if (p.kind != PayloadKind::kRaw) {
    code.scale = p.kind == PayloadKind::kDark ? 0u : scale_.encode(p.scale);
  }
  if (p.kind == PayloadKind::kRaw || code.scale == scale_.escape_code()) {
    code.raw = true;
    code.scale = scale_.escape_code();
    code.index = 0;
    return code;
  }
  float q[D];
  basis_.rotate(p.v, q);
  const NearestResult near = search_.search(q, hint < search_.size() ? hint : NearestCentreTable::kNoHint);
  code.index = near.index;
  // The HDR rule (sh_lut.h): bright nodes the LUT represents badly stay raw.
  if (p.kind == PayloadKind::kRegular && table_->is_hdr(p.scale) && hdr_error_too_large(p.v, near.distance2)) {
    code.raw = true;
    code.scale = scale_.escape_code();
    code.index = 0;
  }
  return code;
}

bool QuantizedShCodec::hdr_error_too_large(const float* v, float distance2) const {
  double norm2 = 0;
  for (size_t k = 0; k < D; ++k) norm2 += double(v[k]) * v[k];
  const double tol = double(table_->hdr_max_error());
  return double(distance2) > tol * tol * norm2;
}

void QuantizedShCodec::dequantize(const QuantizedPayload& code, tree::Node& node) const {
  denormalize_payload(table_->entry(code.index), scale_.decode(code.scale), table_->coverage_weight(), node);
}

size_t QuantizedShCodec::encoded_bytes(size_t node_count, size_t raw_count) const {
  return packed_bytes(node_count, code_bits()) + raw_count * FloatShCodec::kBytesPerNode;
}

void QuantizedShCodec::encode_codes(std::span<const QuantizedPayload> codes, std::span<const tree::Node> nodes,
                                    std::vector<uint8_t>& out) const {
  if (codes.size() != nodes.size()) {
    throw InvalidArgument("QuantizedShCodec::encode_codes: " + std::to_string(codes.size()) + " codes for " +
                          std::to_string(nodes.size()) + " nodes");
  }
  out.reserve(out.size() + packed_bytes(codes.size(), code_bits()));
  BitWriter w(out);
  for (const QuantizedPayload& c : codes) {
    w.put(c.index, index_bits_);
    w.put(c.scale, scale_.bits());
  }
  w.finish();
  // Raw nodes verbatim, in node order, in the float32-sh layout.
  static const FloatShCodec raw_codec;
  for (size_t i = 0; i < codes.size(); ++i)
    if (codes[i].raw) raw_codec.encode(nodes.subspan(i, 1), out);
}

bool QuantizedShCodec::escapes(const tree::Node& node) const {
  const NormalizedPayload p = normalize_payload(node, table_->coverage_weight());
  if (p.kind == PayloadKind::kRaw) return true;
  if (p.kind == PayloadKind::kDark) return false;
  if (scale_.encode(p.scale) == scale_.escape_code()) return true;
  // Only HDR nodes (a small share) need the search to decide.
  return table_->is_hdr(p.scale) && quantize(node).raw;
}

uint32_t QuantizedShCodec::payload_bits(const tree::Node& node) const {
  return code_bits() + (escapes(node) ? uint32_t(FloatShCodec::kBytesPerNode * 8) : 0u);
}

void QuantizedShCodec::encode(std::span<const tree::Node> nodes, std::vector<uint8_t>& out) const {
  // The LUT search dominates a build that stores kmeans-sh payloads: run it
  // in parallel over chunks of the page. The search is exact, so a hint
  // changes only its speed and the codes do not depend on the chunking.
  std::vector<QuantizedPayload> codes(nodes.size());
  constexpr size_t kChunk = 64;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nodes.size(), kChunk), [&](const auto& range) {
    uint32_t hint = NearestCentreTable::kNoHint;
    for (size_t i = range.begin(); i < range.end(); ++i) {
      codes[i] = quantize(nodes[i], hint);
      if (!codes[i].raw) hint = codes[i].index;  // pre-order: the next node is often a child
    }
  });
  encode_codes(codes, nodes, out);
}

void QuantizedShCodec::decode(std::span<const uint8_t> bytes, std::span<tree::Node> nodes,
                              const std::string& what) const {
  const size_t code_bytes = packed_bytes(nodes.size(), code_bits());
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": kmeans-sh payload: " + msg); };
  if (bytes.size() < code_bytes) {
    throw corrupt(std::to_string(bytes.size()) + " bytes for " + std::to_string(nodes.size()) +
                  " nodes, need at least " + std::to_string(code_bytes));
  }
  // 1. Codes; count the raw nodes before touching their records.
  BitReader r(bytes.first(code_bytes));
  std::vector<QuantizedPayload> codes(nodes.size());
  size_t raw = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    codes[i].index = r.get(index_bits_);
    codes[i].scale = r.get(scale_.bits());
    codes[i].raw = codes[i].scale == scale_.escape_code();
    if (codes[i].raw) {
      ++raw;
    } else if (codes[i].index >= table_->size()) {
      throw corrupt("node " + std::to_string(i) + " has LUT index " + std::to_string(codes[i].index) +
                    " of a " + std::to_string(table_->size()) + "-entry table");
    }
  }
  if (bytes.size() != encoded_bytes(nodes.size(), raw)) {
    throw corrupt(std::to_string(bytes.size()) + " bytes for " + std::to_string(nodes.size()) + " nodes (" +
                  std::to_string(raw) + " raw), expected " + std::to_string(encoded_bytes(nodes.size(), raw)));
  }
  // 2. LUT look-ups and raw records.
  static const FloatShCodec raw_codec;
  size_t at = code_bytes;
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (codes[i].raw) {
      raw_codec.decode(bytes.subspan(at, FloatShCodec::kBytesPerNode), nodes.subspan(i, 1), what);
      at += FloatShCodec::kBytesPerNode;
    } else {
      dequantize(codes[i], nodes[i]);
    }
  }
}

}  // namespace pbgi::storage
