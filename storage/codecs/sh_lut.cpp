#include "storage/codecs/sh_lut.h"

#include "common/errors.h"
#include "storage/codecs/bit_packing.h"
#include "storage/format/byte_stream.h"
#include "storage/format/checksum.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <string>

namespace pbgi::storage {

namespace {
constexpr size_t kHeaderBytes = 32;
constexpr size_t kTrailerBytes = 8;
}  // namespace

void ShLutOptions::validate() const {
  if (entries < kMinEntries || entries > kMaxEntries) {
    throw InvalidArgument("codec.lut_entries = " + std::to_string(entries) + ": must be in [" +
                          std::to_string(kMinEntries) + ", " + std::to_string(kMaxEntries) + "]");
  }
  if (scale_bits < 6 || scale_bits > 16) {
    throw InvalidArgument("codec.scale_bits = " + std::to_string(scale_bits) + ": must be in [6, 16]");
  }
  if (!(coverage_weight > 0.f) || !std::isfinite(coverage_weight)) {
    throw InvalidArgument("codec.coverage_weight = " + std::to_string(coverage_weight) + ": must be > 0");
  }
  if (!(bright_quantile > 0.5 && bright_quantile <= 1.0)) {
    throw InvalidArgument("codec.bright_quantile = " + std::to_string(bright_quantile) + ": must be in (0.5, 1]");
  }
  if (!(max_range_octaves >= 4.f && max_range_octaves <= 120.f)) {
    throw InvalidArgument("codec.max_range_octaves = " + std::to_string(max_range_octaves) +
                          ": must be in [4, 120]");
  }
  if (!(hdr_quantile > 0.5 && hdr_quantile <= 1.0)) {
    throw InvalidArgument("codec.hdr_quantile = " + std::to_string(hdr_quantile) + ": must be in (0.5, 1]");
  }
  if (!(hdr_max_error >= 0.f) || !std::isfinite(hdr_max_error)) {
    throw InvalidArgument("codec.hdr_max_error = " + std::to_string(hdr_max_error) + ": must be >= 0");
  }
  if (!(sample_fraction > 0.0 && sample_fraction <= 1.0)) {
    throw InvalidArgument("codec.sample_fraction = " + std::to_string(sample_fraction) + ": must be in (0, 1]");
  }
  kmeans.validate();
}

QuantizedShTable::QuantizedShTable(std::vector<float> entries, uint32_t scale_bits, float coverage_weight,
                                   float lo, float hi, float hdr_lo, float hdr_err)
    : entries_(std::move(entries)),
      scale_bits_(scale_bits),
      coverage_weight_(coverage_weight),
      lo_(lo),
      hi_(hi),
      hdr_lo_(hdr_lo),
      hdr_err_(hdr_err) {
  if (std::isnan(hdr_lo) || !(hdr_err >= 0.f) || !std::isfinite(hdr_err)) {
    throw InvalidArgument("quantized SH table: HDR rule (" + std::to_string(hdr_lo) + ", " +
                          std::to_string(hdr_err) + ")");
  }
  const size_t l = entries_.size() / kDims;
  if (l == 0 || entries_.size() % kDims != 0 || l > ShLutOptions::kMaxEntries) {
    throw InvalidArgument("quantized SH table: " + std::to_string(entries_.size()) +
                          " floats is not 1 to 65536 entries of 36 floats");
  }
  for (float f : entries_)
    if (!std::isfinite(f)) throw InvalidArgument("quantized SH table: non-finite entry");
  if (!(coverage_weight > 0.f) || !std::isfinite(coverage_weight)) {
    throw InvalidArgument("quantized SH table: coverage weight " + std::to_string(coverage_weight));
  }
  (void)LogScaleQuantizer(scale_bits, lo, hi);  // validates bits and range
}

uint32_t QuantizedShTable::index_bits() const { return bits_for_count(size()); }

std::vector<uint8_t> QuantizedShTable::serialize() const {
  std::vector<uint8_t> out;
  out.reserve(kHeaderBytes + entries_.size() * 4 + kTrailerBytes);
  ByteWriter w(out);
  w.put<uint32_t>(kShLutMagic);
  w.put<uint32_t>(kShLutFormatV2);
  w.put<uint32_t>(uint32_t(kDims));
  w.put<uint32_t>(uint32_t(size()));
  w.put<uint32_t>(scale_bits_);
  w.put<float>(coverage_weight_);
  w.put<float>(lo_);
  w.put<float>(hi_);
  w.put<float>(hdr_lo_);
  w.put<float>(hdr_err_);
  for (float f : entries_) w.put<float>(f);
  w.put<uint64_t>(checksum64(out.data(), out.size()));
  return out;
}

QuantizedShTable QuantizedShTable::deserialize(std::span<const uint8_t> bytes, const std::string& what) {
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": SH LUT: " + msg); };
  if (bytes.size() < kHeaderBytes + kTrailerBytes) {
    throw corrupt(std::to_string(bytes.size()) + " bytes, need at least " +
                  std::to_string(kHeaderBytes + kTrailerBytes));
  }
  ByteReader r(bytes, what);
  if (r.get<uint32_t>("lut magic") != kShLutMagic) throw corrupt("bad magic");
  const uint32_t version = r.get<uint32_t>("lut version");
  if (version != kShLutFormatV1 && version != kShLutFormatV2) {
    throw VersionError(what + ": SH LUT format version " + std::to_string(version) +
                       " is not supported by this build");
  }
  const uint32_t dims = r.get<uint32_t>("lut dims");
  const uint32_t count = r.get<uint32_t>("lut entry_count");
  if (dims != kDims) throw corrupt("dims " + std::to_string(dims) + ", expected 36");
  if (count == 0 || count > ShLutOptions::kMaxEntries) throw corrupt("entry count " + std::to_string(count));
  const size_t header = version == kShLutFormatV1 ? kHeaderBytes : kHeaderBytes + 8;
  const size_t need = header + size_t(count) * kDims * 4 + kTrailerBytes;
  if (bytes.size() != need) {
    throw corrupt(std::to_string(bytes.size()) + " bytes for " + std::to_string(count) + " entries, expected " +
                  std::to_string(need));
  }
  const uint64_t stored = load_le<uint64_t>(bytes.data() + need - kTrailerBytes);
  const uint64_t found = checksum64(bytes.data(), need - kTrailerBytes);
  if (stored != found) {
    throw corrupt("checksum mismatch at offset " + std::to_string(need - kTrailerBytes) + ": expected " +
                  checksum_hex(stored) + ", found " + checksum_hex(found));
  }
  const uint32_t scale_bits = r.get<uint32_t>("lut scale_bits");
  const float weight = r.get<float>("lut coverage_weight");
  const float lo = r.get<float>("lut log2_scale_lo");
  const float hi = r.get<float>("lut log2_scale_hi");
  float hdr_lo = std::numeric_limits<float>::infinity(), hdr_err = 0.f;
  if (version >= kShLutFormatV2) {
    hdr_lo = r.get<float>("lut hdr_log2_scale");
    hdr_err = r.get<float>("lut hdr_max_error");
  }
  std::vector<float> entries(size_t(count) * kDims);
  for (float& f : entries) f = r.get<float>("lut entry");
  try {
    return QuantizedShTable(std::move(entries), scale_bits, weight, lo, hi, hdr_lo, hdr_err);
  } catch (const InvalidArgument& e) {
    throw corrupt(e.what());
  }
}

