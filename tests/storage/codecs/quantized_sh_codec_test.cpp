#include "storage/codecs/quantized_sh_codec.h"
#include "common/errors.h"
#include "storage/codecs/bit_packing.h"
#include "storage/codecs/float_sh_codec.h"
#include "storage/format/checksum.h"
#include "tests/storage/codecs/node_payloads.h"

#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <cstring>
#include <random>

namespace pbgi::storage {
namespace {

constexpr size_t D = kNormalizedDims;

std::array<float, 36> flat(const tree::Node& n) {
  std::array<float, 36> v;
  for (int k = 0; k < 9; ++k) {
    v[k] = n.radiance_sh.r[k];
    v[9 + k] = n.radiance_sh.g[k];
    v[18 + k] = n.radiance_sh.b[k];
    v[27 + k] = n.coverage_sh[k];
  }
  return v;
}

bool same_bits(const tree::Node& a, const tree::Node& b) {
  const auto x = flat(a), y = flat(b);
  return std::memcmp(x.data(), y.data(), sizeof(x)) == 0;
}

// hdr_quantile 1: no HDR rule (sh_lut.h), so that errors are the plain
// nearest-centre distances; the rule has its own test.
ShLutTraining train(const std::vector<tree::Node>& sample, uint32_t entries, double bright_quantile = 0.9999,
                    double hdr_quantile = 1.0) {
  ShLutOptions o;
  o.entries = entries;
  o.bright_quantile = bright_quantile;
  o.hdr_quantile = hdr_quantile;
  return train_sh_lut(sample, o);
}

std::shared_ptr<const QuantizedShCodec> codec_of(const ShLutTraining& t) {
  return std::make_shared<const QuantizedShCodec>(std::make_shared<const QuantizedShTable>(t.table));
}

// Squared distance from v to the nearest LUT entry, by brute force in the
// input coordinates (no PCA, no pruning).
double nearest_entry_distance2(const QuantizedShTable& t, const float* v) {
  double best = INFINITY;
  for (uint32_t i = 0; i < t.size(); ++i) {
    double d = 0;
    for (size_t k = 0; k < D; ++k) d += double(v[k] - t.entry(i)[k]) * (v[k] - t.entry(i)[k]);
    best = std::min(best, d);
  }
  return best;
}

TEST(QuantizedSh, ErrorIsTheNearestCentreDistance) {
  const auto sample = test::payload_nodes(6000, 1);
  const auto training = train(sample, 512);
  const auto codec = codec_of(training);
  const QuantizedShTable& t = codec->table();
  EXPECT_LE(t.size(), 512u);
  EXPECT_EQ(codec->code_bits(), t.index_bits() + 12);
  const LogScaleQuantizer sq = t.scale_quantizer();
  const auto nodes = test::payload_nodes(2000, 2);  // not the training data
  size_t raw = 0;
  for (const tree::Node& n : nodes) {
    const QuantizedPayload q = codec->quantize(n);
    if (q.raw) {  // brighter than the sample's bright quantile
      ++raw;
      continue;
    }
    tree::Node back;
    codec->dequantize(q, back);
    // In the normalized domain the dequantized vector is the LUT entry
    // nearest to the node's vector: its error is the nearest distance.
    const NormalizedPayload p = normalize_payload(n, t.coverage_weight());
    const float* e = t.entry(q.index);
    double err2 = 0;
    for (size_t k = 0; k < D; ++k) err2 += double(e[k] - p.v[k]) * (e[k] - p.v[k]);
    const double best2 = nearest_entry_distance2(t, p.v);
    ASSERT_LE(err2, best2 * (1 + 1e-4) + 1e-10);
    // In radiance units: |rad' - rad| <= s (|e - v| + scale error |e|).
    const double s = p.scale, s_q = sq.decode(q.scale);
    EXPECT_LE(std::abs(s_q / s - 1), sq.max_relative_error() * 1.0001 + 1e-6);
    const auto a = flat(n), b = flat(back);
    double rad_err2 = 0, e_norm2 = 0;
    for (size_t k = 0; k < 27; ++k) {
      rad_err2 += double(a[k] - b[k]) * (a[k] - b[k]);
      e_norm2 += double(e[k]) * e[k];
    }
    const double bound = s * (std::sqrt(err2) + sq.max_relative_error() * 1.0001 * std::sqrt(e_norm2)) + 1e-6 * s;
    ASSERT_LE(std::sqrt(rad_err2), bound);
  }
  EXPECT_LT(raw, nodes.size() / 100);
}

TEST(QuantizedSh, PageRoundTripMatchesPerNodeDequantization) {
  auto nodes = test::payload_nodes(3000, 3);
  const auto training = train(nodes, 1024);
  const auto codec = codec_of(training);
  // Special nodes: dark, denormal, NaN, zero area, very bright.
  nodes[10].radiance_sh = {};                               // dark
  for (float& f : nodes[11].radiance_sh.r) f *= 1e-40f;     // denormal radiance
  nodes[11].radiance_sh.g = nodes[11].radiance_sh.b = nodes[11].radiance_sh.r;
  nodes[12].radiance_sh.g[4] = std::nanf("");              // NaN
  nodes[13].coverage_sh = {};                              // no coverage
  nodes[13].radiance_sh = {};
  for (int c = 0; c < 9; ++c) nodes[14].radiance_sh.r[c] *= 1e9f;  // far above the range
  nodes[14].radiance_sh.g = nodes[14].radiance_sh.b = nodes[14].radiance_sh.r;

  std::vector<uint8_t> bytes{1, 2, 3};
  codec->encode(nodes, bytes);
  size_t raw = 0;
  for (const auto& n : nodes) raw += codec->quantize(n).raw;
  for (int i : {12, 13, 14}) EXPECT_TRUE(codec->quantize(nodes[i]).raw);  // NaN, no coverage, too bright
  for (int i : {10, 11}) EXPECT_FALSE(codec->quantize(nodes[i]).raw);    // dark, denormal
  EXPECT_LT(raw, 3 + nodes.size() / 100);
  ASSERT_EQ(bytes.size(), 3 + packed_bytes(nodes.size(), codec->code_bits()) + raw * 144);

  std::vector<tree::Node> back(nodes.size());
  codec->decode(std::span(bytes).subspan(3), back, "page 4");
  for (size_t i = 0; i < nodes.size(); ++i) {
    const QuantizedPayload q = codec->quantize(nodes[i]);
    tree::Node expect;
    if (q.raw) {
      expect = nodes[i];  // raw nodes are stored verbatim
    } else {
      codec->dequantize(q, expect);
    }
    ASSERT_TRUE(same_bits(back[i], expect)) << "node " << i;
  }
  // Dark and denormal nodes decode to exactly zero radiance, with coverage.
  for (int i : {10, 11}) {
    const auto v = flat(back[i]);
    for (size_t k = 0; k < 27; ++k) EXPECT_EQ(v[k], 0.f) << i;
    EXPECT_NEAR(back[i].coverage_sh[0], nodes[i].coverage_sh[0], 1e-3f);
  }
  EXPECT_TRUE(std::isnan(back[12].radiance_sh.g[4]));
  EXPECT_EQ(back[14].radiance_sh.r[0], nodes[14].radiance_sh.r[0]);

  // Damaged sizes and indices are corruption naming the page.
  std::vector<uint8_t> cut(bytes.begin() + 3, bytes.end() - 1);
  EXPECT_THROW(codec->decode(cut, back, "page 4"), CorruptionError);
  try {
    codec->decode(std::span(bytes).subspan(3, 5), back, "page 4");
    FAIL();
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find("page 4"), std::string::npos);
  }
}

TEST(QuantizedSh, IndexOutsideTheTableIsCorruption) {
  // A 200-entry table uses 8-bit indices: 255 is representable but invalid.
  std::mt19937 rng(1);
  std::normal_distribution<float> g;
  std::vector<float> entries(200 * D);
  for (auto& e : entries) e = g(rng);
  const QuantizedShCodec codec(std::make_shared<const QuantizedShTable>(entries, 12, 1.f, -10.f, 10.f));
  std::vector<uint8_t> bytes;
  BitWriter w(bytes);
  w.put(255, 8);
  w.put(100, 12);
  w.finish();
  std::vector<tree::Node> one(1);
  EXPECT_THROW(codec.decode(bytes, one, "p"), CorruptionError);
}

TEST(QuantizedSh, EveryIndexWidthRoundTrips) {
  // Tables of 2^7 .. 2^16 entries (normalized vectors of synthetic nodes):
  // codes of 7 .. 16 index bits.
  std::mt19937 rng(9);
  const auto nodes = test::payload_nodes(200, 4);
  std::vector<float> pool;
  for (uint32_t i = 0; i < (1u << 16); ++i) {
    const NormalizedPayload p = normalize_payload(test::payload_node(rng), 1.f);
    pool.insert(pool.end(), p.v, p.v + D);
  }
  for (uint32_t bits = 7; bits <= 16; ++bits) {
    const size_t l = size_t(1) << bits;
    std::vector<float> entries(pool.begin(), pool.begin() + l * D);
    const QuantizedShCodec codec(std::make_shared<const QuantizedShTable>(entries, 10, 1.f, -10.f, 10.f));
    ASSERT_EQ(codec.table().index_bits(), bits);
    std::vector<uint8_t> bytes;
    codec.encode(nodes, bytes);
    EXPECT_EQ(bytes.size(), packed_bytes(nodes.size(), bits + 10));
    std::vector<tree::Node> back(nodes.size());
    codec.decode(bytes, back, "p");
    for (size_t i = 0; i < nodes.size(); ++i) {
      tree::Node expect;
      codec.dequantize(codec.quantize(nodes[i]), expect);
      ASSERT_TRUE(same_bits(back[i], expect)) << bits << " " << i;
    }
  }
}

// HDR: emitters 10^6 times brighter than the dim surfaces around them.
// Quantization happens in the normalized domain, so a node and the same node
// 10^6 times brighter get the same LUT entry and the same relative error
// (up to the scale code's rounding); nodes above the bright quantile are
// stored exactly.
TEST(QuantizedSh, HdrKeepsRelativeErrorBounded) {
  std::mt19937 rng(5);
  std::vector<tree::Node> sample;
  for (int i = 0; i < 4000; ++i) sample.push_back(test::payload_node(rng, 0.01f + 0.1f * float(i % 10)));
  for (int i = 0; i < 40; ++i) sample.push_back(test::payload_node(rng, 1e5f));  // emitters
  std::vector<tree::Node> dim, bright;
  for (int i = 0; i < 300; ++i) {
    dim.push_back(test::payload_node(rng, 0.05f));
    bright.push_back(dim.back());
    for (auto* c : {&bright.back().radiance_sh.r, &bright.back().radiance_sh.g, &bright.back().radiance_sh.b})
      for (float& f : *c) f *= 1e6f;
  }
  auto rel_err = [](const tree::Node& a, const tree::Node& b) {
    const auto x = flat(a), y = flat(b);
    double e = 0, n = 0;
    for (size_t k = 0; k < 27; ++k) {
      e += double(x[k] - y[k]) * (x[k] - y[k]);
      n += double(x[k]) * x[k];
    }
    return std::sqrt(e / n);
  };
  {
    const auto training = train(sample, 256, 1.0);  // escape only above the sample's max
    const auto codec = codec_of(training);
    const double scale_err = training.table.scale_quantizer().max_relative_error();
    double mean_dim = 0, mean_bright = 0;
    for (size_t i = 0; i < dim.size(); ++i) {
      const QuantizedPayload qd = codec->quantize(dim[i]), qb = codec->quantize(bright[i]);
      ASSERT_FALSE(qd.raw);
      ASSERT_FALSE(qb.raw);
      EXPECT_EQ(qd.index, qb.index);
      tree::Node bd, bb;
      codec->dequantize(qd, bd);
      codec->dequantize(qb, bb);
      const double ed = rel_err(dim[i], bd), eb = rel_err(bright[i], bb);
      EXPECT_NEAR(eb, ed, 2.5 * scale_err + 1e-5) << i;
      mean_dim += ed / double(dim.size());
      mean_bright += eb / double(dim.size());
    }
    EXPECT_LT(mean_bright, 0.3);
    EXPECT_NEAR(mean_bright, mean_dim, 2.5 * scale_err);
  }
  {
    const auto training = train(sample, 256, 0.99);  // the emitters' share
    const auto codec = codec_of(training);
    std::vector<uint8_t> bytes;
    codec->encode(bright, bytes);
    std::vector<tree::Node> back(bright.size());
    codec->decode(bytes, back, "p");
    for (size_t i = 0; i < bright.size(); ++i) {
      EXPECT_TRUE(codec->quantize(bright[i]).raw);
      EXPECT_TRUE(same_bits(back[i], bright[i]));  // stored exactly
    }
  }
}

// The HDR rule: bright nodes (top 1 % of scales) whose normalized error
// would exceed hdr_max_error are stored raw (exactly); every bright node
// that stays quantized is within it; dim nodes are never escaped by it.
TEST(QuantizedSh, HdrRuleBoundsTheErrorOfBrightNodes) {
  std::mt19937 rng(9);
  std::vector<tree::Node> sample;
  for (int i = 0; i < 4000; ++i) sample.push_back(test::payload_node(rng, 0.01f + 0.1f * float(i % 10)));
  for (int i = 0; i < 60; ++i) sample.push_back(test::payload_node(rng, 3e4f));  // emitters, odd colours
  const auto training = train(sample, 128, 0.9999, 0.99);
  const QuantizedShTable& t = training.table;
  ASSERT_TRUE(std::isfinite(t.hdr_log2_scale()));
  const auto codec = codec_of(training);
  size_t hdr = 0, escaped = 0;
  for (const tree::Node& n : sample) {
    const NormalizedPayload p = normalize_payload(n, t.coverage_weight());
    ASSERT_EQ(p.kind, PayloadKind::kRegular);
    const QuantizedPayload q = codec->quantize(n);
    EXPECT_EQ(codec->escapes(n), q.raw);  // the cheap sizing check agrees
    if (!t.is_hdr(p.scale)) {
      if (p.scale < 1.f) {
        EXPECT_FALSE(q.raw);
      }
      continue;
    }
    ++hdr;
    if (q.raw) {
      ++escaped;
      continue;
    }
    double norm2 = 0;
    for (size_t k = 0; k < D; ++k) norm2 += double(p.v[k]) * p.v[k];
    EXPECT_LE(nearest_entry_distance2(t, p.v), 0.01 * norm2 * (1 + 1e-5));
  }
  EXPECT_GE(hdr, 40u);
  EXPECT_GT(escaped, 0u);  // this sample needs the rule
  // Raw nodes decode bit for bit.
  std::vector<uint8_t> bytes;
  codec->encode(sample, bytes);
  std::vector<tree::Node> back(sample.size());
  codec->decode(bytes, back, "p");
  for (size_t i = 0; i < sample.size(); ++i) {
    if (codec->quantize(sample[i]).raw) {
      EXPECT_TRUE(same_bits(back[i], sample[i])) << i;
    }
  }
}

TEST(QuantizedShTable, SerializationRoundTripAndDamage) {
  const auto training = train(test::payload_nodes(3000, 7), 256, 0.9999, 0.99);
  const std::vector<uint8_t> bytes = training.table.serialize();
  ASSERT_EQ(bytes.size(), 40 + training.table.size() * 144 + 8);  // V2 header
  const QuantizedShTable back = QuantizedShTable::deserialize(bytes, "lut");
  EXPECT_EQ(back.entries(), training.table.entries());
  EXPECT_EQ(back.scale_bits(), training.table.scale_bits());
  EXPECT_EQ(back.log2_scale_lo(), training.table.log2_scale_lo());
  EXPECT_EQ(back.log2_scale_hi(), training.table.log2_scale_hi());
  EXPECT_EQ(back.hdr_log2_scale(), training.table.hdr_log2_scale());
  EXPECT_EQ(back.hdr_max_error(), training.table.hdr_max_error());
  EXPECT_TRUE(std::isfinite(back.hdr_log2_scale()));
  // Registry: codec 1 built from its state.
  const auto codec = make_payload_codec(uint32_t(CodecId::kQuantizedSh), bytes, "m");
  EXPECT_EQ(codec->name(), "kmeans-sh");
  EXPECT_THROW(make_payload_codec(uint32_t(CodecId::kQuantizedSh)), InvalidArgument);
  EXPECT_TRUE(codec_needs_state(1));
  EXPECT_FALSE(codec_needs_state(0));

  auto damaged = bytes;
  damaged[100] ^= 1;
  try {
    QuantizedShTable::deserialize(damaged, "/x/manifest.pbgm");
    FAIL();
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/x/manifest.pbgm"), std::string::npos);
  }
  // A V1 table (no HDR fields) is still read, without the HDR rule.
  std::vector<uint8_t> v1(bytes.begin(), bytes.begin() + 32);
  v1.insert(v1.end(), bytes.begin() + 40, bytes.end() - 8);
  v1[4] = 1;
  const uint64_t sum = checksum64(v1.data(), v1.size());
  for (int k = 0; k < 8; ++k) v1.push_back(uint8_t(sum >> (8 * k)));
  const QuantizedShTable old = QuantizedShTable::deserialize(v1, "lut");
  EXPECT_EQ(old.entries(), training.table.entries());
  EXPECT_FALSE(old.is_hdr(1e30f));
  auto newer = bytes;
  newer[4] = 3;
  EXPECT_THROW(QuantizedShTable::deserialize(newer, "lut"), VersionError);
  EXPECT_THROW(QuantizedShTable::deserialize(std::span(bytes).first(bytes.size() - 1), "lut"), CorruptionError);
}

TEST(QuantizedSh, TrainingOnFewDistinctNodesGivesASmallTable) {
  std::mt19937 rng(3);
  std::vector<tree::Node> sample;
  const tree::Node a = test::payload_node(rng), b = test::payload_node(rng);
  for (int i = 0; i < 500; ++i) sample.push_back(i % 2 ? a : b);
  const auto training = train(sample, 128);
  EXPECT_EQ(training.table.size(), 2u);
  EXPECT_EQ(training.table.index_bits(), 1u);
  const auto codec = codec_of(training);
  tree::Node back;
  codec->dequantize(codec->quantize(a), back);
  EXPECT_NEAR(back.radiance_sh.r[0], a.radiance_sh.r[0], 1e-2f * std::abs(a.radiance_sh.r[0]));
}

TEST(LogScaleQuantizer, CodesAndBounds) {
  const LogScaleQuantizer q(12, -20.f, 20.f);
  EXPECT_EQ(q.encode(0.f), 0u);
  EXPECT_EQ(q.encode(-1.f), 0u);
  EXPECT_EQ(q.encode(std::nanf("")), 0u);
  EXPECT_EQ(q.encode(1e30f), q.escape_code());
  EXPECT_EQ(q.decode(0), 0.f);
  EXPECT_LT(q.max_relative_error(), 0.004);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-20.f, 20.f);
  for (int i = 0; i < 10000; ++i) {
    const float s = std::exp2(u(rng));
    const uint32_t c = q.encode(s);
    ASSERT_GT(c, 0u);
    ASSERT_LT(c, q.escape_code());
    ASSERT_LE(std::abs(q.decode(c) / s - 1.f), q.max_relative_error() * 1.001);
  }
  // Below the range: absolute error under 2^lo.
  EXPECT_LE(q.decode(q.encode(std::exp2(-20.5f))), std::exp2(-20.f) * 1.0001f);
  EXPECT_THROW(LogScaleQuantizer(3, 0.f, 1.f), InvalidArgument);
  EXPECT_THROW(LogScaleQuantizer(12, 1.f, 1.f), InvalidArgument);
}

TEST(SampleSurfels, FractionAndDeterminism) {
  std::vector<Surfel> s(100000);
  for (size_t i = 0; i < s.size(); ++i) s[i].radius = float(i);
  ShLutOptions o;
  o.sample_fraction = 0.03;
  o.min_sample_surfels = 100;
  o.entries = 128;  // 16 surfels per entry: 2048 < 3 %
  const auto a = sample_surfels(s, o, 4), b = sample_surfels(s, o, 4);
  ASSERT_EQ(a.size(), 3000u);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].radius, b[i].radius);
  for (size_t i = 1; i < a.size(); ++i) EXPECT_LT(a[i - 1].radius, a[i].radius);  // order kept, no repeats
  EXPECT_GT(a.back().radius, 90000.f);  // spread over the whole input
  o.min_sample_surfels = 200000;
  EXPECT_EQ(sample_surfels(s, o).size(), s.size());
}

}  // namespace
}  // namespace pbgi::storage
