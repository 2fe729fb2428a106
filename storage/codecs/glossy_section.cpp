#include "storage/codecs/glossy_section.h"

#include "common/errors.h"
#include "storage/codecs/cube_wavelet.h"
#include "storage/format/byte_stream.h"
#include "storage/format/checksum.h"

#include <Imath/half.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace pbgi::storage {

namespace {

constexpr uint8_t kHasDetail = 0x80;
constexpr uint8_t kFaceBits = 0x3f;

// One block: scale, bitmap of stored coefficients, halves of value / scale.
void put_block(ByteWriter& w, const float* v, size_t floats) {
  float scale = 0.f;
  for (size_t i = 0; i < floats; ++i) scale = std::max(scale, std::abs(v[i]));
  // A block of denormals (or NaN) is stored as zero: 1 / scale would
  // overflow, and such radiance is nothing anyone can see.
  if (!(scale >= std::numeric_limits<float>::min()) || !std::isfinite(scale)) scale = 0.f;
  w.put<float>(scale);
  std::vector<uint8_t> bitmap((floats + 7) / 8, 0);
  std::vector<Imath::half> kept;
  if (scale > 0.f) {
    for (size_t i = 0; i < floats; ++i) {
      const Imath::half h(std::isfinite(v[i]) ? v[i] / scale : 0.f);
      if (float(h) == 0.f) continue;  // zero at half precision: not stored
      bitmap[i / 8] |= uint8_t(1u << (i % 8));
      kept.push_back(h);
    }
  }
  w.put_bytes(bitmap);
  for (const Imath::half h : kept) w.put<uint16_t>(h.bits());
}

void get_block(ByteReader& r, float* out, size_t floats, const std::string& what) {
  const float scale = r.get<float>("glossy block scale");
  if (!std::isfinite(scale) || scale < 0.f) {
    throw CorruptionError(what + ": glossy radiance block scale " + std::to_string(scale));
  }
  const auto bitmap = r.get_bytes((floats + 7) / 8, "glossy block bitmap");
  for (size_t i = 0; i < floats; ++i) {
    if (!(bitmap[i / 8] >> (i % 8) & 1u)) {
      out[i] = 0.f;
      continue;
    }
    Imath::half h;
    h.setBits(r.get<uint16_t>("glossy coefficient"));
    const float v = float(h);
    if (!std::isfinite(v) || std::abs(v) > 1.f) {
      throw CorruptionError(what + ": glossy radiance coefficient " + std::to_string(v) + " outside [-1, 1]");
    }
    out[i] = v * scale;
  }
}

}  // namespace

std::vector<uint8_t> write_glossy_section(const WaveletTreeCode& code, uint32_t n) {
  const CubeLayout layout{n};
  layout.validate();
  const size_t bf = layout.face_floats();
  if (code.dims != layout.floats() || code.block_floats != bf || code.average_levels != 0 ||
      code.average_at.empty() || code.average_at[0] == WaveletTreeCode::kNone) {
    throw InvalidArgument("glossy section: the code is not a per-face cube map code with a root average");
  }
  std::vector<uint8_t> out;
  ByteWriter w(out);
  w.put<uint32_t>(kGlossySectionMagic);
  w.put<uint32_t>(kGlossySectionV1);
  w.put<uint32_t>(n);
  const size_t nodes = code.average_at.size();
  w.put<uint32_t>(static_cast<uint32_t>(nodes));
  w.put<float>(code.threshold);
  for (size_t i = 0; i < nodes; ++i) {
    w.put<uint8_t>(uint8_t((code.has_detail[i] ? kHasDetail : 0) | (code.detail_mask[i] & kFaceBits)));
  }
  const float* root = code.averages.data() + code.average_at[0];
  for (uint32_t f = 0; f < 6; ++f) put_block(w, root + f * bf, bf);
  for (size_t i = 0; i < nodes; ++i) {
    const float* h = code.details.data() + code.detail_at[i];
    for (uint32_t f = 0; f < 6; ++f) {
      if (!(code.detail_mask[i] >> f & 1u)) continue;
      put_block(w, h, bf);
      h += bf;
    }
  }
  w.put<uint64_t>(checksum64(out.data(), out.size()));
  return out;
}

WaveletTreeCode read_glossy_section(std::span<const uint8_t> bytes, const std::string& what, uint32_t& n) {
  auto corrupt = [&](const std::string& msg) { return CorruptionError(what + ": glossy radiance: " + msg); };
  ByteReader r(checked_body(bytes, 28, what + ": glossy radiance"), what);
  if (r.get<uint32_t>("magic") != kGlossySectionMagic) throw corrupt("bad magic");
  const uint32_t version = r.get<uint32_t>("version");
  if (version != kGlossySectionV1) {
    throw VersionError(what + ": glossy radiance section version " + std::to_string(version) +
                       " is not supported by this build");
  }
  n = r.get<uint32_t>("resolution");
  const CubeLayout layout{n};
  try {
    layout.validate();
  } catch (const InvalidArgument& e) {
    throw corrupt(e.what());
  }
  const size_t bf = layout.face_floats();
  const uint32_t nodes = r.get<uint32_t>("node_count");
  if (nodes == 0 || nodes > r.remaining()) throw corrupt("node count " + std::to_string(nodes));
  WaveletTreeCode c;
  c.dims = layout.floats();
  c.block_floats = static_cast<uint32_t>(bf);
  c.average_levels = 0;
  c.threshold = r.get<float>("threshold");
  c.average_at.assign(nodes, WaveletTreeCode::kNone);
  c.average_at[0] = 0;
  c.has_detail.assign(nodes, 0);
  c.detail_mask.assign(nodes, 0);
  c.detail_at.assign(nodes, 0);
  uint64_t kept = 0;
  for (uint32_t i = 0; i < nodes; ++i) {
    const uint8_t m = r.get<uint8_t>("node mask");
    if (m & ~(kHasDetail | kFaceBits)) throw corrupt("node " + std::to_string(i) + " mask " + std::to_string(m));
    c.has_detail[i] = (m & kHasDetail) ? 1 : 0;
    c.detail_mask[i] = m & kFaceBits;
    if (c.detail_mask[i] && !c.has_detail[i]) throw corrupt("node " + std::to_string(i) + " keeps details it has not");
    kept += uint64_t(std::popcount(c.detail_mask[i]));
  }
  // Each block takes at least its scale and bitmap: refuse counts the
  // bytes cannot hold before allocating.
  const uint64_t min_block = 4 + (bf + 7) / 8;
  if ((6 + kept) * min_block > r.remaining()) throw corrupt(std::to_string(kept) + " blocks do not fit");
  c.averages.resize(c.dims);
  for (uint32_t f = 0; f < 6; ++f) get_block(r, c.averages.data() + f * bf, bf, what);
  c.details.resize(kept * bf);
  uint64_t at = 0;
  for (uint32_t i = 0; i < nodes; ++i) {
    c.detail_at[i] = at;
    for (uint32_t f = 0; f < 6; ++f) {
      if (!(c.detail_mask[i] >> f & 1u)) continue;
      get_block(r, c.details.data() + at, bf, what);
      at += bf;
    }
  }
  r.expect_end();
  c.kept_blocks = kept;
  return c;
}

}  // namespace pbgi::storage
