#include "storage/codecs/float_sh_codec.h"
#include "common/errors.h"
#include "storage/format/byte_order.h"

#include <gtest/gtest.h>

#include <random>

namespace pbgi::storage {
namespace {

std::vector<tree::Node> random_payloads(size_t n) {
  std::mt19937 rng(5);
  std::normal_distribution<float> g;
  std::vector<tree::Node> nodes(n);
  for (auto& node : nodes) {
    for (int i = 0; i < sh::kCoeffs; ++i) {
      node.radiance_sh.r[i] = g(rng);
      node.radiance_sh.g[i] = g(rng);
      node.radiance_sh.b[i] = g(rng);
      node.coverage_sh[i] = g(rng);
    }
  }
  return nodes;
}

TEST(FloatShCodec, LosslessRoundTrip) {
  const auto codec = make_payload_codec(static_cast<uint32_t>(CodecId::kFloatSh));
  EXPECT_EQ(codec->id(), 0u);
  EXPECT_EQ(codec->bytes_per_node(), 144u);
  const auto nodes = random_payloads(17);
  std::vector<uint8_t> bytes{0xAA};  // encode appends
  codec->encode(nodes, bytes);
  ASSERT_EQ(bytes.size(), 1 + 17 * 144u);
  EXPECT_EQ(bytes[0], 0xAA);
  // Layout: r, g, b, coverage of node 0 first.
  EXPECT_EQ(load_le<float>(bytes.data() + 1), nodes[0].radiance_sh.r[0]);
  EXPECT_EQ(load_le<float>(bytes.data() + 1 + 27 * 4), nodes[0].coverage_sh[0]);

  std::vector<tree::Node> back(17);
  codec->decode(std::span(bytes).subspan(1), back, "test");
  for (size_t i = 0; i < nodes.size(); ++i) {
    EXPECT_EQ(back[i].radiance_sh.r, nodes[i].radiance_sh.r);
    EXPECT_EQ(back[i].radiance_sh.g, nodes[i].radiance_sh.g);
    EXPECT_EQ(back[i].radiance_sh.b, nodes[i].radiance_sh.b);
    EXPECT_EQ(back[i].coverage_sh, nodes[i].coverage_sh);
  }
}

TEST(FloatShCodec, SizeMismatchIsCorruption) {
  const FloatShCodec codec;
  std::vector<uint8_t> bytes(144 * 2 + 3);
  std::vector<tree::Node> nodes(2);
  try {
    codec.decode(bytes, nodes, "pages.pbgp: page 9");
    FAIL();
  } catch (const CorruptionError& e) {
    EXPECT_NE(std::string(e.what()).find("page 9"), std::string::npos) << e.what();
  }
}

TEST(PayloadCodecs, UnknownIdIsVersionError) {
  EXPECT_THROW(make_payload_codec(77), VersionError);
}

}  // namespace
}  // namespace pbgi::storage
