// Build keys: every option that changes the stored bytes changes the key;
// the defaults keep the key they had before payload codecs were options.
#include "server/engine/build_key.h"
#include "tests/support/perturbed_option.h"

#include <gtest/gtest.h>

namespace pbgi {
namespace {

TEST(BuildKey, PayloadCodecAndLutOptionsChangeTheKey) {
  const OpenOptions base;
  const std::string k = page_set_build_key("scene", base);
  EXPECT_EQ(k, page_set_build_key("scene", base));
  EXPECT_NE(k, page_set_build_key("other", base));

  OpenOptions o = base;
  o.tree.lut_entries = 100;  // no LUT with derived payloads: same bytes, same key
  EXPECT_EQ(page_set_build_key("scene", o), k);
  o.tree.payload_codec = tree::PayloadCodecOption::kFloatSh;
  const std::string float_key = page_set_build_key("scene", o);
  EXPECT_NE(float_key, k);
  o.tree.payload_codec = tree::PayloadCodecOption::kQuantizedSh;
  const std::string kmeans_100 = page_set_build_key("scene", o);
  EXPECT_NE(kmeans_100, float_key);
  o.tree.lut_entries = 1000;
  EXPECT_NE(page_set_build_key("scene", o), kmeans_100);
  o.tree.lut_entries = 100;
  o.tree.lut_sample_fraction = 0.1;
  EXPECT_NE(page_set_build_key("scene", o), kmeans_100);
  o.tree.payload_codec = tree::PayloadCodecOption::kAuto;
  EXPECT_NE(page_set_build_key("scene", o), kmeans_100);
}

TEST(BuildKey, BounceCountAndBounceGatherChangeTheKey) {
  OpenOptions a;
  OpenOptions b = a;
  b.bounce.bounces = 2;
  EXPECT_NE(page_set_build_key("h", a), page_set_build_key("h", b));
  OpenOptions c = b;
  c.bounce.gather.microbuffer_resolution = 16;
  EXPECT_NE(page_set_build_key("h", b), page_set_build_key("h", c));
  // With one bounce the bounce gather is unused and must not split the cache.
  OpenOptions d = a;
  d.bounce.gather.microbuffer_resolution = 16;
  EXPECT_EQ(page_set_build_key("h", a), page_set_build_key("h", d));
}

TEST(BuildKey, BounceSplattingOptionsChangeTheKey) {
  OpenOptions on;
  on.bounce.bounces = 2;
  ASSERT_TRUE(on.bounce.splatting);  // the default
  OpenOptions off = on;
  off.bounce.splatting = false;
  EXPECT_NE(page_set_build_key("h", on), page_set_build_key("h", off));
  OpenOptions wider = on;
  wider.bounce.view_solid_angle = 0.03f;
  EXPECT_NE(page_set_build_key("h", on), page_set_build_key("h", wider));
  // "auto" is its resolved value: one set for both spellings.
  OpenOptions explicit_auto = on;
  explicit_auto.bounce.view_solid_angle = on.bounce.effective_view_solid_angle();
  EXPECT_EQ(page_set_build_key("h", on), page_set_build_key("h", explicit_auto));
  // Without splatting its view solid angle is unused.
  OpenOptions off_wider = off;
  off_wider.bounce.view_solid_angle = 0.03f;
  EXPECT_EQ(page_set_build_key("h", off), page_set_build_key("h", off_wider));
  // With one bounce nothing is gathered: no split of the cache.
  OpenOptions one, one_off;
  one_off.bounce.splatting = false;
  EXPECT_EQ(page_set_build_key("h", one), page_set_build_key("h", one_off));
}

TEST(BuildKey, CoarseBounceOptionsChangeTheKey) {
  OpenOptions full;
  full.bounce.bounces = 3;
  full.bounce.receiver_stride = 1;
  full.bounce.gather.microbuffer_resolution = 8;
  full.bounce.gather.max_solid_angle = 0.03f;
  const std::string k = page_set_build_key("h", full);
  OpenOptions sparse = full;
  sparse.bounce.receiver_stride = 8;
  EXPECT_NE(page_set_build_key("h", sparse), k);
  OpenOptions sparser = full;
  sparser.bounce.receiver_stride = 16;
  EXPECT_NE(page_set_build_key("h", sparser), page_set_build_key("h", sparse));
  OpenOptions coarse_mb = full;
  coarse_mb.bounce.gather.microbuffer_resolution = 4;
  EXPECT_NE(page_set_build_key("h", coarse_mb), k);
  OpenOptions coarse_cut = full;
  coarse_cut.bounce.gather.max_solid_angle = 0.1f;
  EXPECT_NE(page_set_build_key("h", coarse_cut), k);
  // One bounce gathers nothing: the bounce options do not split the cache.
  OpenOptions one, one_sparse;
  one_sparse.bounce.receiver_stride = 8;
  one_sparse.bounce.gather.microbuffer_resolution = 4;
  one_sparse.bounce.gather.max_solid_angle = 0.1f;
  EXPECT_EQ(page_set_build_key("h", one), page_set_build_key("h", one_sparse));
}

TEST(BuildKey, GlossySenderOptionsChangeTheKeyButTheirDefaultsDoNot) {
  const OpenOptions a;
  const std::string k = page_set_build_key("h", a);
  OpenOptions b = a;
  b.surfels.glossy_roughness = 0.f;
  EXPECT_NE(page_set_build_key("h", b), k);
  OpenOptions c = a;
  c.tree.glossy_resolution = 8;
  EXPECT_NE(page_set_build_key("h", c), k);
  OpenOptions d = a;
  d.tree.wavelet_threshold = 0.01f;
  EXPECT_NE(page_set_build_key("h", d), k);
}

TEST(BuildKey, LeafFormatChangesTheKeyButItsDefaultDoesNot) {
  const OpenOptions a;
  OpenOptions explicit_default = a;
  explicit_default.tree.leaf_format = storage::LeafFormat::kRelative;
  EXPECT_EQ(page_set_build_key("h", explicit_default), page_set_build_key("h", a));
  OpenOptions half = a;
  half.tree.leaf_format = storage::LeafFormat::kHalf;
  EXPECT_NE(page_set_build_key("h", half), page_set_build_key("h", a));
}

// Keys computed by the build key code before the options tables existed
// (main at 1833fb7), re-pinned when kPageSetFormatVersion became 4 (page
// format V4: every key changed on purpose, so V2 page sets are rebuilt)
// 5 (V6 pages: compact records, rounded payloads), 6 (V8 pages:
// rounded bounds, compact page frame), 7 (air regions) and 8 (V10 pages):
// cached page sets keep their keys, byte for byte.
TEST(BuildKey, KeysOfExistingOptionsArePinned) {
  const std::string scene = "0123456789abcdef";
  EXPECT_EQ(page_set_build_key(scene, OpenOptions()), "36935898b991600f5c5e53f2977e3817");
  OpenOptions a;
  a.surfels.spacing = 0.013f;
  a.surfels.target_surfels = 12345;
  a.surfels.light_samples = 9;
  a.surfels.seed = 42;
  a.tree.leaf_size = 8;
  a.tree.page_size = 32768;
  EXPECT_EQ(page_set_build_key(scene, a), "e3aafb0fdbbf7bdd24c533d4f3b452b2");
  OpenOptions b;
  b.surfels.sampler = SurfelSampler::kPoisson;
  b.surfels.camera = "/World/Camera";
  b.surfels.image_width = 640;
  b.surfels.image_height = 360;
  b.surfels.pixel_footprint = 1.5f;
  b.surfels.glossy_roughness = 0.2f;
  b.tree.glossy_resolution = 32;
  b.tree.wavelet_threshold = 0.05f;
  b.tree.leaf_format = storage::LeafFormat::kHalf;
  EXPECT_EQ(page_set_build_key(scene, b), "b75c285ea4839197c94e24e22c5c990f");
  OpenOptions c;
  c.tree.payload_codec = tree::PayloadCodecOption::kQuantizedSh;
  c.tree.lut_entries = 1000;
  c.tree.lut_sample_fraction = 0.05;
  c.bounce.bounces = 3;
  c.bounce.splatting = true;
  c.bounce.view_solid_angle = 0.02f;
  c.bounce.receiver_stride = 4;
  c.bounce.gather.microbuffer_resolution = 16;
  c.bounce.gather.max_solid_angle = 0.05f;
  EXPECT_EQ(page_set_build_key(scene, c), "f965971740632aaed313567a885cec57");
  // Fog and the default lights are not in the page set (the lights reach
  // it through the scene's content hash).
  OpenOptions e;
  e.tree.payload_codec = tree::PayloadCodecOption::kFloatSh;
  e.bounce.bounces = 2;
  e.bounce.splatting = false;
  e.bounce.receiver_stride = 1;
  e.default_light = true;
  e.fog.extinction_per_density = 3.f;
  EXPECT_EQ(page_set_build_key(scene, e), "c02f32d1406a81024ec6b327b2870584");
}

// Build-key membership is what the tables say: every option marked as a
// member changes the key (where its group applies: a learned LUT, a camera,
// bounce gathers with splatting), every other one does not.
TEST(BuildKey, MembershipFollowsTheOptionsTables) {
  OpenOptions context;
  context.tree.payload_codec = tree::PayloadCodecOption::kQuantizedSh;
  context.surfels.sampler = SurfelSampler::kPoisson;
  context.surfels.camera = "/Camera";
  context.bounce.bounces = 2;
  const std::string base = page_set_build_key("h", context);
  int members = 0, others = 0;
  options::for_each_field(kOpenOptionTable, [&](const auto& probe) {
    OpenOptions changed = context;
    // The probe's own field, found again by walking to it with its name.
    options::for_each_value(
        kOpenOptionTable,
        [&](const auto& f, auto& values) {
          if constexpr (std::is_same_v<std::remove_cvref_t<decltype(f)>, std::remove_cvref_t<decltype(probe)>>) {
            if (f.name == probe.name && f.get == probe.get) f.set(values, testing::perturbed(f.get(values)));
          }
        },
        changed);
    const bool keyed = probe.spec.key != options::KeyMember::kNo;
    (keyed ? members : others)++;
    if (keyed) {
      EXPECT_NE(page_set_build_key("h", changed), base) << probe.name << " is a member but does not change the key";
    } else {
      EXPECT_EQ(page_set_build_key("h", changed), base) << probe.name << " is not a member but changes the key";
    }
  });
  EXPECT_GT(members, 20);
  EXPECT_GT(others, 3);  // default_light and the fog
}

}  // namespace
}  // namespace pbgi