ShLutTraining train_sh_lut(std::span<const tree::Node> nodes, const ShLutOptions& options) {
  options.validate();
  const auto t0 = std::chrono::steady_clock::now();
  // 1. Normalized vectors of the sample's nodes; scales of the lit ones.
  std::vector<float> vectors;
  std::vector<float> scales;
  vectors.reserve(nodes.size() * kNormalizedDims);
  for (const tree::Node& n : nodes) {
    const NormalizedPayload p = normalize_payload(n, options.coverage_weight);
    if (p.kind == PayloadKind::kRaw) continue;
    vectors.insert(vectors.end(), p.v, p.v + kNormalizedDims);
    if (p.kind == PayloadKind::kRegular) scales.push_back(p.scale);
  }
  if (vectors.empty()) {
    throw InvalidArgument("train_sh_lut: none of the " + std::to_string(nodes.size()) +
                          " sample nodes has a usable payload");
  }

  // 2. Scale range: up to the bright quantile, down to the dimmest node
  //    (at most max_range_octaves below).
  float lo = -1.f, hi = 0.f;
  float hdr_lo = std::numeric_limits<float>::infinity();
  if (!scales.empty()) {
    std::sort(scales.begin(), scales.end());
    const double q = options.bright_quantile;
    const float bright = q >= 1.0 ? scales.back() : scales[size_t(q * double(scales.size() - 1))];
    hi = float(std::log2(double(bright)));
    lo = std::max(float(std::floor(std::log2(double(scales.front())))) - 1.f, hi - options.max_range_octaves);
    if (!(hi - lo >= 1.f)) lo = hi - 1.f;
    if (options.hdr_quantile < 1.0) {
      hdr_lo = float(std::log2(double(scales[size_t(options.hdr_quantile * double(scales.size() - 1))])));
    }
  }

  // 3. k-means on the vectors.
  KMeansOptions km = options.kmeans;
  km.clusters = options.entries;
  KMeansResult result = kmeans(vectors, kNormalizedDims, km);
  const uint64_t clustered = vectors.size() / kNormalizedDims;
  QuantizedShTable table(result.centres, options.scale_bits, options.coverage_weight, lo, hi, hdr_lo,
                         options.hdr_max_error);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ShLutTraining{std::move(table), std::move(result), nodes.size(), clustered, seconds};
}

std::vector<Surfel> sample_surfels(std::span<const Surfel> surfels, const ShLutOptions& options, uint64_t seed) {
  const uint64_t n = surfels.size();
  const uint64_t want = std::min<uint64_t>(
      n, std::max({options.min_sample_surfels, uint64_t(options.min_surfels_per_entry) * options.entries,
                   uint64_t(std::ceil(options.sample_fraction * double(n)))}));
  std::vector<Surfel> out;
  out.reserve(want);
  if (want == n) {
    out.assign(surfels.begin(), surfels.end());
    return out;
  }
  // Selection sampling (Knuth, TAOCP 3.4.2, algorithm S): one pass, uniform
  // without replacement, input order kept.
  std::mt19937_64 rng(seed);
  uint64_t needed = want;
  for (uint64_t i = 0; i < n && needed > 0; ++i) {
    const double u = double(rng() >> 11) * 0x1.0p-53;
    if (double(n - i) * u < double(needed)) {
      out.push_back(surfels[i]);
      --needed;
    }
  }
  return out;
}

}  // namespace pbgi::storage
