#include "storage/codecs/codec_selection.h"
#include "common/errors.h"

#include <gtest/gtest.h>

namespace pbgi::storage {
namespace {

TEST(CodecSelection, DiffuseScenesNeverPayForWavelets) {
  const std::vector<float> rough(1000000, 1.f);
  const SceneMaterialStats s = scan_material_stats(rough, 0.3f);
  EXPECT_EQ(s.glossy_surfels, 0u);
  const CodecSelection c = select_payload_codecs(s, PayloadCodecPolicy::kAuto, {});
  EXPECT_EQ(c.diffuse, CodecId::kFloatSh);
  EXPECT_FALSE(c.node_payloads);  // derived: nothing stored per node
  EXPECT_FALSE(c.glossy_wavelets);
  EXPECT_NE(c.reason.find("no glossy"), std::string::npos);
}

TEST(CodecSelection, GlossySendersGetWavelets) {
  std::vector<float> rough(500000, 0.8f);
  for (size_t i = 0; i < rough.size(); i += 10) rough[i] = 0.1f;
  const SceneMaterialStats s = scan_material_stats(rough, 0.3f);
  EXPECT_EQ(s.glossy_surfels, 50000u);
  CodecSelectionOptions o;
  const CodecSelection c = select_payload_codecs(s, PayloadCodecPolicy::kAuto, o);
  EXPECT_TRUE(c.glossy_wavelets);
  EXPECT_EQ(c.cube_resolution, 16u);
  // A minimum glossy share above the scene's disables them.
  o.min_glossy_fraction = 0.2;
  EXPECT_FALSE(select_payload_codecs(s, PayloadCodecPolicy::kAuto, o).glossy_wavelets);
}

SceneMaterialStats big_scene() { return {10000000, 0}; }

TEST(CodecSelection, SmallScenesAndPoliciesKeepFloatSh) {
  SceneMaterialStats small{1000, 0};
  EXPECT_EQ(select_payload_codecs(small, PayloadCodecPolicy::kAuto, {}).diffuse, CodecId::kFloatSh);
  EXPECT_FALSE(select_payload_codecs(small, PayloadCodecPolicy::kAuto, {}).node_payloads);  // derived
  EXPECT_FALSE(select_payload_codecs(big_scene(), PayloadCodecPolicy::kAuto, {}).node_payloads);  // derived
  EXPECT_FALSE(select_payload_codecs(small, PayloadCodecPolicy::kDerived, {}).node_payloads);
  EXPECT_TRUE(select_payload_codecs(small, PayloadCodecPolicy::kFloatSh, {}).node_payloads);
  SceneMaterialStats big{10000000, 0};
  EXPECT_EQ(select_payload_codecs(big, PayloadCodecPolicy::kAuto, {}).diffuse, CodecId::kFloatSh);
  EXPECT_EQ(select_payload_codecs(big, PayloadCodecPolicy::kFloatSh, {}).diffuse, CodecId::kFloatSh);
  EXPECT_EQ(select_payload_codecs(small, PayloadCodecPolicy::kQuantizedSh, {}).diffuse, CodecId::kQuantizedSh);
  EXPECT_EQ(tree::parse_payload_codec("kmeans-sh"), PayloadCodecPolicy::kQuantizedSh);
  EXPECT_EQ(tree::parse_payload_codec("derived"), PayloadCodecPolicy::kDerived);
  EXPECT_EQ(tree::to_string(tree::parse_payload_codec("auto")), "auto");
  EXPECT_THROW(tree::parse_payload_codec("zip"), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::storage
